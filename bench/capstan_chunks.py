"""Chunked against per-step runs of the frictional capstan (examples/capstan.py, mu = 0.2, m_heavy / m_light = 1.5,
24 elements, dt = 1e-3 s, 64 ms, newton {single: false, lte_fraction: 0}): the heavy mass's speed at 5, 10, 30 and
60 ms and the rejected steps of each run. Per-step: the time loop with chunks switched off (every step through
the integrator's attempt/accept, the same compiled step graph). `--surface`: the rope starts with its centre line
on the drum's surface (radius R + half thickness) instead of pressed into it by its half thickness.

Run: python bench/capstan_chunks.py [--surface]
"""
from __future__ import annotations

import argparse
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "examples"))
import capstan as CP  # noqa: E402

import numpy as np  # noqa: E402

import ancf_sym.dynamics.run as RUN  # noqa: E402
from ancf_sym.dynamics.newton import NewtonOptions  # noqa: E402
import ancf_sym.dynamics.time_loop as TL  # noqa: E402

T_END = 0.064


def run(chunked: bool, surface: bool) -> tuple[np.ndarray, np.ndarray, list]:
    out = {}
    simulate, path, chunk_size = CP.simulate, CP._path, TL.chunk_size

    def sim(asm, opts):
        opts.newton = NewtonOptions(single=False, lte_fraction=0.0)
        opts.output_dt = 1e-3
        out["res"] = res = simulate(asm, opts)
        return res

    def surface_path(s):
        r0 = CP.R
        CP.R = r0 + 0.5 * 0.003  # (the rope's diameter)
        try:
            return path(s)
        finally:
            CP.R = r0

    CP.simulate = sim
    if surface:
        CP._path = surface_path
    if not chunked:
        TL.chunk_size = RUN.chunk_size = lambda n: 0
    try:
        CP.run_case("chunks", 0.2, 1.5, 1.0, T_END, 24)
    except (TypeError, ValueError):
        pass  # (the example's fit after its 0.25 s transient: this run is shorter)
    finally:
        CP.simulate, CP._path, TL.chunk_size, RUN.chunk_size = simulate, path, chunk_size, chunk_size
    res = out["res"]
    return np.asarray(res.t), -np.asarray(res.sensors["v"])[:, 1], res.rejected


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--surface", action="store_true")
    a = ap.parse_args()
    runs = {name: run(chunked, a.surface) for name, chunked in (("chunked", True), ("per-step", False))}
    print(f"capstan mu = 0.2, ratio 1.5, {'rope on the drum surface' if a.surface else 'rope pressed in'}")
    for name, (t, v, rej) in runs.items():
        times = sorted({round(r["t"], 6) for r in rej})
        print(f"{name:9s} rejected {len(rej):3d}, at t = {times[:6]}{' ...' if len(times) > 6 else ''} "
              f"(last {times[-1] if times else None})")
        print("          v(t) [m/s]: " + ", ".join(f"{tt * 1e3:.0f} ms {v[np.argmin(abs(t - tt))]:.10f}"
                                               for tt in (0.005, 0.01, 0.03, 0.06)))
    (t1, v1, _), (t2, v2, _) = runs.values()
    print(f"largest difference at the outputs: {np.max(np.abs(v1 - v2)):.3g} m/s")


if __name__ == "__main__":
    main()
