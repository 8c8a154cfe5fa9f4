"""The capstan's sticking case (mu 0.1, load ratio 1.2, the example's quick mesh) against the time step, for three
Newton variants: the default, the line search with 30 iterations (the belt's setting) and tight tolerances.

Prints per variant and step: rejected sub-steps, the heavy mass's velocity over the first 12 ms (the start kick)
and the example's creep speed (mean velocity over 0.25-0.45 s). The creep figure is the tail of the start
transient, and the variants part in the first milliseconds, where the first steps are rejected and halved.

Run: python bench/capstan_kink_refinement.py [--steps 1e-3,2.5e-4,6.25e-5] (from a folder outside the source tree)
"""
from __future__ import annotations

import argparse
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "examples"))
import capstan as CP  # noqa: E402  (imports _common first: BLAS threads)

import numpy as np  # noqa: E402

VARIANTS = {"default": {}, "line search, 30 it.": {"line_search": True, "max_iter": 30},
            "tight tolerances": {"tol": 1e-11, "xtol": 1e-13, "lte_fraction": 1e-6, "max_iter": 60}}
CASE = ("mu0.1_r1.2", 0.1, 1.2, 1.0)


def run(dt: float, newton: dict, t_end: float, output_dt: float) -> tuple[dict, object]:
    """The example's run_case with the step, the Newton options and the output step replaced."""
    orig_opts, orig_sim, got = CP.DynamicOptions, CP.simulate, {}

    def opts(**kw):
        return orig_opts(**{**kw, "dt": dt, "newton": newton, "output_dt": output_dt})

    def sim(asm, o):
        got["r"] = orig_sim(asm, o)
        return got["r"]

    CP.DynamicOptions, CP.simulate = opts, sim
    try:
        rec = CP.run_case(*CASE, t_end, 24)
    finally:
        CP.DynamicOptions, CP.simulate = orig_opts, orig_sim
    return rec, got["r"]


def main(argv=None) -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--steps", default="1e-3,2.5e-4,6.25e-5")
    a = ap.parse_args(argv)
    steps = [float(s) for s in a.steps.split(",")]
    f = np.log(CASE[2] / CASE[3]) / (CASE[1] * CP.THETA)
    print(f"regularised law, massless rope: friction fraction f = {f:.3f}, steady creep eps f / sqrt(1 - f^2) = "
          f"{CP.EPS * f / np.sqrt(1 - f * f) * 1e3:.2f} mm/s")
    for name, nw in VARIANTS.items():
        for dt in steps:
            rec, r = run(dt, nw, 0.45, 1e-3)
            t, v = np.asarray(r.t), -np.asarray(r.sensors["v"])[:, 1]
            rej = np.array([x["t"] for x in r.rejected])
            kick = " ".join(f"{x * 1e3:.0f}" for x in v[t <= 0.0125])
            print(f"{name:20s} dt {dt:8.3g}: rejected {len(rej):3d} ({int(np.sum(rej < 0.01)):2d} in the first 10 ms)"
                  f", creep {rec['creep_speed'] * 1e3:5.2f} mm/s, min velocity {v.min() * 1e3:6.0f} mm/s, "
                  f"v(0..12 ms) [mm/s]: {kick}", flush=True)


if __name__ == "__main__":
    main()
