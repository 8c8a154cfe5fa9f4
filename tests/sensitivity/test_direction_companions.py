"""The compiled parameter-direction companions <kernel>_dp(q, p, dq, dp) against central differences of the kernels
themselves along (dq, dp), and the beam's mass companion against differences of the mass kernel.

Reference: Richardson-extrapolated central differences (truncation O(s^4) at a step s = 1e-3 of the direction's
scale, round-off ~1e-16 |H| / s ~ 1e-13 relative), against 1e-7 relative: a wrong or missing term of the forward
derivative errs by O(1). The contact states press every Gauss point into the obstacle (the law's kink at zero gap
stays outside the differences)."""
from __future__ import annotations

import numpy as np
import pytest

from ancf_sym import kernels, registry


def _beam_q(L: float) -> np.ndarray:
    """A straight beam3d element along x (r, r_x, r_y, r_z at both nodes)."""
    e = np.eye(3)
    return np.r_[0, 0, 0, e[0], e[1], e[2], L, 0, 0, e[0], e[1], e[2]]


def _cable_q(L: float, dim: int) -> np.ndarray:
    e = np.eye(dim)[0]
    return np.r_[np.zeros(dim), e, L * e, e]


L = 0.5
CASES = {  # (element, effect): (q of a physical state, p)
    ("beam3d", "line_strain"): (_beam_q(L), [L, 0.02, 0.03, 2e8, 0.3]),
    ("beam3d", "continuum"): (_beam_q(L), [L, 0.02, 0.03, 2e8, 0.3, 4e-8]),
    ("beam3d", "line_bending"): (_beam_q(L), [L, 10.0, 20.0]),
    ("beam3d", "line_torsion"): (_beam_q(L), [L, 5.0]),
    ("cable2d", "contact_ground"): (_cable_q(L, 2), [L, 1e4, 1e5, 0.01, 0.0, 1.0, 0.05]),
    ("cable3d", "contact_ground"): (_cable_q(L, 3), [L, 1e4, 1e5, 0.01, 0.0, 0.0, 1.0, 0.05]),
    ("beam3d", "contact_ground"): (_beam_q(L), [L, 1e4, 1e5, 0.01, 0.0, 0.0, 1.0, 0.05]),
    ("cable2d", "contact_drum"): (_cable_q(L, 2), [L, 1e4, 1e5, 0.01, 0.3, 0.25, -0.1]),
    ("cable3d", "contact_drum"): (_cable_q(L, 3), [L, 1e4, 1e5, 0.01, 0.3, 0.0, 0.0, 1.0, 0.25, -0.1, 0.02]),
    ("beam3d", "contact_drum"): (_beam_q(L), [L, 1e4, 1e5, 0.01, 0.3, 0.0, 0.0, 1.0, 0.25, -0.1, 0.02]),
}


def test_every_companion_is_tested():
    assert set(CASES) == set(registry.PARAMETER_DIRECTION_EFFECTS)


@pytest.mark.parametrize("key", list(CASES))
def test_direction_companion_matches_differences(key):
    element, effect = key
    q0, p0 = (np.asarray(v, float) for v in CASES[key])
    rng = np.random.default_rng(3)
    q = q0 + 1e-2 * rng.standard_normal(q0.size)  # (a bent, stretched, twisted state)
    dq = 1e-2 * rng.standard_normal(q.size)
    # every parameter moves but the element length and the unit normal or axis (the geometry moves by the level,
    # the radius, the centre, the thickness)
    held = {"L", "nx", "ny", "nz", "ax", "ay", "az"}
    dp = np.array([0.0 if n in held else 1.0 for n in kernels.parameters(element, effect)]) * p0 * \
        rng.standard_normal(p0.size)
    k = kernels.load(element, effect)
    d = kernels.load_direction(element, effect)
    got = [np.asarray(o, float) for o in d(q, p0, dq, dp)]

    def f(s):
        return [np.asarray(o, float) for o in k(q + s * dq, p0 + s * dp)]
    s = 1e-3

    def D(s):
        return [(a - b) / (2 * s) for a, b in zip(f(s), f(-s))]
    fd = [(4 * a - b) / 3 for a, b in zip(D(s / 2), D(s))]
    for name, a, b in zip(("energy", "gradient", "hessian"), got, fd):
        assert np.linalg.norm(b) > 0, name
        assert np.linalg.norm(a - b) <= 1e-7 * np.linalg.norm(b), (key, name, np.linalg.norm(a - b) / np.linalg.norm(b))


def test_beam_mass_companion():
    p = np.array([0.5, 0.02, 0.03, 2000.0])
    for j in (1, 2):
        dp = np.zeros(4)
        dp[j] = p[j]
        got = kernels.mass_matrix_direction("beam3d", p, dp)
        s = 1e-3
        D = lambda s: (kernels.mass_matrix("beam3d", p + s * dp) - kernels.mass_matrix("beam3d", p - s * dp)) / (2 * s)
        fd = (4 * D(s / 2) - D(s)) / 3
        assert np.linalg.norm(got - fd) <= 1e-7 * np.linalg.norm(fd)
