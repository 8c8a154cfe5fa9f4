"""Modal analysis about an equilibrium (ancf_sym.modal) against closed-form frequencies: each case's tolerance is the
discretisation error of its mesh (cubic Hermite elements: the error falls ~h^4 for cables and Euler-Bernoulli beams,
~h^2 for the beam3d continuum) or the modelling error of the reference theory, and refinement tests assert the error
falls toward the reference."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import brentq

from ancf_sym import Material, Scene, SceneError, Section, linearize, modal_analysis
from ancf_sym.modal import eigen

G = 9.81
STEEL = Material(E=2e11, density=7800.0)
BAR = Section.rectangle(0.01, 0.01)


def cantilever(n: int, free: bool = False) -> Scene:
    s = Scene(dim=2, gravity=(0.0, 0.0))
    s.member("beam", [(0, 0), (1.0, 0)], n, STEEL, BAR)
    if not free:
        s.clamp("beam", "start")
    return s


def beta_l(freq: np.ndarray) -> np.ndarray:
    """beta L = (w^2 rho A / EI)^(1/4) L of an Euler-Bernoulli beam of length 1."""
    w = 2 * np.pi * np.asarray(freq)
    return (w ** 2 * STEEL.density * BAR.area / (STEEL.E * BAR.bending_inertia)) ** 0.25


CLAMPED_FREE = np.array([1.875104, 4.694091, 7.854757])


def test_cantilever_euler_bernoulli_and_refinement():
    # Euler-Bernoulli beam (slender: h/L = 1/100, the shear and rotary-inertia corrections are ~(h/L)^2 ~ 1e-4 of
    # beta L and the ANCF cable has neither): within 1e-3 at 16 elements (the bar); the third mode's error
    # falls with refinement (cubic Hermite: ~h^4 in w^2)
    errs = []
    for n in (4, 8, 16):
        r = modal_analysis(cantilever(n), modes=4)
        assert r.success and not np.any(r.zero)
        errs.append(np.abs(beta_l(r.frequencies[:3]) / CLAMPED_FREE - 1))
    assert np.all(errs[-1] < 1e-3)
    assert errs[0][2] > errs[1][2] > errs[2][2]
    # mode shapes: mass-normalised, the tip moves in the first mode
    lin = r.linearization
    Y = lin.E.T @ r.shapes  # (E's columns are unit selections: E^T x_full gives the unknowns)
    assert np.allclose(Y.T @ lin.M @ Y, np.eye(r.modes), atol=1e-9)
    assert abs(r.displacements(0, "beam")[-1, 1]) > 0 and r.modal_masses[0] > 0


def test_free_beam_zero_modes_shift_invert():
    # free-free beam, 120 elements (484 unknowns: the sparse shift-invert path): three rigid motions reported at
    # zero, then beta L = 4.730041, 7.853205 (refinement error at 120 elements ~1e-8)
    r = modal_analysis(cantilever(120, free=True), modes=5)
    assert r.method.startswith("shift-invert")
    assert list(r.zero) == [True, True, True, False, False]
    assert np.all(r.frequencies[:3] == 0.0)
    assert np.allclose(beta_l(r.frequencies[3:]), [4.730041, 7.853205], rtol=1e-5)


def test_shift_invert_modes_are_reproducible():
    # ARPACK starts from a fixed vector: the same scene solved twice gives the same modes to the last bit (a
    # result.json written twice is the same file)
    lin = linearize(cantilever(120))
    w1, Y1, _ = eigen.sparse_modes(lin.K, lin.M, lin.G, 4)
    w2, Y2, _ = eigen.sparse_modes(lin.K, lin.M, lin.G, 4)
    assert np.array_equal(w1, w2) and np.array_equal(Y1, Y2)


def test_shift_invert_fine_mesh_and_dense_agree():
    # 120 elements: shift-invert resolves the lowest modes to their own precision (the discretisation error is
    # ~1e-9 there): beta L within 1e-6; on 8 elements the dense pencil and shift-invert give the same w^2 to 1e-6
    # (the dense solve's error is round-off of the highest w^2, an axial mode ~1e4 x... 1e8 above the lowest: ~1e-8)
    r = modal_analysis(cantilever(120), modes=3)
    assert r.method.startswith("shift-invert") and np.allclose(beta_l(r.frequencies), CLAMPED_FREE, rtol=1e-6)
    lin = linearize(cantilever(8))
    w_d, _ = eigen.dense_modes(lin.K, lin.M, lin.G, 3)
    w_s, _, sigma = eigen.sparse_modes(lin.K, lin.M, lin.G, 3)
    assert sigma == 0.0 and np.allclose(w_s, w_d, rtol=1e-6)


def hanging_chain(n: int) -> Scene:
    # a chain: cable without bending, EA large (gravity strain rho g L / E = 1e-6)
    s = Scene(dim=2, gravity=(0.0, -G))
    s.member("chain", [(0, 0), (0, -1.0)], n, Material(E=1e10, density=1000.0), Section(area=1e-4), bending=False)
    s.pin("chain", "start")
    return s


def test_hanging_chain_bessel():
    # omega_n = (j0_n / 2) sqrt(g / L) (inextensible chain; the extension 1e-6 shifts it by ~1e-6): within 1e-5 at
    # 16 elements, the third mode's error falling with refinement
    j0 = np.array([2.404826, 5.520078, 8.653728])
    exact = j0 / 2 * np.sqrt(G / 1.0)
    errs = []
    for n in (4, 16):
        r = modal_analysis(hanging_chain(n), modes=3)
        assert r.success and r.static.success
        errs.append(np.abs(2 * np.pi * r.frequencies / exact - 1))
    assert np.all(errs[1] < 1e-5)
    assert errs[0][2] > 10 * errs[1][2]


def sagging_cable(lam2: float, dim: int = 2, n: int = 40) -> tuple[Scene, float]:
    """A cable between two pins 100 m apart, sag/span 1/50, EA chosen for Irvine's lambda^2; returns (scene, EA)."""
    span, A, rho, d = 100.0, 1e-3, 1000.0, 1 / 50
    m = rho * A
    H = m * G * span / (8 * d)
    EA = lam2 * H ** 3 / (m * G * span) ** 2 * (1 + 8 * d ** 2)
    arc = span * (1 + 8 / 3 * d ** 2)
    prestrain = span / (arc / (1 + H / EA)) - 1  # negative: the chord is shorter than the unstretched cable
    s = Scene(dim=dim, gravity=(0.0, -G) if dim == 2 else (0.0, 0.0, -G))
    s.member("cable", [(0, 0), (span, 0)] if dim == 2 else [(0, 0, 0), (span, 0, 0)], n,
             Material(E=EA / A, density=rho), Section(area=A), bending=False, prestrain=prestrain)
    s.pin("cable", "start")
    s.pin("cable", "end")
    return s, EA


