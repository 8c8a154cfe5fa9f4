"""Where the zhang_cantilever study's time goes: decoupled strain on 6 elements against Green strain on 18.

The study times `solve_static` on a freshly built scene whose problem is cached (the first, untimed solve builds the
assembly and the Newton index maps). This script splits the same timing, per setting, into
- the Newton runs (Biot start + the strain's own Newton, whose finish evaluates the answer and tests its stability),
  per iteration, and the rest of the solve (scene fingerprint, start ceiling, the Python around the runs, result);
- what scales with the elements: the kernel calls alone (each evaluation's mapped kernels, the Biot start's and the
  strain's own) and the banded Cholesky (LAPACK dpbtrf + dpbtrs);
and prints the time ratio decoupled 6 / Green 18 as measured, with the decoupled kernels costing nothing, and for a
solve that were only kernels and LAPACK (no Python, numpy or call overhead at all). Min over interleaved repeats.
Last, the bound a compiled Newton loop could reach: one whole iteration (kernels, assembly, sparse LDL solve,
update norms) as one CasADi graph (the StepSystem's, NewtonStatics), timed alone, times the iterations each setting
takes, with no per-solve cost at all.

    python bench/zhang_cost_split.py [--repeats 300] [--python-loop] [--separate-decoupled]

--separate-decoupled: the decoupled strain's axial and bending kernels called separately (its fused kernel
elastic_decoupled hidden), as before that kernel existed.
"""
from __future__ import annotations

import argparse
import time

import numpy as np
from scipy.linalg.lapack import dpbtrf, dpbtrs

from ancf_sym.statics import newton_loop, newton as statics_newton
from ancf_sym.statics import problem_for, solve_static
from ancf_sym.statics.evaluation import ReducedEvaluation
from ancf_sym.study.statics_studies import zhang_scene

SETTINGS = (("decoupled", 6, 5), ("green", 18, 5))


def _loop_min(f, inner: int = 500, outer: int = 9) -> float:
    best = np.inf
    for _ in range(outer):
        t0 = time.perf_counter()
        for _ in range(inner):
            f()
        best = min(best, (time.perf_counter() - t0) / inner)
    return best


class _Counters:
    """Wall time inside KernelNewton.solve and the number of kernel evaluations per evaluation object (calls of
    ReducedEvaluation.evaluate, and those the C loop makes, newton_loop)."""

    def __init__(self):
        self.newton, self.evals = 0.0, {}
        solve, evaluate, run = statics_newton.KernelNewton.solve, ReducedEvaluation.evaluate, newton_loop.CompiledLoop.run
        counters = self

        def timed_solve(self, *a, **k):
            t0 = time.perf_counter()
            try:
                return solve(self, *a, **k)
            finally:
                counters.newton += time.perf_counter() - t0

        def counted_evaluate(self, x):
            counters.evals[id(self)] = counters.evals.get(id(self), 0) + 1
            return evaluate(self, x)

        def counted_run(self, *a, **k):
            out = run(self, *a, **k)
            key = id(self.newton.ev)
            counters.evals[key] = counters.evals.get(key, 0) + self.counts["evaluations"]
            return out

        statics_newton.KernelNewton.solve = timed_solve
        ReducedEvaluation.evaluate = counted_evaluate
        newton_loop.CompiledLoop.run = counted_run

    def reset(self):
        self.newton, self.evals = 0.0, {}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=300)
    ap.add_argument("--python-loop", action="store_true", help="KernelNewton's Python loop instead of the C loop")
    ap.add_argument("--separate-decoupled", action="store_true", help="the decoupled strain's two kernels, unfused")
    args = ap.parse_args()
    statics_newton.PYTHON_LOOP = args.python_loop
    if args.separate_decoupled:
        from ancf_sym import registry
        fused = registry.fused_effect
        registry.fused_effect = lambda el, effs: None if any(e.startswith("axial_decoupled") for e in effs) \
            else fused(el, effs)
    c = _Counters()
    best = {s: (np.inf, 0.0, {}) for s in SETTINGS}
    results = {}
    for s in SETTINGS:
        results[s] = solve_static(zhang_scene(*s))  # builds and caches the problem, as the study's untimed solve
    for _ in range(args.repeats):  # interleaved, as a busy machine loads both alike
        for s in SETTINGS:
            scene = zhang_scene(*s)
            c.reset()
            t0 = time.perf_counter()
            solve_static(scene)
            t = time.perf_counter() - t0
            if t < best[s][0]:
                best[s] = (t, c.newton, dict(c.evals))
    rows = {}
    for s in SETTINGS:
        total, newton, evals = best[s]
        r, prob = results[s], problem_for(zhang_scene(*s))
        evs = [prob.light.ev] + ([prob._biot.ev] if prob._biot else [])
        kernel = 0.0
        for ev in evs:
            ev.evaluate(r.x)
            per = _loop_min(lambda: [call[4]() for call in ev.calls])
            kernel += per * evals.get(id(ev), 0)
        ab, g = prob.light.ev.band(), prob.light.ev.g.copy()
        lapack = _loop_min(lambda: dpbtrs(dpbtrf(ab, lower=0)[0], g, lower=0))
        lapack_solve = lapack * r.iterations
        rows[s] = dict(total=total, newton=newton, iterations=r.iterations, evals=sum(evals.values()),
                       kernel=kernel, lapack=lapack_solve, nf=prob.S.nf)
        print(f"{s[0]} n={s[1]} gauss {s[2]}: {prob.S.nf} free coordinates, {r.iterations} Newton iterations, "
              f"{sum(evals.values())} evaluations; solve {total * 1e6:.0f} us = Newton {newton * 1e6:.0f} us "
              f"({newton / r.iterations * 1e6:.0f} us per iteration) + rest {(total - newton) * 1e6:.0f} us; "
              f"kernel calls {kernel * 1e6:.0f} us, dpbtrf + dpbtrs {lapack_solve * 1e6:.0f} us, everything else "
              f"{(total - kernel - lapack_solve) * 1e6:.0f} us")
        graph = prob.graph  # the compiled iteration (built here, untimed)
        graph.x[:], graph.p[:] = prob.S.reduce(r.x), -prob.S.f_lin
        rows[s]["graph"] = _loop_min(graph._eval) * r.iterations
        print(f"  compiled iteration (one CasADi graph, LDL): {rows[s]['graph'] / r.iterations * 1e6:.1f} us, x "
              f"{r.iterations} iterations = {rows[s]['graph'] * 1e6:.0f} us")
    d, g = rows[SETTINGS[0]], rows[SETTINGS[1]]
    print(f"ratio decoupled 6 / Green 18: measured {d['total'] / g['total']:.2f}; decoupled kernels free "
          f"{(d['total'] - d['kernel']) / g['total']:.2f}; kernels + LAPACK only "
          f"{(d['kernel'] + d['lapack']) / (g['kernel'] + g['lapack']):.2f}; compiled Newton loop, no per-solve "
          f"cost {d['graph'] / g['graph']:.2f}")


if __name__ == "__main__":
    main()
