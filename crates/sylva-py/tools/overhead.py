"""Python's overhead over the Rust API: the best wall time of
``sylva.Recipe.preset(name).grow()`` against the Rust example ``grow_time`` (the same
``sylva::pipeline::grow``), interleaved in rounds so both see the same machine load.

    cargo build --release -p sylva-py --example grow_time
    python crates/sylva-py/tools/overhead.py wp-quaking-aspen 5 10
"""

import subprocess
import sys
import time
from pathlib import Path

import sylva

ROOT = Path(__file__).resolve().parents[3]


def python_best(name: str, runs: int) -> "tuple[float, float]":
    """Best wall time of a grow from Python and best sum of its stage times,
    milliseconds (the tree dropped untimed)."""
    recipe = sylva.Recipe.preset(name)
    recipe.grow()
    best = stages = float("inf")
    for _ in range(runs):
        t = time.perf_counter()
        tree = recipe.grow()
        best = min(best, time.perf_counter() - t)
        stages = min(stages, sum(tree.report["stage_times"].values()))
        del tree
    return best * 1e3, stages * 1e3


def main() -> None:
    name = sys.argv[1] if len(sys.argv) > 1 else "wp-quaking-aspen"
    rounds = int(sys.argv[2]) if len(sys.argv) > 2 else 5
    runs = int(sys.argv[3]) if len(sys.argv) > 3 else 10
    exe = ROOT / "target" / "release" / "examples" / "grow_time"
    rust, py = [], []
    for _ in range(rounds):
        cmd = [str(exe), name, str(runs)]
        out = subprocess.run(cmd, capture_output=True, text=True, check=True)
        rust.append(tuple(map(float, out.stdout.split())))
        py.append(python_best(name, runs))
    r, p = min(x[0] for x in rust), min(x[0] for x in py)
    rs, ps = min(x[1] for x in rust), min(x[1] for x in py)
    print(f"{name}: Rust {r:.1f} ms (stages {rs:.1f}), Python {p:.1f} ms (stages {ps:.1f})")
    print(f"overhead of the call: {(p / r - 1) * 100:+.1f} %")


if __name__ == "__main__":
    main()
