"""Benchmark: build and solve the crane problem of examples/crane_ocp.py (minimum effort, 2 m in 4 s, Radau
IIA with 3 stages) at two sizes; IPOPT iterations and where the time goes.

Run from OUTSIDE the project root, so that `import ancf_sym` is the installed package with the compiled libraries:

    cd "$(mktemp -d)" && OPENBLAS_NUM_THREADS=1 python "$OLDPWD"/bench/control.py [--sizes 4x20,8x40] [--repeats 3]
                                                                             [--markdown]

Columns: nw / ng (variables / constraints), nnz of the constraint Jacobian and of the Hessian's upper triangle;
build = ControlProblem(...) (assembly, equilibria and modes, the CasADi graphs of g, its Jacobian and the
Lagrangian Hessian) + nlpsol; warm = the warm-start simulation (the OCP's own collocation equations); solve =
IPOPT's wall time; functions = the part of it spent in IPOPT's function calls (f, g, grad f, Jacobian, Hessian);
kernels = calls x the measured time of one mapped pass of the compiled kernels over all collocation points
(gradient pass for g, full energy/gradient/Hessian pass for the Jacobian, third-derivative pass for the Hessian);
the rest of solve is IPOPT itself, mostly MUMPS factorising the KKT matrix. Minimum over --repeats solves (each from
the same warm start, on a solver built once).
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

if (Path.cwd() / "ancf_sym").is_dir():
    sys.exit("run this from outside the project root (any other directory), so that the installed, compiled ancf_sym is imported")

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "examples"))
from crane_ocp import crane_problem  # noqa: E402


def measure(n: int, K: int, repeats: int) -> dict:
    t0 = time.perf_counter()
    prob = crane_problem(n, K)
    build = time.perf_counter() - t0
    t0 = time.perf_counter()
    prob.solver(True)
    build_solver = time.perf_counter() - t0
    t0 = time.perf_counter()
    w0, _ = prob.warm_start()
    warm = time.perf_counter() - t0
    best = None
    for _ in range(repeats):
        res = prob.solve(w0)
        if best is None or res.wall_s < best.wall_s:
            best = res
    kt = best.kernel_time()
    return {"n": n, "K": K, "nw": prob.nw, "ng": prob.ng, "jac_nnz": prob.jac_g.sparsity_out(1).nnz(),
            "hess_nnz": prob.hess_lag.sparsity_out(0).nnz(), "build_s": build, "nlpsol_s": build_solver,
            "warm_s": warm, "status": best.status, "iterations": best.iterations, "solve_s": best.wall_s,
            "functions_s": kt["functions_s"], "kernel_s": kt["kernel_s"], "kernel_share": kt["share_of_solve"],
            "kernel_of_functions": kt["kernel_s"] / kt["functions_s"] if kt["functions_s"] else float("nan"),
            "ipopt_rest_s": best.wall_s - kt["functions_s"], "cost": best.cost,
            "gradient_pass_ms": 1e3 * kt["per_call"]["gradient"], "full_pass_ms": 1e3 * kt["per_call"]["full"],
            "hvp_pass_ms": 1e3 * kt["per_call"]["hvp"]}


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--sizes", default="4x20,8x40", help="comma-separated n x K (elements x intervals)")
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--markdown", action="store_true")
    a = p.parse_args(argv)
    rows = []
    for size in a.sizes.split(","):
        n, K = (int(v) for v in size.lower().split("x"))
        rows.append(measure(n, K, a.repeats))
        print(rows[-1], flush=True)
    cols = ["n", "K", "nw", "jac_nnz", "hess_nnz", "build_s", "nlpsol_s", "warm_s", "iterations", "solve_s",
            "functions_s", "kernel_s", "kernel_share", "kernel_of_functions", "gradient_pass_ms", "full_pass_ms",
            "hvp_pass_ms"]
    fmt = lambda v: f"{v:.4g}" if isinstance(v, float) else str(v)  # noqa: E731
    if a.markdown:
        print("| " + " | ".join(cols) + " |")
        print("|" + "---|" * len(cols))
        for r in rows:
            print("| " + " | ".join(fmt(r[c]) for c in cols) + " |")
    else:
        for r in rows:
            print("  ".join(f"{c}={fmt(r[c])}" for c in cols))
    return rows


if __name__ == "__main__":
    main()
