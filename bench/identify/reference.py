#!/usr/bin/env python3
"""Independent numpy reference for gearcomp-identify (issue 4).

Computes, with plain numpy (np.linalg.lstsq, SVD based; no code shared with the Rust crate):
  * the OLS coefficients of the CN105397560 clustering/regression vector (n = 8, c = 5);
  * the dynamic identification on FL_THERMAL (train time_s < 86400, test the rest):
    single-linkage classes on |r| (= lambda-cuts of the max-min transitive closure), one
    representative per class (max |r| with the target), Value + Rate(tau) terms per sensor,
    forward selection by k-fold-by-run cross-validation (3 contiguous blocks of the
    training period), and the final OLS coefficients and train/test RMSE per channel.

Usage:
  python3 reference.py --csv fl_thermal.csv --out golden.json   # write the golden file
  python3 reference.py --csv fl_thermal.csv --bench             # time the identification
Requires numpy only (requirements.txt).
"""
import argparse, json, sys, time
import numpy as np

TAUS_S = [300.0, 600.0, 900.0, 1200.0, 1800.0, 2400.0, 3600.0, 7200.0]
CLASS_COUNTS = [6, 8, 10, 12]
MAX_SENSORS = 8
FOLDS = 3
SPLIT_S = 86400.0


def lag(u, t, tau):
    """First-order lag, exact discretisation for piecewise-constant input, started at u[0]."""
    y = np.empty_like(u)
    y[0] = u[0]
    for k in range(1, len(u)):
        a = 1.0 - np.exp(-(t[k] - t[k - 1]) / tau)
        y[k] = y[k - 1] + a * (u[k] - y[k - 1])
    return y


def single_linkage_classes(absr, k):
    """Classes after merging the strongest |r| links until k classes remain (ties: lower index pair)."""
    c = absr.shape[0]
    parent = list(range(c))

    def find(x):
        while parent[x] != x:
            x = parent[x]
        return x

    edges = sorted(((-absr[i, j], i, j) for i in range(c) for j in range(i + 1, c)))
    n = c
    for _, i, j in edges:
        if n == k:
            break
        a, b = find(i), find(j)
        if a != b:
            parent[max(a, b)] = min(a, b)
            n -= 1
    groups = {}
    for i in range(c):
        groups.setdefault(find(i), []).append(i)
    return sorted(groups.values(), key=lambda g: g[0])


def ols(X, y):
    X1 = np.column_stack([np.ones(len(y)), X])
    return np.linalg.lstsq(X1, y, rcond=None)[0]


def predict(b, X):
    return b[0] + X @ b[1:]


def identify_channel(t, T, y, train, block):
    absr_tt = np.abs(np.corrcoef(T[train].T))
    r_ty = np.array([abs(np.corrcoef(T[train, i], y[train])[0, 1]) for i in range(T.shape[1])])
    feats = {}
    for tau in TAUS_S:
        L = np.column_stack([lag(T[:, i], t, tau) for i in range(T.shape[1])])
        feats[tau] = (T - L) / tau

    def design(sel, tau):
        return np.column_stack([np.column_stack([T[:, i], feats[tau][:, i]]) for i in sel])

    def cv(sel, tau):
        X = design(sel, tau)
        sse, n = 0.0, 0
        for f in range(FOLDS):
            a = train & (block != f)
            v = train & (block == f)
            b = ols(X[a], y[a])
            e = y[v] - predict(b, X[v])
            sse += float(e @ e)
            n += int(v.sum())
        return np.sqrt(sse / n)

    best = None
    for k in CLASS_COUNTS:
        classes = single_linkage_classes(absr_tt, k)
        reps = [max(g, key=lambda i: (r_ty[i], -i)) for g in classes]
        for tau in TAUS_S:
            sel = []
            for _ in range(min(MAX_SENSORS, len(reps))):
                cand = [(cv(sel + [i], tau), i) for i in reps if i not in sel]
                s, i = min(cand)
                sel = sel + [i]
                key = (s, len(sel))
                if best is None or key < best[0]:
                    best = (key, k, tau, list(sel))
    (cv_rmse, _), k, tau, sel = best
    X = design(sel, tau)
    b = ols(X[train], y[train])
    e = y - predict(b, X)
    rm = lambda m: float(np.sqrt(np.mean(e[m] ** 2)))
    return dict(classes=k, tau_s=tau, sensors=[int(i) for i in sel], cv_rmse_um=float(cv_rmse),
                coefficients=[float(x) for x in b], train_rmse_um=rm(train), test_rmse_um=rm(~train))


def load(path):
    d = np.genfromtxt(path, delimiter=",", names=True)
    t = d["time_s"]
    T = np.column_stack([d["t%d_c" % i] for i in range(1, 17)])
    Y = np.column_stack([d["ch%d_um" % i] for i in range(1, 6)])
    return t, T, Y


def baseline(t, T, Y, train):
    out = []
    for j in range(Y.shape[1]):
        b = ols(T[train], Y[train, j])
        e = Y[:, j] - predict(b, T)
        out.append(float(np.sqrt(np.mean(e[~train] ** 2))))
    return out


def seed003_vector():
    T = np.array([[20.0, 22.0, 21.0, 24.0, 20.1], [21.0, 25.0, 23.1, 24.6, 20.8],
                  [22.0, 27.5, 25.2, 25.5, 21.9], [21.5, 29.0, 26.7, 26.9, 21.6],
                  [20.5, 30.1, 27.9, 28.0, 20.9], [20.0, 30.8, 28.4, 29.4, 20.3],
                  [21.0, 31.2, 29.0, 30.5, 21.0], [22.5, 31.5, 29.3, 31.2, 22.2]])
    ta = np.array([38.0, 41.9, 45.6, 48.8, 50.3, 51.2, 52.9, 54.6])
    b = ols(T[:, [0, 2, 3]], ta)
    q = float(np.sum((ta - predict(b, T[:, [0, 2, 3]])) ** 2))
    return dict(columns=["T1", "T3", "T4"], coefficients=[float(x) for x in b], q=q)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--csv", required=True, help="FL_THERMAL CSV (time_s, ch1_um..ch5_um, t1_c..t16_c)")
    ap.add_argument("--out", help="write the golden JSON here")
    ap.add_argument("--bench", action="store_true", help="time the identification of all 5 channels")
    ap.add_argument("--channels", type=int, default=5)
    a = ap.parse_args()
    t, T, Y = load(a.csv)
    train = t < SPLIT_S
    # Folds: 3 contiguous blocks of equal time span over the training period.
    t0, t1 = t[train].min(), t[train].max()
    block = np.minimum(np.floor((t - t0) / ((t1 - t0) / FOLDS)), FOLDS - 1).astype(int)
    if a.bench:
        runs = []
        for _ in range(1):
            s = time.perf_counter()
            for j in range(a.channels):
                identify_channel(t, T, Y[:, j], train, block)
            runs.append(time.perf_counter() - s)
        print(json.dumps(dict(numpy=np.__version__, channels=a.channels, seconds_min=min(runs), seconds=runs)))
        return
    res = dict(source="bench/identify/reference.py (numpy %s, np.linalg.lstsq)" % np.__version__,
               tolerance="1e-9 relative on coefficients",
               seed003=seed003_vector(),
               baseline_all16_test_rmse_um=baseline(t, T, Y, train),
               channels=[identify_channel(t, T, Y[:, j], train, block) for j in range(a.channels)])
    text = json.dumps(res, indent=1)
    if a.out:
        open(a.out, "w").write(text + "\n")
    print(text)


if __name__ == "__main__":
    main()
