"""The 6 x 6 mooring stiffness of a free spatial body held by its lines (ancf_sym.water.body_mooring_stiffness).

1. Taut straight lines against the closed form: per line K_i = EA / L0 n n' + T / l (I - n n') at its attachment
   point a_i, moved to the reference point p by the lever s_i = a_i - p, and the line's force f_i = T n_i turning
   with the lever: K = sum [[K_i, -K_i [s_i]x], [[s_i]x K_i, -[s_i]x K_i [s_i]x - [f_i]x [s_i]x]]. Straight lines
   are exact for the cubic elements, so what remains is round-off: 1e-9 relative.
2. The same mooring turned by a rotation R: K' = blockdiag(R, R) K blockdiag(R, R)' (1e-9).
3. A body on three slack catenaries (weight, buoyancy as an upward force) against central differences of the
   statics: the lines alone, their fairleads pinned where a rigid motion of the body (a translation of a fairlead
   and a turn about it) puts them, the force and moment of the lines on the body about the moved fairlead. The
   lines are straight members with a negative prestrain (natural length L), so every moved scene is the same
   discrete model; central differences err by (h / l)^2 with l >= 1 m the smallest lever, 1e-6 at h = 1 mm.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from ancf_sym import Material, Scene, SceneError, Section, solve_static
from ancf_sym.water import body_mooring_stiffness

MAT, SEC = Material(E=1e9, density=1000.0), Section.circle(0.02)
EA = 1e9 * SEC.area
SPAN = 10.0
# three pairs of opposite lines along n, attached at +-arm n + offset (no net force or moment), prestrain, arm [m]
PAIRS = [(np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.3, -0.2]), 0.01, 1.0),
         (np.array([0.0, 1.0, 0.0]), np.array([0.4, 0.0, 0.1]), 0.02, 0.8),
         (np.array([0.0, 0.0, 1.0]), np.array([-0.2, 0.5, 0.0]), 0.005, 1.2)]


def skew(v: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def taut(R: np.ndarray = np.eye(3)) -> Scene:
    s = Scene(dim=3, gravity=[0.0, 0.0, 0.0])
    s.body("p", 10.0, [1.0, 2.0, 2.5], [0.0, 0.0, 0.0], axes=R.T)
    k = 0
    for n, o, pre, arm in PAIRS:
        for side in (1.0, -1.0):
            a = R @ (side * arm * n + o)
            s.member(f"l{k}", [tuple(a), tuple(a + SPAN * (R @ (side * n)))], 2, MAT, SEC, axial="biot",
                     bending=False, prestrain=pre)
            s.pin_body("p", f"l{k}", "start")
            s.pin(f"l{k}", at="end")
            k += 1
    s.set_water(density=1000.0, surface=100.0)
    return s


def closed_form(R: np.ndarray = np.eye(3), p: np.ndarray = np.zeros(3)) -> np.ndarray:
    K = np.zeros((6, 6))
    for n, o, pre, arm in PAIRS:
        for side in (1.0, -1.0):
            a, u = R @ (side * arm * n + o), R @ (side * n)
            T, L0 = EA * pre, SPAN / (1.0 + pre)
            Ki = EA / L0 * np.outer(u, u) + T / SPAN * (np.eye(3) - np.outer(u, u))
            S = skew(a - p)
            K += np.block([[Ki, -Ki @ S], [S @ Ki, -S @ Ki @ S - skew(T * u) @ S]])
    return K


@pytest.fixture(scope="module")
def taut_result():
    r = solve_static(taut())
    assert r.success
    return r


@pytest.mark.parametrize("point", [None, (0.3, -0.5, 0.7)])
def test_taut_lines_match_the_closed_form(taut_result, point):
    K = body_mooring_stiffness(taut_result, "p", point=point)
    ref = closed_form(p=np.zeros(3) if point is None else np.asarray(point))
    assert abs(ref[3, 4]) > 1e3 and abs(ref[0, 4]) > 1e3  # (couplings present: a check that can fail)
    assert np.abs(K - ref).max() <= 1e-9 * np.abs(ref).max()


def test_turned_mooring_turns_its_stiffness(taut_result):
    R = Rotation.from_rotvec([0.3, -0.5, 0.8]).as_matrix()
    r = solve_static(taut(R))
    assert r.success
    K = body_mooring_stiffness(r, "p")
    B = np.kron(np.eye(2), R)
    K0 = body_mooring_stiffness(taut_result, "p")
    assert np.abs(K - B @ K0 @ B.T).max() <= 1e-9 * np.abs(K0).max()


# -- a body on slack catenaries ------------------------------------------------------------------------------------
CMAT, CSEC = Material(E=2e11, density=7850.0), Section.circle(0.05)
CENTRE = np.array([0.0, 0.0, -5.0])
LINES = [(0.0, 60.0, 80.0), (110.0, 55.0, 76.0), (235.0, 65.0, 84.0)]  # anchor bearing [deg], radius [m], length [m]


def anchors() -> list:
    return [rad * np.array([math.cos(math.radians(b)), math.sin(math.radians(b)), 0.0]) + [0.0, 0.0, -50.0]
            for b, rad, _ in LINES]


def catenaries(fairleads: list | None = None) -> Scene:
    """The body on its lines (fairleads None), or the lines alone pinned at the given fairleads."""
    s = Scene(dim=3, gravity=[0.0, 0.0, -9.81])
    if fairleads is None:
        s.body("b", 1000.0, [800.0, 800.0, 1200.0], CENTRE, force=[0.0, 0.0, 3.5e4])
        fairleads = [CENTRE + 2.0 * (an - CENTRE) * [1, 1, 0] / np.linalg.norm((an - CENTRE)[:2]) - [0, 0, 1.0]
                     for an in anchors()]
        body = True
    else:
        body = False
    for k, (fl, an) in enumerate(zip(fairleads, anchors())):
        s.member(f"l{k}", [tuple(fl), tuple(an)], 4, CMAT, CSEC, axial="biot", bending=False,
                 prestrain=float(np.linalg.norm(an - fl)) / LINES[k][2] - 1.0)
        if body:
            s.pin_body("b", f"l{k}", "start")
        else:
            s.pin(f"l{k}", at="start")
        s.pin(f"l{k}", at="end")
    s.set_water(density=1025.0)
    return s


def test_catenary_moored_body_against_central_differences():
    r = solve_static(catenaries())
    assert r.success
    asm = r.water.asm
    off = asm.mesh.bodies["b"]
    fl0 = [r.x[asm.mesh.members[f"l{k}"].node_dofs(asm.mesh.members[f"l{k}"].node("start"))[:3]] for k in range(3)]
    p = fl0[0]

    def wrench(z: np.ndarray) -> np.ndarray:
        """Force and moment about the moved p of the lines on the body moved by z = (u, theta) about p."""
        R, pp = Rotation.from_rotvec(z[3:]).as_matrix(), p + z[:3]
        moved = [pp + R @ (f - p) for f in fl0]
        rr = solve_static(catenaries(moved), warm_start=r.x[:off])
        assert rr.success
        f = [np.asarray(rr.constraint_forces[f"pin l{k}@start"]) for k in range(3)]  # (the lines' force on the pins)
        return np.r_[sum(f), sum(np.cross(m - pp, fk) for m, fk in zip(moved, f))]

    W0 = wrench(np.zeros(6))
    assert abs(W0[2] + (3.5e4 - 9.81e3)) < 1e-6 * 3.5e4  # (the lines hold the body's net lift down)
    h = 1e-3
    Kfd = np.column_stack([-(wrench(h * e) - wrench(-h * e)) / (2 * h) for e in np.eye(6)])
    K = body_mooring_stiffness(r, "b", point=p)
    assert np.abs(K - Kfd).max() <= 1e-5 * np.abs(K).max()
    assert np.abs(K - K.T).max() > 1e-2 * np.abs(K).max()  # about a fairlead the lines' force turns with the lever
    Kc = body_mooring_stiffness(r, "b")  # about the centre (only centre loads besides the lines): symmetric
    assert np.abs(Kc - Kc.T).max() <= 1e-9 * np.abs(Kc).max()


def test_bad_point_is_refused(taut_result):
    with pytest.raises(SceneError, match="point"):
        body_mooring_stiffness(taut_result, "p", point=(0.0, 1.0))


def test_moored_body_modes_are_those_of_its_stiffness():
    # a heavy body (1000 t) on the six taut lines: its six modes (0.02-0.1 Hz, the lines' own above 2 Hz, so the
    # lines follow quasi-statically) are the eigenvalues of (K, diag(m, m, m, I)) with K its 6 x 6; the lines' mass
    # with their added mass (38 kg, at arms ~1 m against the body's radii of gyration ~0.4 m) shifts them by its
    # fraction, ~1e-5 (measured 1e-5 - 5e-5; 100x that with a 100x lighter body): within 1e-4
    import scipy.linalg as la

    from ancf_sym.modal import modal_analysis

    mb, ib = 1e6, np.array([1e5, 2e5, 2.5e5])
    s = Scene(dim=3, gravity=[0.0, 0.0, 0.0])
    s.body("p", mb, ib, [0.0, 0.0, 0.0])
    k = 0
    for n, o, pre, arm in PAIRS:
        for side in (1.0, -1.0):
            a = side * arm * n + o
            s.member(f"l{k}", [tuple(a), tuple(a + SPAN * side * n)], 4, MAT, SEC, axial="biot", bending=False,
                     prestrain=pre)
            s.pin_body("p", f"l{k}", "start")
            s.pin(f"l{k}", at="end")
            k += 1
    s.set_water(density=1000.0, surface=100.0, lines={f"l{i}": {"ca": 1.0} for i in range(6)})
    r = modal_analysis(s, modes=6)
    assert r.success
    K = body_mooring_stiffness(r.static, "p")
    f = np.sqrt(la.eigh(K, np.diag(np.r_[mb, mb, mb, ib]), eigvals_only=True)) / (2 * np.pi)
    assert np.all(np.abs(r.frequencies / f - 1) < 1e-4)


def test_planar_body_about_a_point_is_the_spatial_formula_in_the_plane():
    # the planar 3 x 3 about an off-centre point: the (u_x, u_y, theta_z) block of the spatial closed form of the
    # same lines (in the plane z = 0), to round-off (1e-9)
    s = Scene(dim=2, gravity=[0.0, 0.0])
    s.body("p", 10.0, 1.0, [0.0, 0.0])
    lines = [(np.array([1.0, 0.0]), np.array([0.0, 0.3]), 0.01), (np.array([-1.0, 0.0]), np.array([0.0, 0.3]), 0.01),
             (np.array([0.0, 1.0]), np.array([0.2, 0.0]), 0.02), (np.array([0.0, -1.0]), np.array([0.2, 0.0]), 0.02)]
    for k, (n, o, pre) in enumerate(lines):
        a = n + o
        s.member(f"l{k}", [tuple(a), tuple(a + SPAN * n)], 2, MAT, SEC, axial="biot", bending=False, prestrain=pre)
        s.pin_body("p", f"l{k}", "start")
        s.pin(f"l{k}", at="end")
    s.set_water(density=1000.0, surface=10.0)
    r = solve_static(s)
    assert r.success
    p = np.array([0.4, -0.7])
    ref = np.zeros((6, 6))
    for n, o, pre in lines:
        n3, a3 = np.r_[n, 0.0], np.r_[n + o, 0.0]
        T, L0 = EA * pre, SPAN / (1.0 + pre)
        Ki = EA / L0 * np.outer(n3, n3) + T / SPAN * (np.eye(3) - np.outer(n3, n3))
        S = skew(a3 - np.r_[p, 0.0])
        ref += np.block([[Ki, -Ki @ S], [S @ Ki, -S @ Ki @ S - skew(T * n3) @ S]])
    ref = ref[np.ix_([0, 1, 5], [0, 1, 5])]
    K = body_mooring_stiffness(r, "p", point=p)
    assert abs(ref[0, 2]) > 1e2 and abs(ref[1, 2]) > 1e2
    assert np.abs(K - ref).max() <= 1e-9 * np.abs(ref).max()
