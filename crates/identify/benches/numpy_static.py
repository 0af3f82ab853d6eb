#!/usr/bin/env python3
"""The CN105397560 static pipeline scripted in numpy: the baseline of the
whole-process benchmark `static_vs_numpy.py` (issue 12, performance).

Same steps as `gearcomp fit --model static --classes 6 --target ch1_um ch3_um ch5_um` on the
FL_THERMAL data: decompress and parse the CSV, check the rows (finite, time increasing, gaps),
split at 24 h, drop constant/duplicated inputs, correlation matrix of the inputs on the
training rows, 6 classes by single linkage on |r| (= the fuzzy-equivalence λ-cut), the
representative of each class (largest |r| with the target), least squares with standard
errors (QR), R², train/test RMSE, 3-fold validation by contiguous time blocks, plain least
squares on all inputs, the Mahalanobis training envelope and 95 % prediction intervals, and
a text report.

Usage: python3 numpy_static.py [fl_thermal.csv.gz | plain.csv]   (needs numpy only)
"""
import gzip
import sys

import numpy as np

PATH = sys.argv[1] if len(sys.argv) > 1 else "crates/datasets/data/fl_thermal.csv.gz"
TARGETS = ["ch1_um", "ch3_um", "ch5_um"]
CLASSES = 6
FOLDS = 3
SPLIT_S = 86_400.0


def single_linkage_classes(absr, k):
    """Classes of single linkage on similarity |r| cut to k classes (maximum spanning tree)."""
    n = absr.shape[0]
    parent = list(range(n))

    def find(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    iu = np.triu_indices(n, 1)
    order = np.lexsort((iu[1], iu[0], -absr[iu]))
    groups = n
    for e in order:
        if groups == k:
            break
        a, b = find(iu[0][e]), find(iu[1][e])
        if a != b:
            parent[max(a, b)] = min(a, b)
            groups -= 1
    roots = {}
    for i in range(n):
        roots.setdefault(find(i), []).append(i)
    return sorted(roots.values())


def ols(X, y):
    A = np.column_stack([np.ones(len(y)), X])
    q, r = np.linalg.qr(A)
    b = np.linalg.solve(r, q.T @ y)
    e = y - A @ b
    dof = len(y) - A.shape[1]
    s2 = e @ e / dof
    rinv = np.linalg.inv(r)
    se = np.sqrt(s2 * np.sum(rinv * rinv, axis=1))
    return b, se, e


def main():
    with (gzip.open(PATH, "rt") if PATH.endswith(".gz") else open(PATH)) as f:
        header = f.readline().strip().split(",")
        data = np.loadtxt(f, delimiter=",")
    col = {h: i for i, h in enumerate(header)}
    if not np.all(np.isfinite(data)):
        raise SystemExit("non-finite cells")
    t = data[:, col["time_s"]]
    dt = np.diff(t)
    if np.any(dt <= 0):
        raise SystemExit("time not increasing")
    gaps = int(np.sum(dt > 3 * np.median(dt)))
    inputs = [h for h in header if h.endswith("_c")]
    X = data[:, [col[h] for h in inputs]]
    train = t < SPLIT_S
    test = ~train
    Xtr = X[train]
    # Drop constant or duplicated inputs (|r| = 1).
    keep = [j for j in range(X.shape[1]) if np.ptp(Xtr[:, j]) > 0]
    corr = np.corrcoef(Xtr[:, keep], rowvar=False)
    dup = {keep[b] for a in range(len(keep)) for b in range(a + 1, len(keep)) if abs(corr[a, b]) >= 1 - 1e-12}
    keep = [j for j in keep if j not in dup]
    X, Xtr = X[:, keep], Xtr[:, keep]
    names = [inputs[j] for j in keep]
    corr = np.corrcoef(Xtr, rowvar=False)
    classes = single_linkage_classes(np.abs(corr), CLASSES)
    # Contiguous time blocks of equal span over the training period.
    ttr = t[train]
    span = (ttr.max() - ttr.min()) / FOLDS
    block = np.minimum(((ttr - ttr.min()) // span).astype(int), FOLDS - 1)
    print(f"data: {PATH}: {len(t)} rows, {len(names)} inputs, {len(TARGETS)} targets; "
          f"{train.sum()} training rows, {test.sum()} test rows; {gaps} gaps")
    for tg in TARGETS:
        y = data[:, col[tg]]
        ytr = y[train]
        yc = ytr - ytr.mean()
        Xc = Xtr - Xtr.mean(axis=0)
        r_y = np.abs(Xc.T @ yc) / np.sqrt(np.sum(Xc * Xc, axis=0) * (yc @ yc))
        reps = sorted(max(c, key=lambda j: (r_y[j], -j)) for c in classes)
        b, se, e = ols(Xtr[:, reps], ytr)
        pred = b[0] + X[:, reps] @ b[1:]
        r2 = 1 - (e @ e) / (yc @ yc)
        rm_tr = np.sqrt(np.mean((y[train] - pred[train]) ** 2))
        rm_te = np.sqrt(np.mean((y[test] - pred[test]) ** 2))
        sse, folds = 0.0, []
        for k in range(FOLDS):
            v = block == k
            bk, _, _ = ols(Xtr[~v][:, reps], ytr[~v])
            ek = ytr[v] - bk[0] - Xtr[v][:, reps] @ bk[1:]
            sse += ek @ ek
            folds.append(np.sqrt(np.mean(ek * ek)))
        cv = np.sqrt(sse / len(ytr))
        ball, _, eall = ols(Xtr, ytr)
        pall = ball[0] + X @ ball[1:]
        ls_tr = np.sqrt(np.mean(eall * eall))
        ls_te = np.sqrt(np.mean((y[test] - pall[test]) ** 2))
        # Envelope: channel ranges and the Mahalanobis bound on the regressors.
        F = Xtr[:, reps]
        mu = F.mean(axis=0)
        _, rr = np.linalg.qr(F - mu)
        w = np.sqrt(len(F) - 1) * np.linalg.inv(rr).T
        d2 = np.sum(((X[:, reps] - mu) @ w.T) ** 2, axis=1)
        bound = d2[train].max()
        lo, hi = F.min(axis=0), F.max(axis=0)
        out = (d2 > bound) | np.any((X[:, reps] < lo) | (X[:, reps] > hi), axis=1)
        h = 1 / len(F) + d2 / (len(F) - 1)
        half = 1.96 * cv * np.sqrt(1 + h)
        print(f"\n{tg}: {CLASSES} classes; {len(reps)} sensor(s): {', '.join(names[j] for j in reps)}")
        print(f"  RMSE µm: train {rm_tr:.3f}, test {rm_te:.3f}, validation {cv:.3f} "
              f"(folds: {', '.join(f'{v:.3f}' for v in folds)}); R² = {r2:.4f}")
        print(f"  plain least squares on all {len(names)} inputs: train {ls_tr:.3f}, test {ls_te:.3f} µm")
        print(f"  extrapolation: {int(out[test].sum())} of {test.sum()} test rows outside the training "
              f"envelope; 95 % prediction interval ± {half[test].mean():.3f} µm on average")
        print(f"  {'term':<40}{'coefficient':>12}{'std. error':>15}")
        for name, c, s in zip(["intercept"] + [names[j] for j in reps], b, se):
            print(f"  {name:<40}{c:>12.6g}{s:>15.5g}")


if __name__ == "__main__":
    main()
