"""Modal analysis of lines in water (ancf_sym.modal.water): the added mass in the mass matrix (normal Ca and
tangential CaAx with the equilibrium's tangent), the buoyancy in the prestress, the current's drag as a load
stiffness (unsymmetric K) and as damping (damped=True)."""
from __future__ import annotations

import numpy as np
import pytest

from ancf_sym import Material, Scene, SceneError, Section
from ancf_sym.modal import linearize, modal_analysis

RHO, RHO_W = 1500.0, 1025.0
SEC = Section.circle(0.05)
A = SEC.area


def taut(n: int, dim: int = 2, E: float = 1e9, eps: float = 1e-3, vertical: bool = False, ca: float = 1.0,
         ca_axial: float = 0.0, **water) -> Scene:
    """A line 10 m long between two pins under water, stretched by 1 + eps (Biot strain: T = EA eps), no gravity."""
    end = np.zeros(dim)
    end[-1 if vertical else 0] = -10.0 if vertical else 10.0
    s = Scene(dim=dim, gravity=[0.0] * dim)
    s.member("c", [tuple(np.zeros(dim) - 20.0 * np.eye(dim)[-1]), tuple(end - 20.0 * np.eye(dim)[-1])], n,
             Material(E=E, density=RHO), SEC, axial="biot", bending=False, prestrain=eps)
    s.pin("c", "start")
    s.pin("c", "end")
    lines = {"c": {"ca": ca, "ca_axial": ca_axial, **water.pop("lines", {})}}
    s.set_water(density=RHO_W, lines=lines, **water)
    return s


def string(k, T: float, mu: float) -> np.ndarray:
    """f_k = k / 2L sqrt(T / mu), L = 10 m, mu per (stretched) length [Hz]."""
    return np.asarray(k) / 20.0 * np.sqrt(T / mu)


def test_taut_line_follows_the_string_with_the_normal_added_mass():
    # transverse modes: mass per length (rho + rho_w Ca) A / (1 + eps) (the tangential CaAx = 0 must not enter); the
    # cubic elements' error falls as h^6 (measured ~60x per halving), below 1e-6 at 16 elements
    eps = 1e-3
    ref = string([1, 2, 3], 1e9 * A * eps, (RHO + RHO_W) * A / (1 + eps))
    errs = []
    for n in (2, 4, 8, 16):
        r = modal_analysis(taut(n, eps=eps), modes=3)
        assert r.success and r.omega2_imag is None
        errs.append(np.abs(r.frequencies / ref - 1))
    assert np.all(errs[-1] < 1e-6)
    for a, b in zip(errs, errs[1:]):
        assert np.all(b < a / 10)
    dry = string(1, 1e9 * A * eps, RHO * A / (1 + eps))
    assert r.frequencies[0] < 0.8 * dry  # (the added mass lowers it by sqrt(rho / (rho + rho_w)) = 0.77)


def test_vertical_line_in_3d_both_transverse_directions():
    eps = 1e-3
    ref = string(1, 1e9 * A * eps, (RHO + 0.7 * RHO_W) * A / (1 + eps))
    r = modal_analysis(taut(8, dim=3, eps=eps, vertical=True, ca=0.7, ca_axial=0.3), modes=2)
    assert r.success
    assert np.all(np.abs(r.frequencies / ref - 1) < 1e-6)  # (a double mode; 8 elements: 6e-8 for the first)


def test_axial_mode_takes_the_tangential_added_mass():
    # a soft line stretched by 25 %: its first axial mode 1 / (2 L0) sqrt(EA / ((rho + rho_w CaAx) A)) (Biot strain:
    # the axial wave equation is linear, L0 = L / 1.25 the natural length) sits between the transverse ones
    E, eps = 1e6, 0.25
    r = modal_analysis(taut(16, E=E, eps=eps, ca=1.0, ca_axial=0.2), modes=4)
    assert r.success
    axial = [k for k in range(4) if np.abs(r.displacements(k, "c")[:, 0]).max() >
             np.abs(r.displacements(k, "c")[:, 1]).max()]
    assert len(axial) == 1
    fa = 1.25 / 20.0 * np.sqrt(E / (RHO + 0.2 * RHO_W))
    assert abs(r.frequencies[axial[0]] / fa - 1) < 1e-6
    others = np.delete(r.frequencies, axial[0])
    assert np.all(np.abs(others / string([1, 2, 3], E * A * eps, (RHO + RHO_W) * A / (1 + eps)) - 1) < 1e-6)


