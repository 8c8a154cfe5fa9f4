"""examples/rope_on_ground.py: statics with exact unilateral contact against the catenary with touchdown, and a
dropped rope coming to rest (linear and Hertz laws).

Bounds (measured in brackets, 16 + 32 + 16 elements): positions 1e-2 m [3.0e-3 m]: cubic elements of 0.14 m (legs)
and 0.25 m (ground) across the touchdown, where the exact curve's curvature jumps from w/H to 0; horizontal tension
3 % [1.0 %]; the contact multipliers carry the grounded weight to 2 % [0.3 %]; the touchdown lies within one ground
element (0.25 m) of the closed form [0.09 m], the first contact point being resolved per Gauss point only.
Dropped rope at rest: the force balance is exact once the motion has died out (speed < 1e-6 m/s), so 1e-3.
"""
from __future__ import annotations

import pytest

from helpers import pick, run_example


@pytest.fixture(scope="module")
def rope(tmp_path_factory):
    return run_example("rope_on_ground", tmp_path_factory)


def test_statics_exact_contact_matches_catenary_with_touchdown(rope):
    _, recs = rope
    r = pick(recs, case="statics_exact")
    assert r["success"], r["status"]
    assert r["max_error_m"] < 1e-2
    assert r["H_N"] == pytest.approx(r["H_ref_N"], rel=3e-2)
    assert r["ground_force_N"] == pytest.approx(r["ground_weight_ref_N"], rel=2e-2)
    assert abs(r["touchdown_m"] - r["touchdown_ref_m"]) < 0.25
    assert r["constraint_violation"] < 1e-8


@pytest.mark.parametrize("law", ["linear", "hertz"])
def test_dropped_rope_comes_to_rest(rope, law):
    _, recs = rope
    r = pick(recs, case=f"drop_{law}")
    assert r["success"], r["status"]
    assert r["final_speed_m_s"] < 1e-6
    assert r["normal_force_N"] == pytest.approx(r["weight_N"], rel=1e-3)
    assert r["penetration_m"] == pytest.approx(r["penetration_ref_m"], rel=1e-3)
    assert r["newton_per_step"] < 1.5  # no chattering: about one Newton iteration per step
    assert abs(r["energy_error_J"]) < 0.05 * r["initial_energy_J"]
