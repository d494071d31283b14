"""Microseconds per sample of the Python float64 RLS implementations on the sled-like ARX problem:
n = 2 and n = 4 regressors of a closed-loop recording (the EMPS file, velocity against drive, the same
conditioning as `sledid replay`). Prints one line per tool and n."""
import csv, sys, time
import numpy as np

N = int(sys.argv[1]) if len(sys.argv) > 1 else 20000
path = __file__.rsplit("/", 3)[0] + "/../shared/data/emps/DATA_EMPS.csv"
rows = list(csv.DictReader(open(path)))[: N + 3]
y = np.array([float(r["qm_meas_pos_m"]) for r in rows]) / 1e-5
u = np.array([float(r["vir_ctrl_V"]) for r in rows]) / 10.0
dy = np.diff(y)
u = u[1:]

def regressors(n):
    na = n // 2
    nb = n - na
    X, d = [], []
    for t in range(max(na, nb) + 1, len(dy)):
        X.append([-dy[t - i] for i in range(1, na + 1)] + [u[t - i] for i in range(1, nb + 1)])
        d.append(dy[t])
    return np.array(X), np.array(d)

def plain_rls(X, d, lam=0.995):
    n = X.shape[1]
    P = np.eye(n) * 10.0
    w = np.zeros(n)
    for x, t in zip(X, d):
        Px = P @ x
        k = Px / (lam + x @ Px)
        w += k * (t - x @ w)
        P = (P - np.outer(k, Px)) / lam
    return w

results = []
for n in (2, 4):
    X, d = regressors(n)
    m = len(d)
    t0 = time.perf_counter(); plain_rls(X, d); t1 = time.perf_counter()
    results.append(("plain numpy RLS", n, (t1 - t0) / m * 1e6))
    try:
        import padasip as pa
        f = pa.filters.FilterRLS(n=n, mu=0.995, w="zeros")
        t0 = time.perf_counter()
        for x, t in zip(X, d):
            f.adapt(t, x)
        t1 = time.perf_counter()
        results.append(("padasip FilterRLS", n, (t1 - t0) / m * 1e6))
    except Exception as e:  # report, do not hide
        results.append((f"padasip FilterRLS failed: {e}", n, float("nan")))
    try:
        from sysidentpy.parameter_estimation import RecursiveLeastSquares
        est = RecursiveLeastSquares(lam=0.995)
        t0 = time.perf_counter()
        est.optimize(X, d.reshape(-1, 1))
        t1 = time.perf_counter()
        results.append(("sysidentpy RecursiveLeastSquares", n, (t1 - t0) / m * 1e6))
    except Exception as e:
        results.append((f"sysidentpy failed: {e}", n, float("nan")))
for name, n, us in results:
    print(f"{name:<34} n={n}  {us:8.2f} µs/sample")