def chain(n: int, wet: bool) -> Scene:
    s = Scene(dim=2, gravity=(0.0, -9.81))
    s.member("chain", [(0.0, -5.0), (0.0, -6.0)], n, Material(E=1e10, density=3000.0), Section(area=1e-4),
             bending=False)
    s.pin("chain", "start")
    if wet:
        s.set_water(density=1000.0, lines={"chain": {"ca": 1.0, "ca_axial": 0.5}})
    return s


def test_hanging_chain_shifts_by_buoyancy_and_added_mass():
    # omega_k = (j0_k / 2) sqrt(g_eff / L), g_eff = g (rho - rho_w) / (rho + rho_w Ca) = g / 2 in water (the
    # submerged weight sets the tension, the added mass joins the inertia); within 1e-5 at 16 elements as the dry
    # chain (tests/modal/test_modal.py), the third mode's error falling with refinement
    j0 = np.array([2.404826, 5.520078, 8.653728])
    errs = []
    for n in (4, 16):
        r = modal_analysis(chain(n, wet=True), modes=3)
        assert r.success and r.static.success
        errs.append(np.abs(2 * np.pi * r.frequencies / (j0 / 2 * np.sqrt(9.81 / 2)) - 1))
    assert np.all(errs[1] < 1e-5)
    assert errs[0][2] > 10 * errs[1][2]
    dry = modal_analysis(chain(16, wet=False), modes=3)
    assert np.allclose(r.frequencies / dry.frequencies, np.sqrt(0.5), rtol=1e-5)


def test_current_drag_stiffness_and_damping():
    # a taut line across a current U (3D, no gravity): the drag's load stiffness makes K unsymmetric (the modes stay
    # real here), and its damping per length is c = 1/2 rho_w Cd d U across the current and twice that in line with
    # it (d(|u| u)/du), proportional to the mass: lambda = -zeta w +- i w sqrt(1 - zeta^2) with |lambda| the
    # undamped w = the string's with the equilibrium's tension H, zeta = c / (2 mu w). The current bends the line by
    # 1e-3 of its length: the cross-flow mode within 1e-4 (measured 4e-6); the in-line one is the bent line's
    # symmetric in-plane mode, raised by its stretching (Irvine's lambda^2 = 0.012 here): within 2e-3 (5e-4)
    U, cd, d = 0.5, 1.2, 0.05
    eps = 1e4 / (1e9 * A)
    r = modal_analysis(taut(16, dim=3, eps=eps, current=[0.0, U, 0.0], lines={"cd": cd}), modes=2, damped=True)
    assert r.success
    K = r.linearization.K
    assert abs(K - K.T).max() > 1e-9 * abs(K).max()  # (the drag's load stiffness: unsymmetric)
    assert np.abs(r.displacements(0, "c")[:, 2]).max() > 10 * np.abs(r.displacements(0, "c")[:, 1]).max()
    mu = (RHO + RHO_W) * A / (1 + eps)
    H = abs(r.static.constraint_forces["pin c@start"][0])
    w = 2 * np.pi * string(1, H, mu)
    tol = np.array([1e-4, 2e-3])
    assert np.all(np.abs(2 * np.pi * r.frequencies / w - 1) < tol)
    lam = r.damped.eigenvalues[:2]
    assert np.all(np.abs(np.abs(lam) / w - 1) < tol)
    c = 0.5 * RHO_W * cd * d * U / (1 + eps)
    assert np.all(np.abs(r.damped.damping_ratios[:2] / (np.array([1.0, 2.0]) * c / (2 * mu * w)) - 1) < tol)


