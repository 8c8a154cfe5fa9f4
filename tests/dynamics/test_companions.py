"""Every kernel library's companions: <name>_energy and <name>_grad (energy + gradient without the Hessian's work)
return exactly what the full kernel returns (same arithmetic, pruned: equal to round-off, 1e-13 relative)."""
from __future__ import annotations

import numpy as np
import pytest

from ancf_sym import kernels, registry

from helpers import kernel_input


def _state_and_params(element: str, effect: str, rng) -> tuple[np.ndarray, np.ndarray]:
    el = registry.ELEMENTS[element]
    params = registry.EFFECTS[(element, effect)].params
    ref = np.zeros(el.ndof)
    nodes = ref.reshape(2, -1)
    dim = el.dim
    nodes[1, 0] = 0.8
    nodes[:, dim] = 1.0  # r_x = e_x
    if element == "beam3d":
        nodes[:, 7], nodes[:, 11] = 1.0, 1.0  # r_y = e_y, r_z = e_z
    q = kernel_input(element, effect, ref + 0.05 * rng.standard_normal(el.ndof))
    p = np.array([{"L": 0.8, "xi": 0.0, "nu": 0.3, "nx": 0.0, "ny": 0.0, "nz": 1.0, "t0x": 1.0, "t0y": 0.0,
                   "t0z": 0.0, "ref1": 0.0, "ref2": 1.0, "ref3": 1.0}.get(n, 1.0 + 0.1 * i) for i, n in enumerate(params)])
    return q, p


@pytest.mark.parametrize("entry", kernels.catalogue(), ids=lambda e: e["name"])
def test_energy_and_grad_companions_match_the_kernel(entry):
    rng = np.random.default_rng(3)
    el, ef, g = entry["element"], entry["effect"], entry["gauss"]
    eff = registry.EFFECTS[(el, ef)]
    gauss = None if g == eff.default_gauss else g
    q, p = _state_and_params(el, ef, rng)
    e, grad, _ = (np.asarray(a).ravel() for a in kernels.load(el, ef, gauss)(q, p))
    e2, g2 = (np.asarray(a).ravel() for a in kernels.load_grad(el, ef, gauss)(q, p))
    e1 = float(kernels.load_energy(el, ef, gauss)(q, p))
    scale = max(np.abs(grad).max(), 1e-300)
    assert abs(e2[0] - e[0]) <= 1e-13 * max(abs(e[0]), 1e-300) and abs(e1 - e[0]) <= 1e-13 * max(abs(e[0]), 1e-300)
    assert np.abs(g2 - grad).max() <= 1e-13 * scale
