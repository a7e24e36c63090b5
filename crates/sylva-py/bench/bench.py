"""The Python benchmarks of BENCHMARKS.md ("Python (issue 42)").

``overhead``: ``sylva.Recipe.preset(name).grow()`` from Python against
``sylva::pipeline::grow`` in a Rust binary (``crates/sylva-py/examples/grow_time.rs``),
the same preset, N grows each, in interleaved rounds so both see the same machine
load: each round takes the best of N grows on each side; prints the median over the
rounds and the best of all, and Python's overhead for both.
Build the Rust side from the same tree as the installed package first::

    cargo build --release -p sylva-py --example grow_time
    python crates/sylva-py/bench/bench.py overhead --preset wp-quaking-aspen --rounds 10 --runs 5

``batch``: ``sylva.batch.run`` of ``--count`` trees (one preset, seeds 0…count−1)
serially in this process, then on a ``LocalCluster`` of ``--workers`` processes with one
thread each; prints trees/s of both, the CPU seconds per tree (the processes' user +
system time: this one's, and the workers'), and checks that the two manifests agree (every
file's SHA-256, all but the times). The trees are written into a temporary folder and
deleted after each run::

    python crates/sylva-py/bench/bench.py batch --preset lsys-honda-a --count 1000 --workers 2

``uptime``'s load average is printed before and after each measurement: other work on
the machine slows either side.
"""

import argparse
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import sylva
import sylva.batch

ROOT = Path(__file__).resolve().parents[3]


def load() -> str:
    """The 1-minute load average and the core count."""
    return f"load {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores"


def python_best(name: str, runs: int) -> float:
    """The best wall time (ms) of ``runs`` grows of preset ``name`` from Python, after
    one untimed warm-up grow; each tree is dropped outside the timed span (as
    ``grow_time`` does)."""
    recipe = sylva.Recipe.preset(name)
    recipe.grow()
    best = float("inf")
    for _ in range(runs):
        t = time.perf_counter()
        tree = recipe.grow()
        best = min(best, time.perf_counter() - t)
        del tree
    return best * 1e3


def rust_best(exe: Path, name: str, runs: int) -> float:
    """The best wall time (ms) of ``runs`` grows by the Rust example ``grow_time``
    (its first number; it warms up with one untimed grow too)."""
    out = subprocess.run([str(exe), name, str(runs)], capture_output=True, text=True, check=True)
    return float(out.stdout.split()[0])


def overhead(a: argparse.Namespace) -> None:
    exe = ROOT / "target" / "release" / "examples" / "grow_time"
    if not exe.is_file():
        sys.exit(f"{exe} is missing: cargo build --release -p sylva-py --example grow_time")
    print(f"start: {load()}")
    rust, py = [], []
    for _ in range(a.rounds):
        rust.append(rust_best(exe, a.preset, a.runs))
        py.append(python_best(a.preset, a.runs))
    print(f"end: {load()}")
    rm, pm = statistics.median(rust), statistics.median(py)
    rb, pb = min(rust), min(py)
    print(f"{a.preset}: {a.rounds} rounds × best of {a.runs} grows, Rust and Python interleaved")
    print(f"  Rust sylva::pipeline::grow  median {rm:.1f} ms, best {rb:.1f} ms")
    print(f"  Python Recipe.grow()        median {pm:.1f} ms, best {pb:.1f} ms")
    print(f"  overhead: median {(pm / rm - 1) * 100:+.1f} %, best {(pb / rb - 1) * 100:+.1f} %")
    print(f"  rounds (Rust / Python, ms): {[f'{r:.0f}/{q:.0f}' for r, q in zip(rust, py)]}")


def cpu_seconds() -> float:
    """User + system CPU seconds of this process so far (all its threads)."""
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def batch_run(jobs: list, client, keep: Path) -> "tuple[sylva.batch.BatchResult, float]":
    """The batch's result and the CPU seconds it took: this process's (the serial
    grows; on a LocalCluster, the client and its in-process scheduler) plus the
    workers'."""
    out = Path(tempfile.mkdtemp(prefix="sylva-bench-"))

    def workers() -> float:
        return sum(client.run(cpu_seconds).values()) if client is not None else 0.0

    try:
        here, there = cpu_seconds(), workers()
        result = sylva.batch.run(jobs, out, client=client)
        here, there = cpu_seconds() - here, workers() - there
        cpu = here + there
        n = len(result.rows)
        print(
            f"  CPU per tree: this process {here / n * 1e3:.0f} ms, "
            f"workers {there / n * 1e3:.0f} ms"
        )
        task = statistics.mean(r["seconds"] for r in result.rows)
        print(f"  mean task wall time (grow + write, the manifest's seconds): {task * 1e3:.0f} ms")
        shutil.copy(result.manifest, keep)
        return result, cpu
    finally:
        shutil.rmtree(out, ignore_errors=True)


def batch(a: argparse.Namespace) -> None:
    from dask.distributed import Client, LocalCluster

    jobs = [(a.preset, seed) for seed in range(a.count)]
    keep = Path(tempfile.mkdtemp(prefix="sylva-bench-manifests-"))
    print(f"serial start: {load()}")
    serial, serial_cpu = batch_run(jobs, None, keep / "serial.jsonl")
    print(f"serial end: {load()}")
    print(
        f"serial: {a.count} × {a.preset} in {serial.seconds:.1f} s = "
        f"{serial.trees_per_second:.2f} trees/s; CPU {serial_cpu / a.count * 1e3:.0f} ms per tree"
    )
    with (
        LocalCluster(
            n_workers=a.workers, threads_per_worker=1, processes=True, dashboard_address=None
        ) as cluster,
        Client(cluster) as client,
    ):
        client.run(lambda: __import__("sylva.batch"))  # workers import sylva before timing
        print(f"dask start: {load()}")
        dask, dask_cpu = batch_run(jobs, client, keep / "dask.jsonl")
        print(f"dask end: {load()}")
    print(
        f"LocalCluster({a.workers} workers × 1 thread): {a.count} × {a.preset} in "
        f"{dask.seconds:.1f} s = {dask.trees_per_second:.2f} trees/s "
        f"({dask.trees_per_second / serial.trees_per_second:.2f}× serial); "
        f"CPU {dask_cpu / a.count * 1e3:.0f} ms per tree"
    )

    def rows(path: Path) -> list:
        out = [json.loads(line) for line in path.read_text().splitlines()]
        for r in out:
            del r["seconds"]
        return out

    same = rows(keep / "serial.jsonl") == rows(keep / "dask.jsonl")
    size = sum(r["bytes"] for r in serial.rows)
    print(f"manifests equal minus times: {same}; {size / 1e9:.2f} GB written per run")
    shutil.rmtree(keep, ignore_errors=True)
    if not same:
        sys.exit("the Dask batch differs from the serial one")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = p.add_subparsers(dest="what", required=True)
    o = sub.add_parser("overhead", help="Python's overhead over the Rust API")
    o.add_argument("--preset", default="wp-quaking-aspen")
    o.add_argument("--rounds", type=int, default=10)
    o.add_argument("--runs", type=int, default=5)
    b = sub.add_parser("batch", help="a batch serially and on a LocalCluster")
    b.add_argument("--preset", default="lsys-honda-a")
    b.add_argument("--count", type=int, default=1000)
    b.add_argument("--workers", type=int, default=2)
    a = p.parse_args()
    overhead(a) if a.what == "overhead" else batch(a)


if __name__ == "__main__":
    main()
