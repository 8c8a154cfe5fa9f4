"""Third-derivative companions <name>_hvp: (q, p, v) -> (H v, d(H v)/dq), against the kernel's Hessian and central
differences of H v. Tolerance: central differences with step 1e-6 on O(1) states have truncation ~1e-12 x the third
derivative and round-off ~1e-10 relative; 1e-6 relative leaves room for the 180-degree-bend-like curvature here."""
from __future__ import annotations

import numpy as np
import pytest

from ancf_sym import kernels, registry

CASES = [(el, ef) for el in ("cable2d", "cable3d") for ef in registry.THIRD_DERIVATIVE_EFFECTS]


@pytest.mark.parametrize("element,effect", CASES)
def test_hvp_matches_hessian_and_its_differences(element, effect):
    rng = np.random.default_rng(7)
    dim = registry.ELEMENTS[element].dim
    L = 0.7
    t = np.zeros(dim)
    t[0] = 1.1
    q = np.concatenate([np.zeros(dim), t, t * L / 1.1, t]) + 0.2 * rng.standard_normal(4 * dim)
    p = [L, 3.0]
    v = rng.standard_normal(4 * dim)
    k, hvp = kernels.load(element, effect), kernels.load_hvp(element, effect)
    hv, dhv = (np.asarray(a) for a in hvp(q, p, v))
    H = np.asarray(k(q, p)[2])
    assert np.allclose(hv.ravel(), H @ v, rtol=1e-12, atol=1e-12 * np.abs(H).max())
    h = 1e-6
    fd = np.column_stack([(np.asarray(k(q + h * e, p)[2]) @ v - np.asarray(k(q - h * e, p)[2]) @ v) / (2 * h)
                          for e in np.eye(len(q))])
    assert np.abs(dhv - fd).max() < 1e-6 * np.abs(fd).max()
    assert np.abs(dhv - dhv.T).max() < 1e-12 * np.abs(dhv).max()


def test_hvp_refused_where_not_generated():
    with pytest.raises(ValueError, match="third-derivative"):
        kernels.load_hvp("beam3d", "gravity")
