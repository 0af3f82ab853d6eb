#!/usr/bin/env python3
"""Whole-process benchmark of the CN105397560 static pipeline (issue 12, performance):
`gearcomp fit --model static --classes 6 --target ch1_um ch3_um ch5_um` against the same steps
scripted in numpy (`numpy_static.py`), each run as a fresh process, alternately, in one run;
medians and their ratio.

- embedded: gearcomp on its embedded FL_THERMAL (the CSV text is stored in the binary as it is,
  inflated at build time), numpy on the same text as a plain CSV file: both parse the same
  4.4 MB of text and nothing is decompressed on either side;
- plain CSV: both read the plain CSV file (`--data`);
- for the record, numpy reading the repository's gzip copy (`.csv.gz`), the baseline of the
  earlier rounds, when gearcomp inflated its embedded copy at run time;
- the parse-only floor `target/release/examples/parse_floor`, when built: a process that reads
  the plain CSV and parses every number on every core, nothing else; numpy's time over the
  floor's is the largest ratio any whole-process fit that reads this CSV can reach here;
- the full default `gearcomp fit` (every family and validation, five targets) against 1 s.

Usage (from the repository root, after `cargo build --release -p gearcomp` and, for the floor,
`cargo build --release -p gearcomp-identify --example parse_floor`):
    python3 crates/identify/benches/static_vs_numpy.py [path/to/gearcomp] [repeats]
"""
import gzip
import os
import resource
import statistics
import subprocess
import sys
import time

GEARCOMP = sys.argv[1] if len(sys.argv) > 1 else "target/release/gearcomp"
REPEATS = int(sys.argv[2]) if len(sys.argv) > 2 else 15
HERE = "crates/identify/benches"
GZ = "crates/datasets/data/fl_thermal.csv.gz"
# The same data as a plain CSV file, as a user passes a log with --data.
PLAIN = "target/fl_thermal_bench.csv"

RUST_STATIC = [GEARCOMP, "fit", "--model", "static", "--classes", "6",
               "--target", "ch1_um", "ch3_um", "ch5_um"]
RUST_STATIC_CSV = RUST_STATIC + ["--data", PLAIN]
NUMPY_STATIC_CSV = [sys.executable, f"{HERE}/numpy_static.py", PLAIN]
NUMPY_STATIC_GZ = [sys.executable, f"{HERE}/numpy_static.py", GZ]
RUST_DEFAULT = [GEARCOMP, "fit"]
FLOOR_BIN = os.path.join(os.path.dirname(os.path.abspath(GEARCOMP)), "examples", "parse_floor")
FLOOR = [FLOOR_BIN, PLAIN]

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
    with gzip.open(GZ, "rb") as f, open(PLAIN, "wb") as g:
        g.write(f.read())
    has_floor = os.path.exists(FLOOR_BIN)
    cases = {
        "gearcomp embedded": RUST_STATIC,
        "numpy plain CSV": NUMPY_STATIC_CSV,
        "gearcomp plain CSV": RUST_STATIC_CSV,
        "numpy .csv.gz": NUMPY_STATIC_GZ,
    }
    if has_floor:
        cases["parse-only floor"] = FLOOR
    for cmd in list(cases.values()) + [RUST_DEFAULT]:
        once(cmd)  # warm the page cache
    walls = {k: [] for k in cases}
    for _ in range(REPEATS):
        for k, cmd in cases.items():
            walls[k].append(once(cmd))
    default = [once(RUST_DEFAULT) for _ in range(max(3, REPEATS // 3))]
    med = {k: statistics.median(v) for k, v in walls.items()}
    cpu = {k: statistics.median(CPU[tuple(cmd)][1:]) for k, cmd in cases.items()}
    ms = lambda v: f"{v * 1e3:6.1f} ms"
    print(f"load average {os.getloadavg()[0]:.2f} (1 min) at the end")
    print(f"static pipeline, whole process, median of {REPEATS} (range), CPU time median:")
    for k in cases:
        v = walls[k]
        print(f"  {k:20} {ms(med[k])} ({min(v) * 1e3:.1f}–{max(v) * 1e3:.1f}), CPU {ms(cpu[k])}")
    n = med["numpy plain CSV"]
    print(f"  ratio, embedded (numpy on the same text, plain CSV): {n / med['gearcomp embedded']:.1f}x "
          f"wall, {cpu['numpy plain CSV'] / cpu['gearcomp embedded']:.1f}x CPU (target >= 20x)")
    print(f"  ratio, plain CSV: {n / med['gearcomp plain CSV']:.1f}x wall, "
          f"{cpu['numpy plain CSV'] / cpu['gearcomp plain CSV']:.1f}x CPU (target >= 20x)")
    print(f"  for the record, numpy on the .csv.gz over gearcomp embedded: "
          f"{med['numpy .csv.gz'] / med['gearcomp embedded']:.1f}x")
    if has_floor:
        fl = med["parse-only floor"]
        print(f"  parse-only floor {fl / med['gearcomp plain CSV']:.2f} of gearcomp plain CSV; numpy plain CSV / "
              f"floor {n / fl:.1f}x: the most a whole-process fit reading this CSV can reach here")
    else:
        print("  (no parse-only floor: build it with "
              "`cargo build --release -p gearcomp-identify --example parse_floor`)")
    print(f"default gearcomp fit (every family, 5 targets), median of {len(default)}: "
          f"{statistics.median(default) * 1e3:.0f} ms (budget 1000 ms)")


if __name__ == "__main__":
    main()