@pytest.mark.parametrize("lam2", [100.0, 1000.0])
def test_irvine_sagging_cable(lam2):
    # Irvine's shallow-cable theory (sag/span 1/50: its own error O((sag/span)^2) ~ 1e-3): the first symmetric
    # in-plane mode x/L sqrt(H/m), tan(x/2) = x/2 - (4/lambda^2)(x/2)^3, the antisymmetric 2 pi/L sqrt(H/m), within
    # 5e-3, with H and lambda^2 from the computed equilibrium; 3D: the first out-of-plane pi/L sqrt(H/m)
    s, EA = sagging_cable(lam2, dim=3)
    r = modal_analysis(s, modes=4)
    st = r.static
    span, m = 100.0, 1.0
    H = abs(st.constraint_forces["pin cable@start"][0])
    sag = -st.nodes("cable")[:, 2].min()
    lam2_m = (m * G * span / H) ** 2 * span / (H * span * (1 + 8 * (sag / span) ** 2) / EA)
    x = brentq(lambda x: np.tan(x / 2) - x / 2 + 4 / lam2_m * (x / 2) ** 3, np.pi * (1 + 1e-9), 3 * np.pi * (1 - 1e-9))
    base = np.sqrt(H / m) / span  # [rad/s per unit x]
    w = 2 * np.pi * r.frequencies
    # mode kinds from the shapes: out-of-plane (y), in-plane (z) symmetric / antisymmetric about midspan
    kinds = []
    for k in range(r.modes):
        u = r.displacements(k, "cable")
        if np.abs(u[:, 1]).max() > np.abs(u[:, 2]).max():
            kinds.append("out")
        else:
            kinds.append("sym" if abs(u[len(u) // 2, 2]) > 0.1 * np.abs(u[:, 2]).max() else "anti")
    out = w[kinds.index("out")]
    assert abs(out / (np.pi * base) - 1) < 5e-3
    assert abs(w[kinds.index("anti")] / (2 * np.pi * base) - 1) < 5e-3
    assert abs(w[kinds.index("sym")] / (x * base) - 1) < 5e-3


def test_taut_string():
    # a string held by two pins at tension T = EA prestrain (no gravity): f_n = n/(2L) sqrt(T/mu) with T the
    # element's axial force at the prestrain (Green: EA(eps + eps^2/2)(1 + eps)) and mu = rho A / (1 + eps); within 1e-4
    # at 20 elements (the refinement error of the 3rd mode at 20 cubic elements ~1e-6), EI = 0
    L, A, E, rho, eps = 1.0, 3.14e-8, 2e11, 7800.0, 5.0 / (2e11 * 3.14e-8)
    s = Scene(dim=2, gravity=(0.0, 0.0))
    s.member("string", [(0, 0), (L, 0)], 20, Material(E=E, density=rho), Section(area=A), bending=False,
             prestrain=eps)
    s.pin("string", "start")
    s.pin("string", "end")
    r = modal_analysis(s, modes=3)
    T = E * A * (eps + eps ** 2 / 2) * (1 + eps)
    mu = rho * A / (1 + eps)
    assert np.allclose(r.frequencies, np.arange(1, 4) / (2 * L) * np.sqrt(T / mu), rtol=1e-4)


def beam3d_bar(n: int) -> Scene:
    s = Scene(dim=3, gravity=(0.0, 0.0, 0.0))
    s.member("bar", [(0, 0, 0), (1.0, 0, 0)], n, Material(E=2e11, density=7800.0, poisson=0.3),
             Section.rectangle(0.02, 0.01), element="beam3d")
    s.clamp("bar", "start")
    return s


def test_beam3d_bending_and_torsion():
    # beam3d (continuum): bending about both axes (beta L = 1.875104 with Iy, Iz) and torsion
    # omega = pi/(2L) sqrt(G J / (rho Ip)); second-order element: error ~h^2 (measured 1.6e-3 -> 4e-4 -> 1e-4 at
    # 8 -> 16 -> 32 elements), within 1e-3 at 16 and falling by ~4 with each halving
    sec, rho, E = Section.rectangle(0.02, 0.01), 7800.0, 2e11
    Gm = E / 2.6
    bend = [1.875104 ** 2 * np.sqrt(E * I / (rho * sec.area)) / (2 * np.pi) for I in (sec.Iy, sec.Iz)]
    tors = np.pi / 2 * np.sqrt(Gm * sec.J / (rho * (sec.Iy + sec.Iz))) / (2 * np.pi)
    errs = []
    for n in (8, 16):
        r = modal_analysis(beam3d_bar(n), modes=12)
        f = {}
        for k in range(r.modes):
            u = r.displacements(k, "bar")
            if np.abs(u).max() < 1e-6 * np.abs(r.shapes[:, k]).max():  # no node moves: torsion
                f.setdefault("tors", r.frequencies[k])
            elif abs(u[-1, 2]) > abs(u[-1, 1]):
                f.setdefault("z", r.frequencies[k])
            else:
                f.setdefault("y", r.frequencies[k])
        errs.append(np.abs([f["z"] / bend[0] - 1, f["y"] / bend[1] - 1, f["tors"] / tors - 1]))
    assert np.all(errs[1] < 1e-3)
    assert np.all(errs[1] < errs[0] / 2.5)


def test_rigid_joint_multipliers():
    # a cantilever sagging under gravity (E low: a large deflection, prestress) made of two members joined rigidly
    # (the slope rows keep multipliers: the KKT path with their curvature) has the modes of the single member
    # (the same discrete model: they agree to the static tolerance, 1e-6 is far above it and far below the shift
    # the prestress makes, 300 % on the first mode)
    mat, sec = Material(E=1e7, density=1000.0), Section.rectangle(0.01, 0.01)

    def scene(split: bool) -> Scene:
        s = Scene(dim=2, gravity=(0.0, -G))
        if split:
            s.member("a", [(0, 0), (0.5, 0)], 8, mat, sec)
            s.member("b", [(0.5, 0), (1.0, 0)], 8, mat, sec)
            s.rigid(("a", "end"), ("b", "start"))
        else:
            s.member("a", [(0, 0), (1.0, 0)], 16, mat, sec)
        s.clamp("a", "start")
        return s

    one, two = modal_analysis(scene(False), modes=5), modal_analysis(scene(True), modes=5)
    assert two.linearization.G.shape[0] > 0
    assert np.allclose(two.frequencies, one.frequencies, rtol=1e-6)


def test_penalty_contact_winkler_foundation():
    # a pinned-free beam pressed into the ground by gravity (linear penalty contact, penetrated everywhere): a beam
    # on a Winkler foundation, w^2 = (EI beta^4 + k) / (rho A) with beta L = 0 (the rigid rotation on the
    # foundation), 3.926602, 7.068583; within 1e-4 at 16 elements, the third mode's error falling
    k, EI, rA = 5e3, STEEL.E * BAR.bending_inertia, STEEL.density * BAR.area
    exact = np.sqrt((EI * np.array([0.0, 3.926602, 7.068583]) ** 4 + k) / rA) / (2 * np.pi)
    errs = []
    for n in (4, 16):
        s = Scene(dim=2, gravity=(0.0, -G))
        s.member("beam", [(0, 0.004), (1.0, 0.004)], n, STEEL, BAR)
        s.pin("beam", "start")
        s.contact_ground("beam", stiffness=k, thickness=0.005, gauss=5)
        r = modal_analysis(s, modes=3)
        errs.append(np.abs(r.frequencies / exact - 1))
    assert np.all(errs[1] < 1e-4) and errs[0][2] > 10 * errs[1][2]


def test_condensed_stiffness_cantilever_tip():
    # the tip's 2x2 stiffness of an unloaded cantilever: EA/L axially, 3EI/L^3 transversally (Euler-Bernoulli; the
    # cubic element is exact for a tip load)
    lin = linearize(cantilever(4))
    K = lin.condensed_stiffness([("beam", "end")])
    EA, EI = STEEL.E * BAR.area, STEEL.E * BAR.bending_inertia
    assert np.allclose(np.diag(K), [EA, 3 * EI], rtol=1e-8)
    assert abs(K[0, 1]) < 1e-8 * EA


def test_condensed_stiffness_at_a_pin_of_a_taut_string():
    # the "fairlead" case: the stiffness a taut string (Biot strain, no bending, no gravity, tension T = EA p) offers
    # the pin it hangs from, moved with the pin: axially EA/L0 (L0 = L/(1 + p) its unstretched length), transversally
    # the geometric stiffness T/L; the element is exact for both (linear fields): 1e-8 is round-off of the solve
    EA, L, p = 1e6, 2.0, 1e-3
    s = Scene(dim=2, gravity=(0.0, 0.0))
    s.member("line", [(0, 0), (L, 0)], 6, Material(E=EA / 1e-4, density=1000.0), Section(area=1e-4), axial="biot",
             bending=False, prestrain=p)
    s.pin("line", "start")
    s.pin("line", "end")
    K = linearize(s).condensed_stiffness([("line", "end")])
    assert np.allclose(np.diag(K), [EA * (1 + p) / L, EA * p / L], rtol=1e-8)
    assert abs(K[0, 1]) < 1e-8 * EA / L
    with pytest.raises(SceneError, match="at='middle'"):
        linearize(s).condensed_stiffness([("line", "middle")])


def test_linearize_matrices():
    lin = linearize(cantilever(4))
    n = lin.size
    assert lin.M.shape == lin.K.shape == (n, n) and lin.G.shape == (0, n) and lin.D is None
    assert lin.B.shape == (n, 2 * 5) and len(lin.inputs) == 10  # 5 nodes x (x, y)
    # B maps a tip force to the tip's coordinate: the static response K^-1 B u is the tip deflection F L^3 / 3EI
    u = np.zeros(10)
    u[lin.inputs.index(("beam", 4, "y"))] = 1.0
    dy = lin.full(np.linalg.solve(lin.K.toarray(), lin.B @ u))
    tip = lin.assembly.mesh.members["beam"].node_dofs(4)[1]
    assert np.isclose(dy[tip], 1.0 / (3 * STEEL.E * BAR.bending_inertia), rtol=1e-8)


def test_rayleigh_damping_matrix():
    s = cantilever(4)
    s.rayleigh(alpha=0.5, beta=1e-4)
    lin = linearize(s)
    assert np.allclose(lin.D.toarray(), 0.5 * lin.M.toarray() + 1e-4 * lin.K.toarray(), rtol=1e-10, atol=1e-12)


def test_bad_input_refused():
    s = cantilever(4)
    for bad in (0, -1, 2.5, "3", True):
        with pytest.raises(SceneError, match="modes"):
            modal_analysis(s, modes=bad)
    with pytest.raises(SceneError, match="modes = 100 exceeds"):
        modal_analysis(s, modes=100)
    free = Scene(dim=2, gravity=(0.0, -G))
    free.member("beam", [(0, 0), (1.0, 0)], 4, STEEL, BAR)
    with pytest.raises(SceneError, match="free structure"):
        modal_analysis(free, modes=2)


SAGGING = __import__("pathlib").Path(__file__).resolve().parents[2] / "examples" / "scenes" / "sagging_cable_modes.toml"


def test_cli_modal_run(tmp_path):
    # `ancf-sym run` of the sagging-cable scene: result.json with the equilibrium under a statics result's keys and
    # the modes; the first two against Irvine (lambda^2 = 100, sag/span 1/50: 5e-3, as in test_irvine_sagging_cable)
    import json

    import meshio

    from helpers import cli

    out = tmp_path / "modes"
    r = cli("run", SAGGING, "--out", out, "--quiet", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    doc = json.loads((out / "result.json").read_text())
    assert doc["success"] and doc["static_success"] and doc["analysis"]["type"] == "modal"
    assert len(doc["frequencies"]) == 6 and doc["frequencies"] == sorted(doc["frequencies"])
    H = abs(doc["constraint_forces"]["pin cable@start"][0])
    f0 = np.sqrt(H / 1.0) / 100.0  # sqrt(H/m)/L [Hz]: the antisymmetric mode
    assert abs(doc["frequencies"][0] / f0 - 1) < 5e-3 and abs(doc["frequencies"][1] / (1.298698 * f0) - 1) < 5e-3
    assert len(doc["members"]["cable"]["nodes"]) == 41
    assert len(doc["modes"][0]["members"]["cable"]["displacements"]) == 41
    assert 40 < doc["modal_masses"][0] < 60  # a half sine of a 100 kg cable: 50 kg
    vtu = meshio.read(out / "modes.vtu")
    assert vtu.point_data["mode_6"].shape == (len(vtu.points), 3)
    assert (out / "modes.png").stat().st_size > 10_000


def test_toml_modal_keys(tmp_path):
    from ancf_sym.io.scene_toml import load_scene

    text = SAGGING.read_text()
    scene, analysis = load_scene(SAGGING)
    assert analysis == {"type": "modal", "modes": 6}
    for bad, match in (("modes = 0", "analysis.modes"), ("modes = 2.5", "analysis.modes"),
                       ("mode = 6", "analysis.*mode")):
        p = tmp_path / "bad.toml"
        p.write_text(text.replace("modes = 6", bad))
        with pytest.raises(SceneError, match=match):
            load_scene(p)


def test_examples_modal(tmp_path_factory):
    # the examples' quick runs: each case's finest mesh within its tolerance (the tests above give the reasons; the
    # coarser meshes are there for the refinement figure)
    from helpers import run_example

    _, beams = run_example("modal_beams", tmp_path_factory)
    _, cables = run_example("modal_cables", tmp_path_factory)
    tol = {"cantilever": 1e-3, "free_free": 1e-5, "foundation": 1e-2, "beam3d_z": 3e-3, "beam3d_y": 3e-3,
           "beam3d_torsion": 2e-3, "hanging_chain": 1e-3, "taut_string": 1e-4, "irvine": 5e-3}
    finest = {}
    for rec in beams + cables:
        finest[rec["case"]] = max(finest.get(rec["case"], 0), rec["n"])
    for rec in beams + cables:
        if rec["n"] == finest[rec["case"]]:
            assert rec["rel_error"] < tol[rec["case"]], rec
    assert sum(r["zero"] for r in beams if r["case"] == "free_free") == 3


def test_column_frequency_falls_to_zero_at_the_euler_load():
    # a clamped-free column under a dead axial tip load P (EI = 1, EA = 1e5, no gravity): the geometric stiffness of
    # the prestress lowers w1^2 to zero at P_cr = pi^2 EI / (4 L^2); the straight state past it (statics asked not
    # to leave the saddle) is unstable: w1^2 < 0, a negative frequency. w1^2(P) is nearly linear near P_cr: the
    # secant through 0.95 and 0.99 P_cr reaches zero within 1e-3 of P_cr (the extensibility shifts P_cr by ~P/EA
    # ~ 2e-5, the mesh by less)
    from ancf_sym import StaticOptions

    pcr = np.pi ** 2 / 4

    def w2(f: float) -> tuple[float, bool]:
        s = Scene(dim=2, gravity=(0.0, 0.0))
        s.member("col", [(0, 0), (0, 1.0)], 16, Material(E=1e5, density=1.0), Section(area=1.0, I=1e-5),
                 axial="decoupled")
        s.clamp("col", "start")
        s.force("col", "end", (0.0, -f * pcr))
        r = modal_analysis(s, modes=2, options=StaticOptions(escape_saddle=False))
        return float(r.omega2[0]), bool(r.static.stable)

    (a, sa), (b, sb), (c, sc) = w2(0.95), w2(0.99), w2(1.1)
    zero = 0.99 + b * (0.99 - 0.95) / (a - b)
    assert a > b > 0 and sa and sb and abs(zero - 1) < 1e-3
    assert c < 0 and not sc


@pytest.mark.parametrize("split", [False, True])
def test_damped_modes_rayleigh(split):
    # Rayleigh damping alpha M + beta K on an unloaded cantilever (K_el = K: proportional damping): each mode's
    # damping ratio is alpha/(2 w) + beta w/2 and its damped frequency w sqrt(1 - zeta^2), exactly (the same pencil):
    # 1e-8 is round-off of the Arnoldi solve. split: two members joined rigidly (a multiplier row: the projected
    # first-order operator)
    mat, sec = Material(E=2e11, density=7800.0), Section.rectangle(0.01, 0.01)
    s = Scene(dim=2, gravity=(0.0, 0.0))
    if split:
        s.member("a", [(0, 0), (0.5, 0)], 8, mat, sec)
        s.member("b", [(0.5, 0), (1.0, 0)], 8, mat, sec)
        s.rigid(("a", "end"), ("b", "start"))
    else:
        s.member("a", [(0, 0), (1.0, 0)], 16, mat, sec)
    s.clamp("a", "start")
    alpha, beta = 2.0, 1e-4
    s.rayleigh(alpha=alpha, beta=beta)
    r = modal_analysis(s, modes=4, damped=True)
    assert (r.linearization.G.shape[0] > 0) == split
    w = np.sqrt(r.omega2)
    zeta = alpha / (2 * w) + beta * w / 2
    assert np.allclose(r.damped.damping_ratios, zeta, rtol=1e-8)
    assert np.allclose(r.damped.frequencies, w * np.sqrt(1 - zeta ** 2) / (2 * np.pi), rtol=1e-8)


def test_damped_modes_strain_rate():
    # Kelvin-Voigt bending damping (moment c_b kappa_dot) on an unloaded cantilever: for its bending modes D = (c_b /
    # EI) K_bending, so zeta = c_b w / (2 EI) exactly (D from the dynamics' AD graph of the dissipation; 1e-8: the
    # Arnoldi solve's round-off). Modes 1-3 only: higher ones are overdamped (zeta > 1), their slow real roots
    # -w (zeta - sqrt(zeta^2 - 1)) -> -EI / c_b come next by |lambda|
    s = cantilever(16)
    EI = STEEL.E * BAR.bending_inertia
    cb = 1e-3 * EI
    s.strain_rate_damping(bending=cb)
    r = modal_analysis(s, modes=4, damped=True)
    w = np.sqrt(r.omega2[:3])
    zeta = cb * w / (2 * EI)
    assert np.allclose(r.damped.damping_ratios[:3], zeta, rtol=1e-8)
    assert np.allclose(r.damped.frequencies[:3], w * np.sqrt(1 - zeta ** 2) / (2 * np.pi), rtol=1e-8)


def test_hinge_identified_penalty_and_mechanism():
    # a beam clamped at 0, hinged at midspan (identified coordinates: the reduced map E sums them), pinned at 1 m:
    # the same modes as with a penalty hinge (its springs 1e3 EA/L stiff: their compliance shifts w^2 by
    # ~1e-6, below the 1e-5 asked); pinned - hinge - pinned is a mechanism: exactly one zero mode, then elastic ones
    def scene(method: str, first: str = "clamp") -> Scene:
        s = Scene(dim=2, gravity=(0.0, 0.0))
        s.member("a", [(0, 0), (0.5, 0)], 8, STEEL, BAR)
        s.member("b", [(0.5, 0), (1.0, 0)], 8, STEEL, BAR)
        if method == "exact":
            s.hinge(("a", "end"), ("b", "start"))
        else:
            s.hinge(("a", "end"), ("b", "start"), method="penalty", penalty=1e3)
        getattr(s, first)("a", "start")
        s.pin("b", "end")
        return s

    exact, pen = modal_analysis(scene("exact"), modes=3), modal_analysis(scene("penalty"), modes=3)
    assert not np.any(exact.zero) and np.allclose(exact.frequencies, pen.frequencies, rtol=1e-5)
    mech = modal_analysis(scene("exact", first="pin"), modes=3)
    assert list(mech.zero) == [True, False, False] and mech.frequencies[1] > 10.0


def test_condensed_stiffness_of_a_sagging_line_against_moved_pins():
    # a sagging line's stiffness at its end pin (a fairlead) against the derivative of the pin's reaction when the
    # pin is moved and the statics solved again (central differences of a solver output: a derivative check, the
    # only place finite differences belong). Moving the pin keeps the unstretched length (the prestrain follows the
    # chord). The reaction is the multiplier lambda of the pin's rows (grad Pi + lambda = 0 there): the force on the
    # pin is -lambda, so K = -d lambda / d u. The differences' error falls as delta^2 (measured 3.2e-3, 3.2e-5,
    # 3.2e-7 of the axial entry at delta = 10, 1, 0.1 mm: the sag makes the axial stiffness strongly nonlinear); at
    # 0.1 mm 1e-5 relative per entry is asked
    span, A, rho, EA = 100.0, 1e-3, 1000.0, 2.4e7
    unstretched = span / (1 - 8.105e-4)

    def line(end) -> Scene:
        chord = float(np.hypot(*end))
        s = Scene(dim=2, gravity=(0.0, -G))
        s.member("line", [(0, 0), tuple(end)], 40, Material(E=EA / A, density=rho), Section(area=A), bending=False,
                 prestrain=chord / unstretched - 1)
        s.pin("line", "start")
        s.pin("line", "end")
        return s

    K = linearize(line((span, 0.0))).condensed_stiffness([("line", "end")])
    d = 1e-4
    Kfd = np.zeros((2, 2))
    for j in range(2):
        lam = []
        for sgn in (1, -1):
            end = np.array([span, 0.0])
            end[j] += sgn * d
            r = modal_analysis(line(end), modes=1).static  # (the statics through the same entry point)
            lam.append(np.array(r.constraint_forces["pin line@end"]))
        Kfd[:, j] = -(lam[0] - lam[1]) / (2 * d)
    assert np.allclose(np.diag(K), np.diag(Kfd), rtol=1e-5)
    # a symmetric sag: uncoupled; the differences' own noise is the statics' tolerance, ~1e-10 L K / 2 delta
    assert abs(K[0, 1]) < 1e-9 * K[0, 0] and abs(Kfd[0, 1]) < 1e-6 * K[0, 0]


def test_compound_pendulum_body():
    # a rigid body on a revolute joint: its rows keep multipliers and the body's unit-vector row is quadratic, and
    # gravity's potential is linear in the coordinates: all the stiffness is sum lambda_i Hess(Phi_i) (without it
    # the frequency would be 0). Small oscillations at sqrt(m g d / (I_c + m d^2)) exactly (one degree of freedom)
    m, Ic, d = 2.0, 0.05, 0.3
    s = Scene(dim=2, gravity=(0.0, -G))
    s.body("b", m, Ic, (0.0, -d))
    s.revolute("b", point=(0.0, 0.0))
    r = modal_analysis(s, modes=1)
    assert r.linearization.G.shape[0] > 0
    assert np.isclose(r.frequencies[0], np.sqrt(m * G * d / (Ic + m * d * d)) / (2 * np.pi), rtol=1e-9)
    assert np.isclose(r.modal_masses[0], (Ic + m * d * d) / d ** 2, rtol=1e-9)  # the centre moves d per radian


def test_damped_free_structure_zero_modes():
    # a free bar with mass-proportional damping alpha: each rigid mode is one lambda = 0 (reported first, exactly)
    # and the real root -alpha (its velocity decays: M v' = -alpha M v), which come next by |lambda|; then the
    # elastic ones with zeta = alpha / (2 w) (proportional damping: exact to the solve's round-off)
    s = cantilever(60, free=True)
    s.rayleigh(alpha=3.0)
    r = modal_analysis(s, modes=8, damped=True)
    lam = r.damped.eigenvalues
    assert list(r.zero) == [True] * 3 + [False] * 5
    assert np.all(lam[:3] == 0) and np.all(np.isnan(r.damped.damping_ratios[:3]))
    # (-alpha up to the rigid modes' round-off: lambda^2 + alpha lambda + w^2 = 0 with |w^2| at its round-off moves
    # the root by ~w^2 / alpha)
    assert np.allclose(lam[3:6], -3.0, rtol=0, atol=3 * np.abs(r.omega2[:3]).max() / 3.0 + 1e-12)
    w = np.sqrt(r.omega2[3:5])
    assert np.allclose(r.damped.damping_ratios[6:8], 3.0 / (2 * w), rtol=1e-8)


def test_exact_contact_is_the_limit_of_penalty_contact():
    # a cantilever sagging onto a drum's crest (radius 0.5 m, under x = 0.6125 m, at half the free deflection there):
    # with exact contact one point holds it (the Gauss point nearest the crest), an equality row of the linear
    # model; a linear penalty contact of stiffness k tends to it: the frequencies' difference falls as 1/k
    # (measured 2.9e-2, 2.9e-3, 2.9e-4 on mode 1, 0.25, 1.3e-2, 1.1e-3 on mode 3 at k = 1e7, 1e8, 1e9 N/m^2).
    # (A ground under the free tip is no such case: the tip lies beyond the law's last point, the penalty law never
    # sees it and statics refuses the state, docs/contact.md "What the law samples".)
    x0, radius = 0.6125, 0.5

    def scene(k: float | None, top: float = 0.0) -> Scene:
        s = Scene(dim=2, gravity=(0.0, -G))
        s.member("beam", [(0, 0.0), (1.0, 0.0)], 8, STEEL, BAR)
        s.clamp("beam", "start")
        if k is None:
            s.contact_drum("beam", centre=(x0, top - radius), radius=radius, method="exact", thickness=0.005, gauss=3)
        elif k > 0:
            s.contact_drum("beam", centre=(x0, top - radius), radius=radius, stiffness=k, thickness=0.005, gauss=3)
        return s

    free = modal_analysis(scene(0), modes=1).static
    top = 0.5 * np.interp(x0, free.nodes("beam")[:, 0], free.nodes("beam")[:, 1]) - 0.005
    exact = modal_analysis(scene(None, top), modes=3)
    assert exact.success and exact.linearization.G.shape[0] == 1
    d = [np.abs(modal_analysis(scene(k, top), modes=3).frequencies / exact.frequencies - 1) for k in (1e7, 1e8, 1e9)]
    # 1/k: each decade of k divides the difference by about 10 (> 5 asserted); at 1e9 within 2e-3 (mode 3's 1.3e-2
    # at 1e8 divided by 10, with margin)
    assert np.all(d[0] > 5 * d[1]) and np.all(d[1] > 5 * d[2]) and np.all(d[2] < 2e-3)
    with pytest.raises(SceneError, match="exact contact needs its static result"):
        linearize(scene(None), exact.static.x)


def test_exact_drum_contact_is_the_limit_of_penalty_contact():
    # a taut rope (pinned 2 m apart, prestrain 1e-3) lifted over a fixed drum: the points on the drum (the gap
    # kernel's rows) are held; penalty drum contact tends to it as 1/k (measured 3.6e-4 -> 3.6e-5 on mode 1 from
    # k = 1e8 to 1e9 N/m^2)
    def scene(k: float | None) -> Scene:
        s = Scene(dim=2, gravity=(0.0, 0.0))
        s.member("rope", [(-1.0, 0.0), (1.0, 0.0)], 24, Material(E=1e9, density=1000.0), Section(area=1e-4, I=1e-12),
                 prestrain=1e-3)
        s.pin("rope", "start")
        s.pin("rope", "end")
        opts = {"method": "exact"} if k is None else {"stiffness": k}
        s.contact_drum("rope", centre=(0.0, -0.25), radius=0.3, thickness=0.0, **opts)
        return s

    exact = modal_analysis(scene(None), modes=3)
    assert exact.success and exact.linearization.G.shape[0] >= 1
    d = [np.abs(modal_analysis(scene(k), modes=3).frequencies / exact.frequencies - 1) for k in (1e8, 1e9)]
    assert np.all(d[0] > 5 * d[1]) and np.all(d[1] < 1e-3)
