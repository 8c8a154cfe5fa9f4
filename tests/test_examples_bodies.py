"""examples/compound_pendulum.py: a rigid body on a revolute joint against the elliptic-integral period.

Bound: 400 steps per small-amplitude period of a second-order scheme give a phase error ~ (omega h)^2 / 12 ~ 2e-5
per period (omega h = 2 pi / 400); 2e-4 leaves room for the zero-crossing interpolation. The joint and unit-vector
rows are exact constraints solved by Newton: violation < 1e-9 m.
"""
from __future__ import annotations

import pytest

from helpers import run_example


@pytest.fixture(scope="module")
def pendulum(tmp_path_factory):
    return run_example("compound_pendulum", tmp_path_factory)


def test_period_matches_elliptic_integral(pendulum):
    _, recs = pendulum
    assert len(recs) >= 2
    for r in recs:
        assert r["success"], r["status"]
        assert abs(r["rel_error"]) < 2e-4, r
        assert r["constraint_violation"] < 1e-9
    big = max(recs, key=lambda r: r["amplitude_rad"])
    assert big["period_s"] / big["period_small_s"] > 1.3  # the large-amplitude case is far from the linear one
