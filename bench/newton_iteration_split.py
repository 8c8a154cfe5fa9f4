"""Cost split of one full Newton iteration (StepSystem.iter_f) of a bench case: the iteration and its parts as
separate compiled functions on the same data, timed interleaved (min and median over rounds of 30 calls).

Parts: the mapped element kernels with the gather of their coordinates; forces_pf (kernels + assembly of g and K);
the residual's mass product as the step graph builds it (StepSystem.mass_mx) and as the plain sparse product; the
step matrix cm M + K in K's pattern; max |diag| of it (the round-off floor's scale); CasADi's sparse LDL^T solve;
one inf-norm of a vector of the unknowns' size (the iteration takes three).

Run: python bench/newton_iteration_split.py [--case pendulum_1000] [--n N] [--rounds 15]
"""
from __future__ import annotations

import argparse
import os
import sys
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import casadi as ca  # noqa: E402
import numpy as np  # noqa: E402
from dynamics_vs_exudyn import CASES, ancf_scene  # noqa: E402

from ancf_sym.model.assembly import Assembly  # noqa: E402
from ancf_sym.util.casadi_buffers import bind  # noqa: E402
from ancf_sym.dynamics import StepSystem  # noqa: E402
from ancf_sym.util.sparsity import dm  # noqa: E402


def parts(S: StepSystem, x: np.ndarray) -> dict:
    """name -> (function, its inputs)."""
    nf, par = S.nf, np.ascontiguousarray(S.par)
    cm = np.array([4e6])  # (h = 1e-3 s: the inertia term as in a step)
    out = {"iter_f": (S.iter_f, [x, np.zeros(S.mc), np.ones(nf + S.nw), cm, np.array([2e3]), np.ones(1),
                                 np.zeros(nf)] + ([np.zeros(S.kel.size)] if S.kel is not None else [])
                      + [np.zeros(nf), par])}
    xs, ps = ca.MX.sym("x", nf), ca.MX.sym("par", S.par.size)
    X = S.x_full_mx(xs)
    kernel_outs, o = [], 0
    for ft in S.force_terms:
        P = ca.reshape(ps[o:o + ft.P.size], ft.P.shape[1], ft.P.shape[0])
        o += ft.P.size
        kernel_outs += list(ft.mapped()(ca.reshape(X[ft.idx.ravel().tolist()], ft.nd, ft.N), P))[1:]
    out["kernels (+ gather of x)"] = (ca.Function("k", [xs, ps], kernel_outs), [x, par])
    g, K = S.forces_pf(xs, ps)[:2]
    out["forces_pf (kernels + assembly)"] = (ca.Function("f", [xs, ps], [g, K]), [x, par])
    Kv = ca.Function("K", [xs, ps], [K])(x, par)
    spK = Kv.sparsity()
    Mdm = dm(S.M)
    A = ca.DM(Kv) + cm[0] * ca.project(Mdm, spK)
    Anz = np.ascontiguousarray(np.asarray(ca.project(A, spK).nonzeros(), dtype=float))
    cms, y, Km = ca.MX.sym("cm"), ca.MX.sym("y", nf), ca.MX.sym("K", spK)
    out["M (cm x + y), step graph"] = (ca.Function("m", [xs, cms, y], [S.mass_mx(cms * xs + y)]), [x, cm, x])
    out["M (cm x + y), sparse product"] = (ca.Function("m", [xs, cms, y], [ca.mtimes(Mdm, cms * xs + y)]), [x, cm, x])
    if spK.unite(Mdm.sparsity()) == spK:
        out["cm M + K"] = (ca.Function("s", [Km, cms], [cms * ca.project(Mdm, spK) + Km]), [Anz, cm])
    out["max |diag|"] = (ca.Function("d", [Km], [ca.mmax(ca.fabs(ca.diag(Km)))]), [Anz])
    r = ca.MX.sym("r", nf)
    out["LDL^T solve (CasADi ldl)"] = (ca.Function("l", [Km, r], [ca.solve(Km, r, "ldl")]), [Anz, np.ones(nf)])
    out["one inf-norm"] = (ca.Function("n", [r], [ca.mmax(ca.fabs(r))]), [x])
    return out


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    ap.add_argument("--case", default="pendulum_1000", choices=sorted(CASES))
    ap.add_argument("--n", type=int, help="elements (default: the case's)")
    ap.add_argument("--rounds", type=int, default=15)
    a = ap.parse_args(argv)
    c = dict(CASES[a.case], **({"n": a.n} if a.n else {}))
    asm = Assembly(ancf_scene(c))
    S = StepSystem.for_scene(asm)
    x = np.ascontiguousarray(S.reduce(asm.x0), dtype=float) + 1e-3
    bound = {}
    for name, (f, args) in parts(S, x).items():
        outs = [np.zeros(f.nnz_out(i)) for i in range(f.n_out())]
        bound[name] = (bind(f, args, outs), args, outs)
    times = {k: [] for k in bound}
    for _ in range(a.rounds):
        for k, ((_, ev), _, _) in bound.items():
            t0 = time.perf_counter()
            for _ in range(30):
                ev()
            times[k].append((time.perf_counter() - t0) / 30)
    print(f"{a.case}, n = {c['n']}, {S.nf} unknowns, K nnz {S.kkt_sparsity.nnz()}; us per call, min / median of "
          f"{a.rounds} rounds of 30, load average {os.getloadavg()[0]:.2f}")
    for k, v in times.items():
        print(f"  {k:32s} {1e6 * min(v):7.1f} / {1e6 * float(np.median(v)):7.1f}")
    return {k: min(v) for k, v in times.items()}


if __name__ == "__main__":
    main()
