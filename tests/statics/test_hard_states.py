"""The states where naive formulas break: every kernel stays finite in them.

- straight (zero curvature): any curvature with |r_xx| (or |r_x x r_xx|) in a denominator or under a square root is
  singular there; the kernels use squared forms (docs/kernels.md).
- a 180-degree bend inside one element (paper 000, Table 1's last row): tangents at +-90 deg to the chord, |r_x| = 1
  at the nodes, chord 0.7488 L (the deformed length is then L).
Energy, gradient and Hessian must be finite; beyond that, facts that hold exactly in these states.
"""
from __future__ import annotations

import numpy as np
import pytest

from ancf_sym import kernels

from helpers import L0, bent_state, evaluate, kernel_input, params, rotate_q, rotation, rotation2, straight_state

KERNELS = [(k["element"], k["effect"], k["gauss"]) for k in kernels.catalogue()]
IDS = [k["name"] for k in kernels.catalogue()]
CHORD_180 = 0.748826  # chord/L of the 180-degree bend whose 5-point-measured length is L (see test_paper000_table1)


def hard_states(element):
    R = rotation2(0.3) if element == "cable2d" else rotation([1, 1, 0.5], 0.3)  # off the coordinate axes
    return {
        "straight": rotate_q(element, straight_state(element), R),
        "straight_stretched": rotate_q(element, straight_state(element, stretch=0.2), R),
        "bend180": rotate_q(element, bent_state(element, np.pi, CHORD_180 * L0), R),
    }


@pytest.mark.parametrize("element,effect,gauss", KERNELS, ids=IDS)
def test_finite_in_hard_states(element, effect, gauss):
    k = kernels.load(element, effect, gauss)
    for name, q in hard_states(element).items():
        q = kernel_input(element, effect, q)
        p = params(element, effect, q)
        e, g, H = evaluate(k, q, p)
        assert np.isfinite(e) and np.all(np.isfinite(g)) and np.all(np.isfinite(H)), f"{name}: non-finite output"
        if effect in ("bending", "line_bending") and name.startswith("straight"):
            # zero curvature: no bending energy or force, and a positive semi-definite tangent with bending stiffness
            assert e == 0.0 or abs(e) < 1e-25 * np.max(np.abs(H)), f"{name}: bending energy {e}"
            assert np.max(np.abs(g)) <= 1e-13 * np.max(np.abs(H)) * np.max(np.abs(q))
            w = np.linalg.eigvalsh(H)
            assert w.max() > 0 and w.min() >= -1e-12 * w.max(), f"{name}: straight bending tangent not PSD: {w.min()}"
        if effect in ("bending", "line_bending") and name == "bend180":
            assert e > 0 and np.max(np.abs(g)) > 0
