#!/usr/bin/env python3
"""Independent numpy implementation of the model families of `gearcomp fit --model auto`
(crates/identify/src/select.rs, `evaluate_fixed`): regressor transforms restarted per run,
deployment validation (rolling origin on one run, leave-one-run-out on runs), OLS / ridge /
PCR fitted directly on the rows of each fold (no QR reduction), final fit on all training rows;
and the classes family (`evaluate_classes`): fuzzy-equivalence classes by the max-min
transitive closure of |r| (not single linkage) and representatives formed on each fold's
training rows.

Usage: python3 families.py fl_thermal.csv > families.json
(fl_thermal.csv = gunzipped crates/datasets/data/fl_thermal.csv.gz). Needs numpy only.
"""
import json
import sys

import numpy as np

SPECS = [
    # name, [(sensor, minus, kind, param)], fit
    ("static", [(3, None, "value", 0), (4, None, "value", 0), (5, None, "value", 0), (10, None, "value", 0)], ("ols", 0)),
    ("ridge", [(3, None, "value", 0), (4, None, "value", 0), (5, None, "value", 0), (10, None, "value", 0), (13, None, "value", 0)], ("ridge", 0.01)),
    ("pcr", [(3, None, "value", 0), (4, None, "value", 0), (5, None, "value", 0), (10, None, "value", 0), (13, None, "value", 0)], ("pcr", 3)),
    ("lead_lag", [(3, None, "value", 0), (3, None, "lag", 2400.0), (5, None, "value", 0), (5, None, "lag", 2400.0), (8, None, "value", 0), (8, None, "lag", 2400.0)], ("ols", 0)),
    ("tf1", [(3, None, "value", 0), (3, None, "lag", 7200.0), (5, None, "value", 0), (5, None, "lag", 600.0), (10, None, "value", 0), (10, None, "lag", 1800.0)], ("ols", 0)),
    ("tf2", [(4, None, "value", 0), (4, None, "lag", 300.0), (4, None, "lag", 3600.0), (8, None, "value", 0), (8, None, "lag", 900.0), (8, None, "lag", 7200.0)], ("ols", 0)),
    ("delay", [(3, None, "delay", 900.0), (5, None, "delay", 300.0), (9, None, "value", 0)], ("ols", 0)),
    ("differences", [(3, 5, "value", 0), (10, 12, "value", 0), (4, None, "value", 0)], ("ols", 0)),
]

# The classes family: (class count, fit).
CLASS_SPECS = [(6, ("ols", 0)), (8, ("ridge", 0.01)), (4, ("ols", 0))]


def lag(t, u, tau):
    y = np.empty_like(u)
    y[0] = u[0]
    for k in range(1, len(u)):
        a = 1.0 - np.exp(-(t[k] - t[k - 1]) / tau)
        y[k] = y[k - 1] + a * (u[k] - y[k - 1])
    return y


def transform(t, u, kind, p, segments):
    out = np.empty_like(u)
    for s, e in segments:
        ts, us = t[s:e], u[s:e]
        if kind == "value":
            out[s:e] = us
        elif kind == "lag":
            out[s:e] = lag(ts, us, p)
        elif kind == "delay":
            out[s:e] = np.interp(ts - p, ts, us)  # clamps to the oldest value
        else:
            raise ValueError(kind)
    return out


def fit(X, y, how):
    n, p = X.shape
    if how[0] == "ols":
        A = np.column_stack([np.ones(n), X])
        return np.linalg.lstsq(A, y, rcond=None)[0]
    m = X.mean(axis=0)
    sd = X.std(axis=0)  # population sd
    Z = (X - m) / sd
    yc = y - y.mean()
    if how[0] == "ridge":
        A = np.vstack([Z, np.sqrt(how[1] * n) * np.eye(p)])
        beta = np.linalg.lstsq(A, np.concatenate([yc, np.zeros(p)]), rcond=None)[0]
    else:
        U, S, Vt = np.linalg.svd(Z, full_matrices=False)
        k = how[1]
        beta = Vt[:k].T @ ((U[:, :k].T @ yc) / S[:k])
    b = beta / sd
    return np.concatenate([[y.mean() - b @ m], b])


def closure_classes(X, k):
    """CN105397560 fuzzy equivalence: |r| as a fuzzy similarity relation, its max-min
    transitive closure (squared until it no longer changes), cut at the level that leaves
    k classes; classes ordered by their first member."""
    R = np.abs(np.corrcoef(X, rowvar=False))
    while True:
        T = np.max(np.minimum(R[:, :, None], R[None, :, :]), axis=1)
        T = np.maximum(T, R)
        if np.array_equal(T, R):
            break
        R = T
    c = R.shape[0]
    levels = sorted(set(R[np.triu_indices(c, 1)].tolist()), reverse=True)
    for lam in [np.inf] + levels:
        classes = []
        seen = set()
        for i in range(c):
            if i not in seen:
                cl = [j for j in range(c) if j == i or R[i, j] >= lam]
                seen.update(cl)
                classes.append(cl)
        if len(classes) == k:
            return classes
    raise ValueError(f"no cut leaves {k} classes (tied levels)")


