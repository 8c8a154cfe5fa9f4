"""One full Newton iteration (StepSystem.iter_f) of the pinned planar cable (the pendulum_1000 case at n elements)
on the band path against the same iteration with CasADi's sparse LDL^T (the band path switched off), interleaved,
min / median of 21 rounds of 20 calls; and the relative difference of the updates.

Run: python bench/band_vs_ldl.py [n ...]   (default 64 130 250 1000)
"""
from __future__ import annotations

import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import numpy as np  # noqa: E402
from dynamics_vs_exudyn import CASES, ancf_scene  # noqa: E402

from ancf_sym.model.assembly import Assembly  # noqa: E402
from ancf_sym.util.casadi_buffers import bind  # noqa: E402
from ancf_sym.dynamics import StepSystem, clear_graph_cache  # noqa: E402
from ancf_sym.system import band as band_mod  # noqa: E402


def compare(n: int) -> dict:
    c = dict(CASES["pendulum_1000"], n=n)
    runs, keep = {}, band_mod.MIN_SIZE
    try:
        for label, min_size in (("band", 1), ("CasADi ldl", 10 ** 9)):
            clear_graph_cache()
            band_mod.MIN_SIZE = min_size
            asm = Assembly(ancf_scene(c))
            S = StepSystem.for_scene(asm)
            nf = S.nf
            x = np.ascontiguousarray(S.reduce(asm.x0), dtype=float) + 1e-3
            args = [x, np.zeros(S.mc), np.ones(nf + S.nw), np.array([4e6]), np.array([2e3]), np.ones(1),
                    np.zeros(nf), np.zeros(nf), np.ascontiguousarray(S.par)]
            outs = [np.zeros(nf + S.mc), np.zeros(7)]
            runs[label] = (bind(S.iter_f, args, outs), outs)
    finally:
        band_mod.MIN_SIZE = keep
        clear_graph_cache()
    for (_, ev), _ in runs.values():
        ev()
    d = runs["band"][1][0] - runs["CasADi ldl"][1][0]
    times = {k: [] for k in runs}
    for _ in range(21):
        for k, ((_, ev), _) in runs.items():
            t0 = time.perf_counter()
            for _ in range(20):
                ev()
            times[k].append((time.perf_counter() - t0) / 20)
    out = {k: (min(v), float(np.median(v))) for k, v in times.items()}
    print(f"n = {n} ({nf} unknowns): " + ", ".join(f"{k} {1e6 * a:.1f} / {1e6 * b:.1f} us" for k, (a, b) in out.items())
          + f"; updates differ by {np.max(np.abs(d)) / np.max(np.abs(runs['CasADi ldl'][1][0])):.1e} (relative)")
    return out


if __name__ == "__main__":
    for n in [int(a) for a in sys.argv[1:]] or [64, 130, 250, 1000]:
        compare(n)
