"""Paper 000 (shared/papers/000_bbae7edf58547259.txt), Table 1: spurious axial energy of the coupled Green strain
in ONE bent element, and the decoupled strain that removes it.

Case: L = 1 m, circular section of radius 0.02 m (A = pi r^2, I = pi r^4 / 4), E = 2e7 Pa, |r_x| = 1 at both nodes,
deformed length int |r_x| dx = L (the paper's eps_L = 0, its eq. 9), symmetric bend by theta (node tangents at
+-theta/2 to the chord); the chord is solved for with brentq.

Conventions, found by exploring numerically:
- deformed length: measured with the same 5-point Gauss rule as the kernels (the rule the decoupled strain uses
  for L_D). It reproduces the table's axial energies at 120-180 deg to 0.04 % (0.09 % at 90 deg); measuring it with
  the exact integral instead gives +0.27 % at 180 deg, with 4 points -1.4 %.
- bending: the table's values are the 5-point Gauss quadrature of kappa^2 (the kernels' default order), to 0.01 %
  at 90-180 deg. That rule is not converged for a 180-degree element: the exact integral is 15.530 J at 180 deg,
  3.2 % above the paper's 15.052 J (7 points: 15.587 J).
- axial Green energy is a degree-8 polynomial in x: 5 points integrate it exactly.
Not reproduced (marked xfail, strict): the small-angle axial energies, 30 deg: 6.979e-5 J here vs 6.22e-5 J in the
paper (+12 %), 60 deg: 0.017383 J vs 0.018 J printed (0.01772 J from the paper's own U1/U2 = 1.283 %; -1.9 %).
At these angles the axial energy is ~1e-4 of the bending energy and changes by 4-10 % per 1e-5 of eps_L, and no
length convention (3, 4, 5, 7 points, exact) or chord choice (true circular arc) we tried moves both towards the
paper; our values equal an independent high-order integration of the same curve (test below), so the difference
is in the paper's numbers or an unstated detail of its setup.
"""
from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import brentq

from ancf_sym import kernels

from helpers import bent_state, cable_slope, evaluate, gauss01, quadrature_length, rotate_q, rotation

L = 1.0
RADIUS = 0.02
E = 2e7
EA = E * np.pi * RADIUS**2
EI = E * np.pi * RADIUS**4 / 4
# theta [deg]: (axial strain energy [J], bending strain energy [J]) as printed in Table 1
PAPER = {0: (0.0, 0.0), 30: (6.22e-5, 0.345), 60: (0.018, 1.381), 90: (0.426, 3.132), 120: (3.985, 5.708),
         150: (21.797, 9.44), 180: (83.688, 15.052)}
TILT = rotation([0.3, -1.0, 0.6], np.radians(50.0))  # cable3d: the bend lies in a tilted plane


def chord(theta: float, length_rule: int | None = 5) -> float:
    """Chord c with deformed length = L, measured by n-point Gauss (None: 40 points, the exact integral here)."""
    n = 40 if length_rule is None else length_rule
    return brentq(lambda c: quadrature_length(bent_state("cable2d", theta, c, L), 2, L, n) - L, 0.1, 1.1, xtol=1e-15)


def table_state(element: str, deg: float, length_rule: int | None = 5) -> np.ndarray:
    theta = np.radians(deg)
    q = bent_state("cable2d", theta, chord(theta, length_rule) * L, L)
    if element == "cable3d":
        q3 = np.zeros(12)
        q3.reshape(4, 3)[:, :2] = q.reshape(4, 2)
        q = rotate_q("cable3d", q3, TILT, shift=[0.4, -0.2, 1.0])
    return q


def energies(element: str, deg: float, length_rule: int | None = 5, gauss: int | None = None):
    q = table_state(element, deg, length_rule)
    axial = evaluate(kernels.load(element, "axial_green", gauss), q, [L, EA])[0]
    bend = evaluate(kernels.load(element, "bending", gauss), q, [L, EI])[0]
    return axial, bend


ELEMENTS = ["cable2d", "cable3d"]