def representatives(X, y, classes):
    r = [abs(np.corrcoef(X[:, i], y)[0, 1]) for i in range(X.shape[1])]
    return [max(cl, key=lambda i: (r[i], -i)) for cl in classes]


def evaluate_classes(X, y, blocks, folds, k, how):
    fold_rmse, fold_reps, sse, nval = [], [], 0.0, 0
    for tr_blocks, va in folds:
        tr = np.isin(blocks, tr_blocks)
        vm = blocks == va
        reps = representatives(X[tr], y[tr], closure_classes(X[tr], k))
        b = fit(X[tr][:, reps], y[tr], how)
        e = y[vm] - b[0] - X[vm][:, reps] @ b[1:]
        fold_rmse.append(float(np.sqrt(np.mean(e * e))))
        fold_reps.append(reps)
        sse += float(e @ e)
        nval += int(vm.sum())
    return fold_rmse, fold_reps, float(np.sqrt(sse / nval))


def evaluate(t, X, y, blocks, folds, how):
    fold_rmse, sse, nval = [], 0.0, 0
    for tr_blocks, va in folds:
        tr = np.isin(blocks, tr_blocks)
        vm = blocks == va
        b = fit(X[tr], y[tr], how)
        e = y[vm] - b[0] - X[vm] @ b[1:]
        fold_rmse.append(float(np.sqrt(np.mean(e * e))))
        sse += float(e @ e)
        nval += int(vm.sum())
    return fold_rmse, float(np.sqrt(sse / nval))


def main():
    d = np.genfromtxt(sys.argv[1], delimiter=",", names=True)
    t = d["time_s"]
    inputs = np.column_stack([d[f"t{i}_c"] for i in range(1, 17)])
    y = d["ch3_um"]
    out = {"target": "ch3_um", "cases": [], "classes_cases": []}
    # Case 1: one run, train t < 86400 s, rolling origin: 3 folds over 4 blocks.
    # Case 2: 8 h pseudo-runs (run = floor(t / 28800)), the last run tests,
    #         leave-one-run-out over the 5 training runs; every filter restarts per run.
    run = np.floor(t / 28800.0).astype(int)
    for case in ("rolling", "runs"):
        if case == "rolling":
            train = t < 86400.0
            segments = [(0, len(t))]
            tt = t[train]
            t0, t1 = tt.min(), tt.max()
            span = (t1 - t0) / 4
            blocks = np.minimum(np.floor((tt - t0) / span).astype(int), 3)
            folds = [(list(range(f + 1)), f + 1) for f in range(3)]
        else:
            train = run != run.max()
            starts = [0] + [i for i in range(1, len(t)) if run[i] != run[i - 1]]
            segments = list(zip(starts, starts[1:] + [len(t)]))
            blocks = run[train]
            nb = int(blocks.max()) + 1
            folds = [([g for g in range(nb) if g != f], f) for f in range(nb)]
        for name, terms, how in SPECS:
            cols = []
            for s, minus, kind, p in terms:
                if minus is not None:
                    cols.append(inputs[:, s] - inputs[:, minus])
                else:
                    cols.append(transform(t, inputs[:, s], kind, p, segments))
            X = np.column_stack(cols)
            Xtr, ytr = X[train], y[train]
            fold_rmse, cv = evaluate(t, Xtr, ytr, blocks, folds, how)
            coef = fit(Xtr, ytr, how)
            out["cases"].append({
                "scheme": case,
                "family": name,
                "terms": [[s, minus, kind, p] for s, minus, kind, p in terms],
                "fit": [how[0], how[1]],
                "fold_rmse_um": fold_rmse,
                "cv_rmse_um": cv,
                "coefficients": [float(c) for c in coef],
            })
        # The classes family (CN105397560 inside the comparison): classes and
        # representatives formed on each fold's training rows, values only.
        V, yv = inputs[train], y[train]
        for k, how in CLASS_SPECS:
            fold_rmse, fold_reps, cv = evaluate_classes(V, yv, blocks, folds, k, how)
            reps = representatives(V, yv, closure_classes(V, k))
            coef = fit(V[:, reps], yv, how)
            out["classes_cases"].append({
                "scheme": case,
                "classes": k,
                "fit": [how[0], how[1]],
                "representatives": reps,
                "fold_representatives": fold_reps,
                "fold_rmse_um": fold_rmse,
                "cv_rmse_um": cv,
                "coefficients": [float(c) for c in coef],
            })
    json.dump(out, sys.stdout, indent=1)


if __name__ == "__main__":
    main()
