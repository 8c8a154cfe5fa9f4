"""A step the compiled Newton iterations leave unconverged is finished by full Newton in Python. That loop starts
from the graph's last iterate only where it cut the predictor's residual a hundredfold (it was converging): on the
capstan's first steps (linear law, every contact point at the kink, regularised friction) the graph's full updates
diverged to a residual of 3e7 N, and Newton continued from there (given 60 iterations) reached a distant root of the
step equations, a rope 47 mm deep in the drum, accepted as converged; the sticking masses then slid at 5 m/s. (With
the weaker rule, below the predictor's residual at all, another build of numpy and its BLAS still found a root 12.7
mm deep.)"""
import os
import sys

import pytest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "examples"))
import capstan as CP  # noqa: E402


def test_unconverged_graph_step_does_not_seed_a_distant_root():
    got = {}
    orig_opts, orig_sim = CP.DynamicOptions, CP.simulate

    def opts(**kw):  # tight tolerances and a long budget: the Python loop runs on the steps the graph leaves
        return orig_opts(**{**kw, "newton": {"tol": 1e-11, "xtol": 1e-13, "lte_fraction": 1e-6, "max_iter": 60}})

    def sim(asm, o):
        got["r"] = orig_sim(asm, o)
        return got["r"]

    CP.DynamicOptions, CP.simulate = opts, sim
    try:
        rec = CP.run_case("mu0.1_r1.2", 0.1, 1.2, 1.0, 0.3, 24)  # (0.3 s: the chunking of the failing run)
    finally:
        CP.DynamicOptions, CP.simulate = orig_opts, orig_sim
    r = got["r"]
    assert r.success, r.status
    # the penalty carries the tight end's pressure T / R ~ 120 N/m at 1e6 N/m^2: 0.12 mm (twice that for the
    # release's overshoot); the distant root was 47 mm
    assert r.contact_gaps[0]["smallest_gap"] > -1e-3, r.contact_gaps
    # sticking: the heavy mass creeps below eps (it slid at metres per second)
    assert abs(rec["creep_speed"]) < CP.EPS, rec