@pytest.mark.parametrize("element", ELEMENTS)
@pytest.mark.parametrize("deg", [90, 120, 150, 180])
def test_large_bends_within_one_percent(element, deg):
    axial, bend = energies(element, deg)
    pa, pb = PAPER[deg]
    assert abs(axial / pa - 1) < 0.01, f"axial {axial:.6g} J vs paper {pa} J"
    assert abs(bend / pb - 1) < 0.01, f"bending {bend:.6g} J vs paper {pb} J"


@pytest.mark.parametrize("element", ELEMENTS)
@pytest.mark.parametrize("deg", [30, 60])
def test_small_bends_bending_within_rounding(element, deg):
    """The paper prints 3 decimals: half a unit in the last digit is its rounding."""
    _, bend = energies(element, deg)
    assert abs(bend - PAPER[deg][1]) <= 0.0005, f"bending {bend:.6g} J vs paper {PAPER[deg][1]} J"


@pytest.mark.xfail(strict=True, reason="not reproduced: 60 deg axial 0.017383 J vs paper 0.018 J (rounding "
                   "0.0175-0.0185), 30 deg 6.979e-5 J vs 6.22e-5 J; see module docstring")
@pytest.mark.parametrize("deg,half_unit", [(30, 0.005e-5), (60, 0.0005)])
def test_small_bends_axial_within_rounding(deg, half_unit):
    axial, _ = energies("cable2d", deg)
    assert abs(axial - PAPER[deg][0]) <= half_unit, f"axial {axial:.6g} J vs paper {PAPER[deg][0]} J"


@pytest.mark.parametrize("deg", [30, 60, 180])
def test_axial_energy_is_the_integral_of_the_green_strain(deg):
    """Independent check of what the kernel computes for the table's state: U = 1/2 int EA ((r_x.r_x - 1)/2)^2 dx
    by 40-point Gauss in numpy (the same quantity, integrated exactly by both). Tolerance 1e-9: r_x.r_x - 1 cancels,
    which amplifies round-off by 1/eps ~ 1e4 at 30 deg (strain ~ 7e-5); measured 4e-12 there."""
    q = table_state("cable2d", deg)
    xs, ws = gauss01(40)
    ref = sum(w * L * EA / 2 * ((cable_slope(q, 2, L, x) @ cable_slope(q, 2, L, x) - 1) / 2) ** 2 for x, w in zip(xs, ws))
    axial, _ = energies("cable2d", deg)
    assert abs(axial / ref - 1) < 1e-9


def test_table_conventions():
    """Pins the two conventions that reproduce the table at 180 deg (see module docstring)."""
    axial5, bend5 = energies("cable2d", 180)
    axial_exact_length, _ = energies("cable2d", 180, length_rule=None)
    _, bend7 = energies("cable2d", 180, gauss=7)
    assert abs(axial5 / PAPER[180][0] - 1) < 2e-4  # 5-point length: -0.005 %
    assert abs(axial_exact_length / PAPER[180][0] - 1) > 2e-3  # exact length: +0.27 %
    assert abs(bend5 / PAPER[180][1] - 1) < 2e-4  # 5-point bending quadrature: -0.001 %
    assert bend7 / PAPER[180][1] - 1 > 0.03  # converging towards the exact 15.53 J: +3.6 %


@pytest.mark.parametrize("element", ELEMENTS)
@pytest.mark.parametrize("deg", sorted(PAPER))
def test_decoupled_strain_has_no_spurious_axial_energy(element, deg):
    """A bent but unstretched element (|r_x| = 1 at the nodes, L_D = L by the kernel's own 5-point rule) has zero
    decoupled strain. Round-off: the chord is solved to 1e-15, so the strain is ~1e-15 and the energy
    ~ EA L (1e-15)^2 / 2; we allow an equivalent uniform strain of 1e-12."""
    q = table_state(element, deg)
    e = evaluate(kernels.load(element, "axial_decoupled"), q, [L, EA])[0]
    assert 0 <= e <= EA * L * (1e-12) ** 2 / 2, f"decoupled axial energy {e:.3e} J at {deg} deg"
    if deg > 0:
        assert energies(element, deg)[0] > 1e3 * EA * L * (1e-12) ** 2  # while the coupled strain's is not zero
