"""Gradient and Hessian of every compiled kernel against central finite differences of the kernel itself.

Every (element, effect, gauss) of kernels.catalogue(), at random curved AND stretched states (straight reference
stretched by 5-20 %, every coordinate perturbed by 10-30 % relative, rigidly turned so no axis is special).

Step and tolerances. Central differences with step h have truncation error ~ h^2 |f'''|/6 and round-off error
~ eps_mach |f| / h. With coordinates of order 1 and h = 1e-6 (relative to max(1, |q_i|)) both are ~1e-10 relative
to the size of the derivative being checked, so we require agreement to 1e-6 (gradient, from energies) and 1e-5
(Hessian, from gradients), measured against the largest entry of the exact derivative: the finite-difference error
scales with the derivatives' overall size, not with each entry, so an entry-wise relative test would be meaningless
for entries that vanish. A wrong derivative (sign, missing term, wrong parameter index) is off by O(1).
"""
from __future__ import annotations

import zlib

import casadi as ca
import numpy as np
import pytest

from ancf_sym import kernels

from helpers import evaluate, kernel_input, params, perturbed_state

KERNELS = [(k["element"], k["effect"], k["gauss"]) for k in kernels.catalogue()]
IDS = [k["name"] for k in kernels.catalogue()]

H_REL = 1e-6
GRAD_TOL = 1e-6
HESS_TOL = 1e-5


def _states(element: str, seed: int, effect: str):
    """Two random curved, stretched states (different stretch, perturbation size and orientation); contact kernels:
    with the obstacle's coordinates (and velocities) appended (helpers.kernel_input)."""
    rng = np.random.default_rng(seed)
    return [kernel_input(element, effect, perturbed_state(element, rng, amplitude=0.1, stretch=0.05, angle=0.7), seed),
            kernel_input(element, effect, perturbed_state(element, rng, amplitude=0.3, stretch=0.2, angle=-1.9), seed)]


def _fd_gradient(f, q, h):
    g = np.empty_like(q)
    for i in range(q.size):
        dq = np.zeros_like(q)
        dq[i] = h[i]
        g[i] = (f(q + dq) - f(q - dq)) / (2 * h[i])
    return g


@pytest.mark.parametrize("element,effect,gauss", KERNELS, ids=IDS)
def test_gradient_and_hessian_match_finite_differences(element, effect, gauss):
    k = kernels.load(element, effect, gauss)
    for j, q in enumerate(_states(element, zlib.crc32(f"{element}/{effect}/{gauss}".encode()), effect)):
        p = params(element, effect, q)
        e, g, H = evaluate(k, q, p)
        h = H_REL * np.maximum(1.0, np.abs(q))

        g_fd = _fd_gradient(lambda x: evaluate(k, x, p)[0], q, h)
        scale_g = np.max(np.abs(g))
        assert scale_g > 0, f"state {j}: gradient identically zero, the check would be empty"
        err_g = np.max(np.abs(g - g_fd)) / scale_g
        assert err_g < GRAD_TOL, f"state {j}: gradient vs central differences, relative error {err_g:.2e}"

        def hessian_fd(h):
            return np.column_stack([
                (evaluate(k, q + dq, p)[1] - evaluate(k, q - dq, p)[1]) / (2 * hi)
                for hi, dq in ((h[i], h[i] * np.eye(q.size)[i]) for i in range(q.size))])

        H_fd = hessian_fd(h)
        scale_H = np.max(np.abs(H))
        if effect.startswith("contact_") and np.max(np.abs(H - H_fd)) >= HESS_TOL * scale_H:
            # a contact point just touching: the Hertz law's delta^1/2 terms vary fast there and the differences'
            # truncation error O(h^2) exceeds the tolerance; a 10x smaller step must then close in on the exact one
            H_fd = hessian_fd(h / 10)
        if effect == "gravity":
            # gravity is linear in q: its Hessian must be exactly zero, and the differences of gradients agree
            assert scale_H == 0.0 and np.max(np.abs(H_fd)) < 1e-9 * scale_g
            continue
        assert scale_H > 0
        err_H = np.max(np.abs(H - H_fd)) / scale_H
        assert err_H < HESS_TOL, f"state {j}: Hessian vs central differences, relative error {err_H:.2e}"
        # exact symmetry: the quadrature kernels mirror one triangle, CasADi's Hessian is symmetric by construction
        asym = np.max(np.abs(H - H.T)) / scale_H
        assert asym < 1e-14, f"state {j}: Hessian asymmetry {asym:.2e}"


