#!/usr/bin/env python3
"""Whole-process benchmark of the seed 003 static pipeline (issue 12, performance):
`gearcomp fit --model static --classes 6 --target ch1_um ch3_um ch5_um` (embedded FL_THERMAL)
against the same steps scripted in numpy (`numpy_static.py`, reading the same gzip file),
each run as a fresh process, alternately, in one run; medians and their ratio. Also the full
default `gearcomp fit` (every family and validation, five targets) against 1 s.

Usage (from the repository root, after `cargo build --release -p gearcomp`):
    python3 crates/identify/benches/static_vs_numpy.py [path/to/gearcomp] [repeats]
"""
import statistics
import subprocess
import sys
import time

GEARCOMP = sys.argv[1] if len(sys.argv) > 1 else "target/release/gearcomp"
REPEATS = int(sys.argv[2]) if len(sys.argv) > 2 else 15
HERE = "crates/identify/benches"

RUST_STATIC = [GEARCOMP, "fit", "--model", "static", "--classes", "6",
               "--target", "ch1_um", "ch3_um", "ch5_um"]
NUMPY_STATIC = [sys.executable, f"{HERE}/numpy_static.py", "crates/datasets/data/fl_thermal.csv.gz"]
RUST_DEFAULT = [GEARCOMP, "fit"]


def once(cmd):
    t = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    return time.perf_counter() - t


def main():
    for cmd in (RUST_STATIC, NUMPY_STATIC, RUST_DEFAULT):
        once(cmd)  # warm the page cache
    rust, numpy, default = [], [], []
    for _ in range(REPEATS):
        rust.append(once(RUST_STATIC))
        numpy.append(once(NUMPY_STATIC))
    for _ in range(max(3, REPEATS // 3)):
        default.append(once(RUST_DEFAULT))
    r, n, d = (statistics.median(v) for v in (rust, numpy, default))
    print(f"static pipeline, whole process, median of {REPEATS}:")
    print(f"  gearcomp fit --model static --classes 6 (3 targets): {r * 1e3:8.1f} ms")
    print(f"  numpy script, same steps:                             {n * 1e3:8.1f} ms")
    print(f"  speed-up: {n / r:.1f}x (target >= 20x)")
    print(f"default gearcomp fit (every family, 5 targets), median of {len(default)}: "
          f"{d * 1e3:.0f} ms (budget 1000 ms)")


if __name__ == "__main__":
    main()
