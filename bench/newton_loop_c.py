"""The statics Newton loop in C (ancf_sym.statics.newton_loop) against the Python loop, per iteration.

One KernelNewton run from the straight beam (tol 1e-10) per setting, timed with the C loop and with the Python loop
(statics_newton.PYTHON_LOOP) alternately on the same problem; min over repeats, divided by the run's iterations.
The settings: the zhang_cantilever study's Green n = 18 and decoupled n = 6 (gauss 5; from the straight beam the
decoupled run meets indefinite tangents: LU and shifted steps, extra evaluations), and paper 000's cantilever with
Green strain on 60 and 6000 elements (element-local positions from ~75 elements).

    python bench/newton_loop_c.py [--repeats 50] [--large-repeats 5]
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from ancf_sym import Material, Scene, Section
from ancf_sym.statics import newton as statics_newton
from ancf_sym.statics import StaticProblem
from ancf_sym.study.statics_studies import zhang_scene


def cantilever(n: int) -> Scene:
    """Paper 000's cantilever (L = 3 m, E = 20 GPa, gravity, clamped), Green strain."""
    s = Scene(dim=2, gravity=(0, -9.81))
    s.member("beam", [(0, 0), (3.0, 0)], n, Material(E=20e9, density=7200), Section(area=7.854e-5, I=4.909e-10),
             axial="green", gravity=True)
    s.clamp("beam", "start")
    return s


SETTINGS = (("zhang green 18", lambda: zhang_scene("green", 18, 5)),
            ("zhang decoupled 6", lambda: zhang_scene("decoupled", 6, 5)),
            ("cantilever green 60", lambda: cantilever(60)),
            ("cantilever green 6000", lambda: cantilever(6000)))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=50)
    ap.add_argument("--large-repeats", type=int, default=5, help="repeats at 6000 elements")
    args = ap.parse_args()
    for name, scene in SETTINGS:
        p = StaticProblem(scene())
        kn = p.light
        solve = lambda: kn.solve(p.asm.x0, 1e-10, 60, p.work)  # noqa: E731
        best = {False: np.inf, True: np.inf}
        runs = {}
        for _ in range(args.large_repeats if p.S.nf > 10000 else args.repeats):
            for python in (False, True):
                statics_newton.PYTHON_LOOP = python
                t0 = time.perf_counter()
                runs[python] = solve()
                best[python] = min(best[python], time.perf_counter() - t0)
        statics_newton.PYTHON_LOOP = False
        c, py = runs[False], runs[True]
        assert (c.status, c.iterations) == (py.status, py.iterations)
        it = c.iterations
        print(f"{name}: {p.S.nf} free coordinates, {it} iterations ({c.status}; {kn._loop.counts}); per iteration "
              f"C {best[False] / it * 1e6:.1f} us, Python {best[True] / it * 1e6:.1f} us, ratio "
              f"{best[False] / best[True]:.2f}; run C {best[False] * 1e3:.3f} ms, Python {best[True] * 1e3:.3f} ms")


if __name__ == "__main__":
    main()