@pytest.mark.parametrize("element,effect,gauss", KERNELS, ids=IDS)
def test_energy_function_and_reverse_companion_match_kernel(element, effect, gauss):
    """load_energy() (the function IPOPT differentiates) equals the kernel's energy, and its compiled reverse-mode
    companion adj1_<name>_energy gives the kernel's gradient: the same expressions, so to round-off (1e-12)."""
    k = kernels.load(element, effect, gauss)
    fe = kernels.load_energy(element, effect, gauss)
    q = _states(element, 7, effect)[1]
    p = params(element, effect, q)
    e, g, _ = evaluate(k, q, p)
    assert abs(float(fe(q, p)) - e) <= 1e-12 * max(abs(e), 1e-300)
    qs = ca.MX.sym("q", q.size)
    grad = ca.Function("grad", [qs], [ca.gradient(fe(qs, ca.DM(p)), qs)])
    g_adj = np.asarray(grad(q)).ravel()
    assert np.max(np.abs(g_adj - g)) <= 1e-12 * np.max(np.abs(g))


# Parameter that multiplies each effect's energy as a whole (energy is linear in it).
LINEAR_PARAM = {"axial_green": ("EA",), "axial_biot": ("EA",), "axial_decoupled": ("EA",),
                "axial_decoupled_biot": ("EA",), "bending": ("EI",),
                "gravity": ("rhoA",), "moment": ("M",), "continuum": ("E",), "line_strain": ("E",),
                "line_bending": ("EIy", "EIz"), "line_torsion": ("GIp",), "moment_z": ("M",), "moment_y": ("M",),
                "elastic_green": ("EA", "EI"), "elastic_biot": ("EA", "EI"),  # fused axial + bending: both factors
                "elastic_decoupled": ("EA", "EI"), "elastic_decoupled_biot": ("EA", "EI"),
                "contact_ground": ("k", "kh"), "contact_circle": ("k", "kh"),  # normal law: both stiffnesses
                "contact_ground_friction": ("k", "kh", "c"), "contact_circle_friction": ("k", "kh", "c"),
                "contact_drum": ("k", "kh"), "contact_drum_friction": ("k", "kh", "c"),
                "contact_body_friction": ("k", "kh", "c"),
                "contact_body_drum": ("k", "kh"), "contact_body_drum_friction": ("k", "kh", "c")}


# the contact gap kernels (a constraint of statics: a distance, no stiffness or load factor) are left out here;
# their values are checked against the geometry in tests/contact/test_contact_exact.py
SCALED = [(k, i) for k, i in zip(KERNELS, IDS) if not k[1].endswith("_gap")]


@pytest.mark.parametrize("element,effect,gauss", [k for k, _ in SCALED], ids=[i for _, i in SCALED])
def test_outputs_are_linear_in_the_stiffness(element, effect, gauss):
    """Energy, gradient and Hessian are proportional to the effect's stiffness (or load) factor: zero factor gives
    exactly zero outputs, factor 3 gives three times the outputs (to round-off). Independent of the parameter scale,
    so it catches a constant added to an output even where the finite-difference test's relative tolerance would
    drown it under a large stiffness."""
    k = kernels.load(element, effect, gauss)
    q = _states(element, 11, effect)[0]
    names = kernels.parameters(element, effect)
    p = params(element, effect, q)
    idx = [names.index(n) for n in LINEAR_PARAM[effect]]
    p0, p3 = p.copy(), p.copy()
    p0[idx] = 0.0
    p3[idx] *= 3.0
    e, g, H = evaluate(k, q, p)
    e0, g0, H0 = evaluate(k, q, p0)
    assert e0 == 0.0 and not g0.any() and not H0.any(), \
        f"zero {LINEAR_PARAM[effect]}: energy {e0}, max|gradient| {np.abs(g0).max()}, max|Hessian| {np.abs(H0).max()}"
    e3, g3, H3 = evaluate(k, q, p3)
    assert abs(e3 - 3 * e) <= 1e-13 * abs(3 * e)
    assert np.max(np.abs(g3 - 3 * g)) <= 1e-13 * np.max(np.abs(3 * g))
    assert np.max(np.abs(H3 - 3 * H)) <= 1e-13 * max(np.max(np.abs(3 * H)), 1e-300)
