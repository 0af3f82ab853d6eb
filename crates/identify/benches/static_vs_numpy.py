#!/usr/bin/env python3
"""Whole-process benchmark of the CN105397560 static pipeline (issue 12, performance):
`gearcomp fit --model static --classes 6 --target ch1_um ch3_um ch5_um` (embedded FL_THERMAL)
against the same steps scripted in numpy (`numpy_static.py`, reading the same gzip file),
each run as a fresh process, alternately, in one run; medians and their ratio. Also the full
default `gearcomp fit` (every family and validation, five targets) against 1 s.

Usage (from the repository root, after `cargo build --release -p gearcomp`):
    python3 crates/identify/benches/static_vs_numpy.py [path/to/gearcomp] [repeats]
"""
import os
import resource
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
# The same data as a plain CSV file, as a user passes a log with --data (no decompression).
PLAIN = "target/fl_thermal_bench.csv"
RUST_STATIC_CSV = RUST_STATIC + ["--data", PLAIN]
NUMPY_STATIC_CSV = [sys.executable, f"{HERE}/numpy_static.py", PLAIN]


CPU = {}


# numpy with one BLAS thread: on this shared 2-core machine OpenBLAS's worker threads spin
# for a core and made the numpy side slower and far more variable (0.6–1.6 s against
# 0.40–0.49 s wall), which would flatter the ratio. The baseline is numpy at its best here.
NUMPY_ENV = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1", MKL_NUM_THREADS="1")


def once(cmd):
    """Wall time of one fresh process; its CPU time (user + system, all threads) is kept in
    CPU under the command (less sensitive to other load on the machine than wall time)."""
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    env = NUMPY_ENV if cmd[0] == sys.executable else None
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, env=env)
    wall = time.perf_counter() - t
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
    CPU.setdefault(tuple(cmd), []).append(cpu)
    return wall


def main():
    import gzip
    with gzip.open("crates/datasets/data/fl_thermal.csv.gz", "rb") as f, open(PLAIN, "wb") as g:
        g.write(f.read())
    for cmd in (RUST_STATIC, NUMPY_STATIC, RUST_STATIC_CSV, NUMPY_STATIC_CSV, RUST_DEFAULT):
        once(cmd)  # warm the page cache
    rust, numpy, rust_csv, numpy_csv, default = [], [], [], [], []
    for _ in range(REPEATS):
        rust.append(once(RUST_STATIC))
        numpy.append(once(NUMPY_STATIC))
        rust_csv.append(once(RUST_STATIC_CSV))
        numpy_csv.append(once(NUMPY_STATIC_CSV))
    for _ in range(max(3, REPEATS // 3)):
        default.append(once(RUST_DEFAULT))
    r, n, rc, nc, d = (statistics.median(v) for v in (rust, numpy, rust_csv, numpy_csv, default))
    spread = lambda v: f"{min(v) * 1e3:.1f}–{max(v) * 1e3:.1f}"
    cpu = lambda cmd: statistics.median(CPU[tuple(cmd)][1:])
    print(f"load average {os.getloadavg()[0]:.2f} (1 min) at the end")
    print(f"static pipeline, whole process, median of {REPEATS}:")
    print(f"  embedded gzip: gearcomp {r * 1e3:7.1f} ms, numpy (same .csv.gz) {n * 1e3:7.1f} ms: "
          f"{n / r:.1f}x (target >= 20x)")
    print(f"  plain CSV (--data): gearcomp {rc * 1e3:7.1f} ms, numpy {nc * 1e3:7.1f} ms: {nc / rc:.1f}x")
    print(f"  range of the wall times: gearcomp gzip {spread(rust)}, numpy gzip {spread(numpy)}, "
          f"gearcomp CSV {spread(rust_csv)}, numpy CSV {spread(numpy_csv)} ms")
    cr, cn, crc, cnc = (cpu(c) for c in (RUST_STATIC, NUMPY_STATIC, RUST_STATIC_CSV, NUMPY_STATIC_CSV))
    print(f"  CPU time (user + system, all threads), medians: embedded gzip gearcomp {cr * 1e3:.1f} ms, "
          f"numpy {cn * 1e3:.1f} ms: {cn / cr:.1f}x; plain CSV gearcomp {crc * 1e3:.1f} ms, "
          f"numpy {cnc * 1e3:.1f} ms: {cnc / crc:.1f}x")
    print(f"default gearcomp fit (every family, 5 targets), median of {len(default)}: "
          f"{d * 1e3:.0f} ms (budget 1000 ms)")


if __name__ == "__main__":
    main()
