"""Benchmark: what each effect costs. Time of Assembly.evaluate (energy + gradient + sparse Hessian) of a
cable of --n elements (default 1000) with the effects switched on one by one, the three axial strain measures,
and the planar (cable2d, 8 DOF) against the spatial (cable3d, 12 DOF) element.

Run from OUTSIDE the project root, so that `import ancf_sym` is the installed package with the compiled libraries:

    cd "$(mktemp -d)" && python "$OLDPWD"/bench/effects.py [--n 1000] [--repeats 30] [--markdown]

Each configuration is evaluated at the same perturbed state (reference + 1e-3 m noise, so no kernel sees the
special straight state); "min / median" over --repeats timings of one evaluate() call each (after a warm-up).
Columns: E+G+H evaluate [ms], per element [ns], E+G only (hessian=False) [ms], the mapped kernel calls alone
(gather of the element coordinates + compiled kernel, summed over the terms, min) [ms]; the rest of evaluate()
is assembly (bincount of gradients, Hessian scatter into the CSC pattern) and grows with the terms' DOF count.
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

if (Path.cwd() / "ancf_sym").is_dir():
    sys.exit("run this from outside the project root (any other directory), so that the installed, compiled ancf_sym is imported")

from ancf_sym import Material, Scene, Section  # noqa: E402
from ancf_sym.model.assembly import Assembly  # noqa: E402

CONFIGS = [  # (label, dim, axial, bending, gravity)
    ("cable3d axial (green) only", 3, "green", False, False),
    ("cable3d axial + bending", 3, "green", True, False),
    ("cable3d axial + bending + gravity", 3, "green", True, True),
    ("cable3d bending only (axial none)", 3, None, True, False),
    ("cable3d gravity only", 3, None, False, True),
    ("cable3d green + bending + gravity", 3, "green", True, True),
    ("cable3d biot + bending + gravity", 3, "biot", True, True),
    ("cable3d decoupled + bending + gravity", 3, "decoupled", True, True),
    ("cable2d green + bending + gravity", 2, "green", True, True),
    ("cable2d biot + bending + gravity", 2, "biot", True, True),
    ("cable2d decoupled + bending + gravity", 2, "decoupled", True, True),
]


def assembly(n: int, dim: int, axial: str | None, bending: bool, gravity: bool) -> Assembly:
    g = (0, -9.81) if dim == 2 else (0, 0, -9.81)
    s = Scene(dim=dim, gravity=g if gravity else None)
    end = (100.0,) + (0.0,) * (dim - 1)
    s.member("cable", [(0.0,) * dim, end], elements=n, material=Material(E=200e9, density=7800),
             section=Section.circle(0.01), axial=axial, bending=bending, gravity=gravity)
    s.pin("cable", "start")
    return Assembly(s)


def timings(f, repeats: int) -> tuple[float, float]:
    f()  # warm-up
    t = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        f()
        t.append(time.perf_counter() - t0)
    return min(t), statistics.median(t)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=1000, help="elements (default 1000)")
    ap.add_argument("--repeats", type=int, default=30)
    args = ap.parse_args()
    rng = np.random.default_rng(0)
    rows = []
    for label, dim, axial, bending, gravity in CONFIGS:
        a = assembly(args.n, dim, axial, bending, gravity)
        x = a.x0 + 1e-3 * rng.standard_normal(a.n)
        full = timings(lambda: a.evaluate(x), args.repeats)
        eg = timings(lambda: a.evaluate(x, hessian=False), args.repeats)
        kern = [timings(lambda mk=mk: mk(x), args.repeats)[0] for mk in a.mapped]
        terms = ", ".join(f"{t.effect} {k * 1e3:.3f}" for t, k in zip(a.terms, kern))
        rows.append((label, full, eg, sum(kern), terms))
    print(f"Assembly.evaluate of a {args.n}-element cable, min / median of {args.repeats} calls "
          f"(numpy {np.__version__})\n")
    print("| configuration | E+G+H [ms] | per element [ns] | E+G only [ms] | kernels alone [ms] | "
          "kernel terms (min ms each) |")
    print("|---|---|---|---|---|---|")
    for label, (fmin, fmed), (gmin, gmed), kern, terms in rows:
        print(f"| {label} | {fmin * 1e3:.3f} / {fmed * 1e3:.3f} | {fmin / args.n * 1e9:.0f} / "
              f"{fmed / args.n * 1e9:.0f} | {gmin * 1e3:.3f} / {gmed * 1e3:.3f} | {kern * 1e3:.3f} | {terms} |")


if __name__ == "__main__":
    main()