def test_linearize_in_water_needs_the_statics_result():
    s = taut(2)
    r = modal_analysis(s, modes=1)
    with pytest.raises(SceneError, match="in water"):
        linearize(s, r.static.x)
    lin = linearize(s, r.static)
    assert lin.M.shape == lin.K.shape and lin.G.shape[1] == lin.size


def test_unsymmetric_pencil_dense_and_sparse():
    # blocks [[a, b], [-b, a]] (a follower load's skew stiffness) with M = I: w^2 = a +- i b, dense and by Arnoldi
    # (enough blocks for shift-invert) alike, to round-off of the solves (1e-9 relative)
    from ancf_sym.modal import eigen
    import scipy.sparse as sp

    for blocks in (3, 60):
        a = 1.0 + np.arange(blocks)
        K = sp.block_diag([np.array([[ak, 0.1 * ak], [-0.1 * ak, ak]]) for ak in a], format="csc")
        M = sp.identity(2 * blocks, format="csc")
        w2, Y, method = eigen.lowest_modes(K, M, sp.csr_matrix((0, 2 * blocks)), 4)
        assert ("dense" in method) == (blocks == 3)
        assert np.iscomplexobj(w2)
        ref = np.array([1 + 0.1j, 1 - 0.1j, 2 + 0.2j, 2 - 0.2j])
        assert np.allclose(np.sort_complex(w2), np.sort_complex(ref), rtol=1e-9)
        assert np.allclose(K @ Y, (M @ Y) * w2, atol=1e-9)


def test_condensed_stiffness_in_a_current_is_the_fairleads():
    # the linearisation's condensation at a pinned end (unsymmetric in a current: not symmetrised) and the water
    # statics' mooring_stiffness are the same exact Schur complement: equal to round-off (1e-12)
    from ancf_sym import solve_static
    from ancf_sym.water import mooring_stiffness

    s = taut(8, dim=3, eps=1e4 / (1e9 * A), current=[0.2, 0.5, 0.0], lines={"cd": 1.2, "cd_axial": 0.4})
    r = solve_static(s)
    assert r.success
    Kc = linearize(s, r).condensed_stiffness([("c", "end")])
    Km = mooring_stiffness(r, "c", "end")
    assert abs(Km[0, 1] - Km[1, 0]) > 1e-7 * abs(Km).max()  # (unsymmetric: 3e-6 of the axial stiffness)
    assert np.abs(Kc - Km).max() <= 1e-12 * np.abs(Km).max()


def test_result_document_in_water(tmp_path):
    import json

    from ancf_sym.io.json_out import json_ready
    from ancf_sym.modal.output import modal_result_dict, write_modes_vtu

    r = modal_analysis(taut(4, current=[0.5, 0.0], lines={"cd": 1.2}), modes=2, damped=True)
    doc = json.loads(json.dumps(json_ready(modal_result_dict(r))))
    assert doc["success"] and doc["omega2_imag"] is None and len(doc["damped"]["damping_ratios"]) == 2
    assert write_modes_vtu(r, tmp_path / "m.vtu").stat().st_size > 0


def test_frequencies_of_complex_w2():
    # a complex w^2 = (a + i b)^2: frequency a / 2 pi; a real negative one (to round-off) stays an unstable mode
    from ancf_sym.modal.analysis import frequencies_of

    w2 = np.array([(3.0 + 0.5j) ** 2, -4.0 + 1e-14j, 9.0 + 0j, 1e-20 + 0j])
    re, im, f = frequencies_of(w2, np.array([False, False, False, True]))
    assert np.allclose(f * 2 * np.pi, [3.0, -2.0, 3.0, 0.0]) and np.allclose(im, w2.imag) and np.allclose(re, w2.real)
    assert frequencies_of(np.array([4.0]), np.array([False]))[1] is None


def test_waves_are_refused_naming_the_field():
    # a linearisation about an equilibrium has no place for a time-dependent load: refused before any solve
    s = taut(4, depth=50.0, waves={"height": 2.0, "period": 8.0})
    with pytest.raises(SceneError, match="water.waves"):
        modal_analysis(s, modes=2)
