"""The beam3d elastic energies' third-derivative companions <name>_hvp (point form, codegen.hvp_forms): H v against
the kernel's compiled Hessian, d(H v)/dq against central differences of that Hessian times v. A bent, twisted and
stretched element (slopes and section gradients perturbed by 5 %). Tolerances as tests/elements/test_hvp.py:
differences with step 1e-6 on O(1) coordinates have truncation ~1e-12 of the third derivative and round-off ~1e-10
relative (the stiffness coefficients scale H and its derivative alike); 1e-6 leaves room."""
from __future__ import annotations

import numpy as np
import pytest

from ancf_sym import kernels, registry

PARAMS = {"line_strain": [0.8, 0.02, 0.03, 2e8, 0.3], "line_bending": [0.8, 3e-8, 4e-8],
          "line_torsion": [0.8, 5e-8], "continuum": [0.8, 0.02, 0.03, 2e8, 0.3, 5e-8]}


@pytest.mark.parametrize("effect", registry.THIRD_DERIVATIVE_BEAM_EFFECTS)
def test_beam_hvp_matches_hessian_and_its_differences(effect):
    assert registry.has_third_derivatives("beam3d", effect, None)
    rng = np.random.default_rng(3)
    L = 0.8
    frame = np.r_[1.0, 0, 0, 0, 1.0, 0, 0, 0, 1.0]
    q = np.r_[0, 0, 0, frame, L, 0, 0, frame] + 0.05 * rng.standard_normal(24)
    p = PARAMS[effect]
    v = rng.standard_normal(24)
    k, hvp = kernels.load("beam3d", effect), kernels.load_hvp("beam3d", effect)
    hv, dhv = (np.asarray(a) for a in hvp(q, p, v))
    H = np.asarray(k(q, p)[2])
    assert np.abs(hv.ravel() - H @ v).max() <= 1e-12 * np.abs(H).max() * np.abs(v).max() * 24
    h = 1e-6
    fd = np.column_stack([(np.asarray(k(q + h * e, p)[2]) @ v - np.asarray(k(q - h * e, p)[2]) @ v) / (2 * h)
                          for e in np.eye(24)])
    assert np.abs(dhv - fd).max() < 1e-6 * np.abs(fd).max()
    assert np.abs(dhv - dhv.T).max() < 1e-12 * np.abs(dhv).max()
