"""Speed that the API promises, as ratios measured inside one run: a Session re-grows a
leaf change ≥ 5× faster than a fresh grow (issue 42), and
Python threads grow trees in parallel (the GIL is released while a tree grows)."""

import hashlib
import os
import threading
import time
from concurrent.futures import ThreadPoolExecutor

import pytest

import sylva

PRESET = "wp-quaking-aspen"


def best_of(n, f):
    """The fastest of ``n`` timed calls of ``f``."""
    best = float("inf")
    for _ in range(n):
        t = time.perf_counter()
        f()
        best = min(best, time.perf_counter() - t)
    return best


def test_session_update_after_a_leaf_change_is_5x_faster_than_a_fresh_grow():
    recipe = sylva.Recipe.preset(PRESET)
    session = sylva.Session(recipe)
    first = session.run()
    assert "generate" in session.last_run
    cutoffs = iter([0.30 + 0.01 * k for k in range(1, 16)])

    def leaf_change():
        r = recipe.copy().set("leaves.alpha_cutoff", next(cutoffs))
        session.update(r)

    # The best of several runs: a shared 2-core machine's load spikes last longer than
    # one update (20 ms), so one slow sample said 4.9x once (stop 51).
    fresh = best_of(3, recipe.grow)
    update = best_of(9, leaf_change)
    assert "generate" not in session.last_run and "bark" not in session.last_run
    assert session.tree is not None and session.tree.triangles == first.triangles
    print(f"fresh grow {fresh * 1e3:.1f} ms, session update {update * 1e3:.1f} ms")
    # Issue 42 asks for 5x. Measured on the 2-core machine (stop 52): a fresh aspen grow
    # about 120 ms, the update about 11 ms (assemble..clip rerun for a material-only
    # change, sharing the kept stages' images instead of copying them).
    assert update * 5 <= fresh, f"update {update:.3f} s vs fresh grow {fresh:.3f} s"
    # The updated tree is the one a fresh grow of the same recipe makes.
    assert session.tree.to_glb() == session.recipe.grow().to_glb()


def test_four_threads_grow_faster_than_one_after_another():
    if (os.cpu_count() or 1) < 2:
        pytest.skip("one CPU: threads cannot run in parallel")
    # Each grow on one engine thread of its own (`threads=1`), so the parallelism
    # measured is that of the Python threads: it exists only if the GIL is released.
    recipe = sylva.Recipe.preset("lsys-abop-bush").set("output.textures", "none")
    seeds = [1, 2, 3, 4]

    def grow(seed):
        return recipe.grow(seed=seed, threads=1)

    def serial(grow=grow):
        return [grow(s) for s in seeds]

    # Long-lived threads, as a worker pool has: each keeps its engine thread (and that
    # thread's warm allocator arena) from one grow to the next.
    pool = ThreadPoolExecutor(len(seeds))

    def threaded(grow=grow):
        return list(pool.map(grow, seeds))

    # Timed: each tree freed by the thread that grew it (its memory back to that
    # thread's arena), as a worker that writes its tree and moves on does.
    def count(seed):
        return grow(seed).triangles

    with pool:
        glbs = [t.to_glb() for t in serial()]
        assert [t.to_glb() for t in threaded()] == glbs
        assert glbs[0] == recipe.grow(seed=1).to_glb(), "threads=1 grows the same tree"
        t_serial = best_of(5, lambda: serial(count))
        t_threads = best_of(5, lambda: threaded(count))
    ratio = t_threads / t_serial
    # What the machine allows right now: the same split of hashing, which releases the
    # GIL (on a machine busy with other work, threads cannot beat serial however free
    # the GIL is).
    calibration = parallel_capacity()
    print(
        f"4 grows: serial {t_serial * 1e3:.1f} ms, 4 threads {t_threads * 1e3:.1f} ms "
        f"(ratio {ratio:.2f}; sha256 in 4 threads: {calibration:.2f})"
    )
    if calibration >= 0.7:
        # Other work holds the CPUs: no threads can show a speed-up here (on an idle
        # machine of two or more cores, as CI's, sha256 in 4 threads takes ~0.5).
        pytest.skip(f"the CPUs are busy: sha256 in 4 threads takes {calibration:.2f} of serial")
    assert ratio < 0.8, f"threads {t_threads:.3f} s, serial {t_serial:.3f} s ({calibration:.2f})"


def parallel_capacity() -> float:
    """Time of four sha256 runs in four threads over their time one after another."""
    data = b"sylva" * (8 << 20)

    def job(_):
        return hashlib.sha256(data).digest()

    with ThreadPoolExecutor(4) as pool:
        serial = best_of(3, lambda: [job(i) for i in range(4)])
        threads = best_of(3, lambda: list(pool.map(job, range(4))))
    return threads / serial


def test_the_gil_is_released_while_a_tree_grows():
    # Python code runs on the main thread while another thread grows.
    recipe = sylva.Recipe.preset("wp-quaking-aspen")
    done = threading.Event()

    def grow():
        recipe.grow()
        done.set()

    t = threading.Thread(target=grow)
    t.start()
    ticks = 0
    while not done.is_set():
        ticks += 1
        time.sleep(0.001)
    t.join()
    assert ticks >= 10, f"the main thread ran {ticks} times during a grow"
