"""Angled beam3d frames under mesh refinement against linear frame theory: two members joined by `rigid`, and one
bent member (a polyline corner), loaded in their plane and normal to it (torsion), both beam methods.

The frame: steel bars of rectangular section b x h = 0.04 x 0.02 m, leg a = 1 m along x clamped at the origin, leg
c = 0.6 m along y from its end, a load P at the free tip. Two members: sections with b in the frame's plane; the bent
member: y_axis normal to the plane (b normal to it), so the two cases bend about different section axes.
- in plane (P along -x): tip displacement P c^3 / (3 E I) + P c^2 a / (E I) + P a / (E A), I about the plane's
  normal;
- normal to the plane (P along z): P a^3 / (3 E I') + P c^2 a / (G J) + P c^3 / (3 E I'), I' about the in-plane
  axis, J = Section.rectangle's torsion constant, which both forms use (elastic line: line_torsion's G J;
  continuum: its torsion factor makes a uniform twist cost exactly G J, tests/statics/test_beam_locking.py).
The elastic line bends through the centre line's curvature: its limit is Euler-Bernoulli (the formulas above). The
continuum bends through its section field and resists transverse shear with G A (no correction factor): its limit
adds the shear of each leg that carries a transverse force, P c / (G A) in plane, P (a + c) / (G A) normal to it
(relative 1e-4 to 1e-3 here). Both limits are checked by a single cantilever in tests/statics/test_beam_locking.py.

Tolerances: the load is small (P = 0.01 N, tip deflection <= 1e-6 m) so geometric nonlinearity, of relative size
w / L <= 1e-6, stays below the discretisation error; the elements' error falls about as 1 / n^2 (measured 2e-4 to
5e-4 at 16 elements, a few 1e-5 at 64). The figure asked of a frame is 2e-3 at 16, 64 and 256 elements per member,
and the error must fall from 16 to 64 and not grow past 64 (beyond the 2e-6 of round-off and nonlinearity).
Before the joints tied consistent frames, the in-plane error grew like n (+1.2 %, +4.1 %, +16 % elastic line).
"""
from __future__ import annotations

import numpy as np
import pytest

from ancf_sym import Material, Scene, Section, solve_static

E, NU, B, H = 2e11, 0.3, 0.04, 0.02
SEC = Section.rectangle(B, H)
G = E / (2 * (1 + NU))
A_SEC = B * H
IY, IZ = B * H**3 / 12, H * B**3 / 12  # about the section's y axis (b along y), about its z axis
LEG_A, LEG_C, P = 1.0, 0.6, 0.01
METHODS = ("elastic_line", "continuum")
FLOOR = 2e-6  # round-off and geometric nonlinearity (w / L <= 1e-6) below which "not growing" is not asked


def _frame(method: str, n: int, load: str, bent: bool) -> tuple[Scene, str]:
    s = Scene(dim=3, gravity=(0.0, 0.0, 0.0))
    kw = dict(element="beam3d", beam_method=method, section=SEC, material=Material(E=E, density=7850.0, poisson=NU),
              gravity=False, torsion=method == "elastic_line")
    if bent:  # one member, a polyline corner; its elements split by length: n per leg on average
        s.member("m", points=[(0, 0, 0), (LEG_A, 0, 0), (LEG_A, LEG_C, 0)], elements=2 * n, y_axis=(0, 0, 1), **kw)
        s.clamp("m", at="start")
        tip = "m"
    else:
        s.member("m1", points=[(0, 0, 0), (LEG_A, 0, 0)], elements=n, y_axis=(0, 1, 0), **kw)
        s.member("m2", points=[(LEG_A, 0, 0), (LEG_A, LEG_C, 0)], elements=n, y_axis=(-1, 0, 0), **kw)
        s.clamp("m1", at="start")
        s.rigid(("m1", "end"), ("m2", "start"))
        tip = "m2"
    s.force(tip, at="end", force=(-P, 0.0, 0.0) if load == "in_plane" else (0.0, 0.0, P))
    return s, tip


def frame_theory(method: str, load: str, bent: bool) -> float:
    """Tip displacement along the load by linear frame theory (module docstring), with the continuum's shear."""
    i_in, i_out = (IY, IZ) if bent else (IZ, IY)  # bent: section y normal to the plane
    a, c = LEG_A, LEG_C
    if load == "in_plane":
        w = P * c**3 / (3 * E * i_in) + P * c**2 * a / (E * i_in) + P * a / (E * A_SEC)
        return w + (P * c / (G * A_SEC) if method == "continuum" else 0.0)
    w = P * a**3 / (3 * E * i_out) + P * c**2 * a / (G * SEC.J) + P * c**3 / (3 * E * i_out)
    return w + (P * (a + c) / (G * A_SEC) if method == "continuum" else 0.0)


def frame_error(method: str, n: int, load: str, bent: bool) -> float:
    s, tip = _frame(method, n, load, bent)
    r = solve_static(s)
    assert r.success, r.status
    x = r.nodes(tip)[-1]
    w = LEG_A - x[0] if load == "in_plane" else x[2]
    return w / frame_theory(method, load, bent) - 1


CASES = [(m, load, bent) for bent in (False, True) for load in ("in_plane", "normal") for m in METHODS]
IDS = [f"{'bent' if bent else 'two_members'}-{load}-{m}" for m, load, bent in CASES]


def _check(errs: list[float], ns: list[int], coarse: float = 2e-3) -> None:
    """Within 2e-3 (the first mesh within `coarse`), falling from the first mesh to the second, not growing after."""
    e = np.abs(errs)
    assert e[0] <= coarse and np.all(e[1:] <= 2e-3), dict(zip(ns, errs))
    assert e[1] < e[0], f"no fall from {ns[0]} to {ns[1]} elements: {dict(zip(ns, errs))}"
    assert np.all(e[2:] <= np.maximum(e[1:-1], FLOOR)), f"error grows: {dict(zip(ns, errs))}"


@pytest.mark.parametrize("method,load,bent", CASES, ids=IDS)
def test_frame_converges_to_frame_theory(method, load, bent):
    ns = [16, 64, 256]  # (about 1 s a case)
    _check([frame_error(method, n, load, bent) for n in ns], ns)


def _joined_otherwise(method: str, n: int, load: str, how: str) -> float:
    """The two-member frame with its corner made another way: a penalty rigid joint (factor 1e3 on both kinds of
    row), or a small rigid body at the corner that both members' end nodes are tied to (rigid_body)."""
    s, tip = _frame(method, n, load, False)
    s.joints.clear()
    if how == "penalty":
        s.rigid(("m1", "end"), ("m2", "start"), method="penalty", penalty=1e3)
    else:
        s.body("corner", mass=1e-3, inertia=(1e-6, 1e-6, 1e-6), position=(LEG_A, 0.0, 0.0))
        s.rigid_body("corner", "m1", at="end")
        s.rigid_body("corner", "m2", at="start")
    r = solve_static(s)
    assert r.success, r.status
    x = r.nodes(tip)[-1]
    return (LEG_A - x[0] if load == "in_plane" else x[2]) / frame_theory(method, load, False) - 1


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("load", ["in_plane", "normal"])
def test_penalty_joint_adds_only_its_own_compliance(method, load):
    """The penalty joint's rows are the exact joint's, so its error is the penalty's compliance, the same at every
    mesh: a moment M through rotation rows of stiffness 1e3 E I / (1 m) adds about M c / (1e3 E I) to the tip,
    8.3e-4 of the in-plane deflection (P c^2 / (1e3 E I) against the leading P c^2 a / (E I), a = 1 m) and 1.2e-4
    normal to the plane (measured, 8.3e-4 and 1.2e-4 at 64 and 256 elements). 2e-3 bounds it; between 64 and 256
    elements it may not change by more than 1e-4 (the exact joint's discretisation error there is below 4e-5)."""
    e = [_joined_otherwise(method, n, load, "penalty") for n in (16, 64, 256)]
    assert max(abs(v) for v in e) <= 2e-3, e
    assert abs(e[2] - e[1]) <= 1e-4, e


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("load", ["in_plane", "normal"])
def test_corner_body_converges_to_frame_theory(method, load):
    """Body-to-node rigid joints tie all of a node's gradients to the body (a clamp into it): no node mode is left
    to carry the moment, and the corner body (zero size: both nodes at its centre) converges like the rigid joint."""
    ns = [16, 64, 256]
    _check([_joined_otherwise(method, n, load, "body") for n in ns], ns)


@pytest.mark.parametrize("method", METHODS)
def test_rigid_joint_rows_see_rotations_only(method):
    """The rigid joint's rotation rows at the reference state: zero after any finite rigid rotation of the whole
    scene (they are sums of dot products of gradients), 3 independent rows (3 relative rotations, no redundant row),
    and blind to the node modes the form resists only over one element (a stiffness that vanishes with the element
    length): stretch of each gradient, and the tilt between slope and sections that the form does not bend through
    (elastic line: the sections' tilt; continuum: the slope's)."""
    from ancf_sym.model.constraints import build_constraints
    from ancf_sym.model.mesh import build_mesh
    s, _ = _frame(method, 4, "normal", False)
    mesh = build_mesh(s)
    cons = build_constraints(mesh)
    rows = [k for k, lab in enumerate(cons.labels) if lab.startswith("rigid")]
    assert len(rows) == 6  # 3 positions, then the 3 rotation rows
    c = cons.subset(np.array(rows[3:]))
    x0 = mesh.x0
    assert np.allclose(c.value(x0), 0.0, atol=1e-12)
    ax = np.array([1.0, 2.0, -0.5]) / np.linalg.norm([1.0, 2.0, -0.5])
    K = np.array([[0, -ax[2], ax[1]], [ax[2], 0, -ax[0]], [-ax[1], ax[0], 0]])
    R = np.eye(3) + np.sin(0.7) * K + (1 - np.cos(0.7)) * K @ K  # 0.7 rad about an oblique axis
    assert np.allclose(c.value((x0.reshape(-1, 3) @ R.T).ravel()), 0.0, atol=1e-12)
    Jc = c.jacobian(x0).toarray()
    assert np.linalg.matrix_rank(Jc) == 3
    for name, node in (("m1", -1), ("m2", 0)):
        mm = mesh.members[name]
        d = mm.node_dofs(range(mm.n_nodes)[node])
        t, y, z = x0[d].reshape(4, 3)[1:]
        modes = [(0, t), (1, y), (2, z)] + ([(1, t), (2, t)] if method == "elastic_line" else [(0, y), (0, z)])
        for g, v in modes:
            dx = np.zeros_like(x0)
            dx[d[3 + 3 * g:6 + 3 * g]] = v
            assert np.allclose(Jc @ dx, 0.0, atol=1e-12), (name, g, v)
        if method == "elastic_line":  # and the turn of r_x alone is its bending rotation: seen
            dx = np.zeros_like(x0)
            dx[d[3:6]] = y
            assert np.abs(Jc @ dx).max() > 0.5


def _hinged_link(method: str, n: int) -> tuple[Scene, float]:
    """Leg a clamped, leg b hinged to it about the frame's normal z and pinned at its far end: in the plane, b is a
    simply supported span; a force F along -x at b's middle node. Returns the scene and the middle's deflection by
    beam theory: F c^3 / (48 E I) (I about z), + F c / (4 G A) for the continuum's shear, + F a / (4 E A) from the
    corner's support, a, shortening under F / 2 (half of it reaches the middle)."""
    F = 0.01
    s, _ = _frame(method, n, "in_plane", False)
    s.loads.clear()
    s.joints.clear()
    s.hinge(("m1", "end"), ("m2", "start"), axis=(0.0, 0.0, 1.0))
    s.pin("m2", at="end")
    s.force("m2", at=n // 2, force=(-F, 0.0, 0.0))
    w = F * LEG_C**3 / (48 * E * IZ) + F * LEG_A / (4 * E * A_SEC)
    return s, w + (F * LEG_C / (4 * G * A_SEC) if method == "continuum" else 0.0)


@pytest.mark.parametrize("method", METHODS)
def test_hinge_axis_frees_exactly_that_rotation(method):
    """A beam3d hinge with an axis: its rows see the relative rotations normal to the axis and not the one about it
    (rank 2); in a frame, the span hinged about z and pinned at its end is simply supported in the plane (the
    rigid joint would clamp it elastically into leg a: 24 % stiffer at midspan, measured), while the rotations
    normal to z still carry leg a's twist and bending. Error against beam theory <= 2e-3 at 64 and 256 elements, falling; at 16
    (8 elements a half span) the continuum's linear section field is 4.1e-3 stiff (measured; it falls as 1 / n^2,
    3.0e-4 at 64), so 16 elements are held to 5e-3."""
    from ancf_sym.model.constraints import build_constraints
    from ancf_sym.model.mesh import build_mesh
    s, _ = _hinged_link(method, 4)
    mesh = build_mesh(s)
    cons = build_constraints(mesh)
    rows = [k for k, lab in enumerate(cons.labels) if lab.startswith("hinge")]
    assert len(rows) == 5  # 3 positions, 2 rotations
    Jc = cons.subset(np.array(rows[3:])).jacobian(mesh.x0).toarray()
    mm = mesh.members["m2"]
    d = mm.node_dofs(0)
    for axis, seen in (((0, 0, 1.0), False), ((1.0, 0, 0), True), ((0, 1.0, 0), True)):
        dx = np.zeros(mesh.n)  # a small rotation of b's node frame about axis
        for g in range(1, 4):
            dx[d[3 * g:3 * g + 3]] = np.cross(axis, mesh.x0[d[3 * g:3 * g + 3]])
        assert (np.abs(Jc @ dx).max() > 0.1) == seen, (axis, Jc @ dx)
    errs, ns = [], [16, 64, 256]
    for n in ns:
        s, w = _hinged_link(method, n)
        r = solve_static(s)
        assert r.success, r.status
        errs.append((LEG_A - r.nodes("m2")[n // 2][0]) / w - 1)
    _check(errs, ns, coarse=5e-3)


def test_hinge_axis_in_toml_and_its_refusals(tmp_path):
    """[[joints]] axis reaches Scene.hinge; a rigid joint, a cable, or a zero axis is refused naming the field."""
    from ancf_sym.util.checks import SceneError
    from ancf_sym.io.scene_toml import load_scene
    text = """[scene]
dim = 3
[materials.steel]
E = 2e11
density = 7850
poisson = 0.3
[sections.bar]
shape = "rectangle"
b = 0.04
h = 0.02
[[members]]
name = "m1"
points = [[0, 0, 0], [1, 0, 0]]
elements = 4
material = "steel"
section = "bar"
element = "{el}"
[[members]]
name = "m2"
points = [[1, 0, 0], [1, 0.6, 0]]
elements = 4
material = "steel"
section = "bar"
element = "{el}"
[[supports]]
type = "clamp"
member = "m1"
at = "start"
[[joints]]
type = "{kind}"
a = ["m1", "end"]
b = ["m2", "start"]
axis = {axis}
"""
    f = tmp_path / "s.toml"
    f.write_text(text.format(el="beam3d", kind="hinge", axis="[0, 0, 2]"))
    assert np.allclose(load_scene(f)[0].joints[0].axis, [0, 0, 1])
    for el, kind, axis, why in (("beam3d", "rigid", "[0, 0, 1]", "is for hinges"),
                                ("cable3d", "hinge", "[0, 0, 1]", "needs beam3d members"),
                                ("beam3d", "hinge", "[0, 0, 0]", "nonzero")):
        f.write_text(text.format(el=el, kind=kind, axis=axis))
        with pytest.raises(SceneError, match=rf"joints\[0\]\.axis.*{why}"):
            load_scene(f)


def test_cable3d_corner_ties_the_angle_between_its_slopes():
    """A cable3d polyline corner: a cable carries no section vectors, so all its corner can tie is the angle between
    the two slopes (one row; the corner may spin about either side's axis, which a torsion-free cable does not
    resist). The L of a cable clamped at one end and pinned at the other (the pin holds the spin) loaded in its
    plane: in the x-z plane and in a tilted plane it deflects as the cable2d L in the x-y plane, node by node (same
    mesh, same energies: agreement to round-off, 1e-9 of the deflection allows for the solver's stopping). The
    former corner row took the x-y components of the slopes only, and left these corners free."""
    from ancf_sym.model.mesh import build_mesh
    from ancf_sym.model.constraints import build_constraints
    sec, P = Section.circle(0.02), 10.0
    swap = np.array([[1.0, 0, 0], [0, 0, 1], [0, 1, 0]])  # x-y plane -> x-z plane
    c, s_ = np.cos(0.5), np.sin(0.5)
    tilt = np.array([[1.0, 0, 0], [0, c, -s_], [0, s_, c]]) @ swap
    p2 = np.array([(0.0, 0.0), (LEG_A, 0.0), (LEG_A, LEG_C)])
    disp = []
    for R in (None, swap, tilt):
        dim = 2 if R is None else 3
        sc = Scene(dim=dim, gravity=(0.0,) * dim)
        pts = p2 if R is None else (R @ np.c_[p2, np.zeros(3)].T).T
        f = np.array([-P, 0.0]) if R is None else R @ np.array([-P, 0.0, 0.0])
        sc.member("m", points=[tuple(p) for p in pts], elements=24, material=Material(E=E, density=7850.0),
                  section=sec, gravity=False)
        sc.clamp("m", at="start")
        sc.pin("m", at="end")
        sc.force("m", at=20, force=tuple(f))
        if R is not None:
            labels = build_constraints(build_mesh(sc)).labels  # the corner: 3 position rows and 1 angle row
            assert sum(lab.startswith("vertex") for lab in labels) == 4
        r = solve_static(sc)
        assert r.success, r.status
        mm = build_mesh(sc).members["m"]
        u = np.asarray(r.nodes("m")) - mm.x0[mm.public_nodes, :dim]
        disp.append(u if R is None else (u @ R)[:, :2])
    scale = np.abs(disp[0]).max()
    assert scale > 1e-6  # the load does bend the L
    for d in disp[1:]:
        assert np.abs(d - disp[0]).max() <= 1e-9 * scale + 1e-15, np.abs(d - disp[0]).max() / scale


def _beam_cable_frame(method: str, n: int, load: str, beam_first: bool) -> float:
    """Leg a a beam3d member, leg b a cable3d member (isotropic bending E I_z of the same section), joined by
    `rigid`: the joint holds the cable's slope direction in the beam's frame (two rows; the cable has no twist to
    tie). Returns the relative tip error against frame theory: in plane as for two beams (I_z for both legs);
    normal to the plane the cable's bending E I_z, the beam's E I_y, torsion G J of leg a, and for the continuum
    leg a's shear P a / (G A) (the cable has none)."""
    s = Scene(dim=3, gravity=(0.0, 0.0, 0.0))
    mat = Material(E=E, density=7850.0, poisson=NU)
    s.member("m1", points=[(0, 0, 0), (LEG_A, 0, 0)], elements=n, element="beam3d", beam_method=method, section=SEC,
             material=mat, gravity=False, torsion=method == "elastic_line", y_axis=(0, 1, 0))
    s.member("m2", points=[(LEG_A, 0, 0), (LEG_A, LEG_C, 0)], elements=n, element="cable3d", section=SEC,
             material=mat, gravity=False)
    s.clamp("m1", at="start")
    ends = [("m1", "end"), ("m2", "start")]
    s.rigid(*(ends if beam_first else ends[::-1]))
    s.force("m2", at="end", force=(-P, 0.0, 0.0) if load == "in_plane" else (0.0, 0.0, P))
    r = solve_static(s)
    assert r.success, r.status
    a, c = LEG_A, LEG_C
    if load == "in_plane":
        w = P * c**3 / (3 * E * IZ) + P * c**2 * a / (E * IZ) + P * a / (E * A_SEC)
        return (a - r.nodes("m2")[-1][0]) / w - 1
    w = P * a**3 / (3 * E * IY) + P * c**2 * a / (G * SEC.J) + P * c**3 / (3 * E * IZ)
    w += P * a / (G * A_SEC) if method == "continuum" else 0.0
    return r.nodes("m2")[-1][2] / w - 1


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("load", ["in_plane", "normal"])
def test_beam_to_cable_rigid_joint_converges(method, load):
    """A rigid joint of a beam3d and a cable3d member (it failed to mesh before when the beam came first, and was
    refused the other way round): within 2e-3 of frame theory at 16, 64, 256 elements, falling (measured 4.7e-4,
    3.0e-5, 1.9e-6 for the continuum normal to the plane); the same rows whichever member is named first."""
    ns = [16, 64, 256]
    errs = [_beam_cable_frame(method, n, load, True) for n in ns]
    _check(errs, ns)
    assert abs(_beam_cable_frame(method, 64, load, False) - errs[1]) <= 1e-6


def test_rigid_joint_of_two_cable3d_members_is_refused():
    from ancf_sym.util.checks import SceneError
    s = Scene(dim=3, gravity=(0.0, 0.0, 0.0))
    for name, pts in (("c1", [(0, 0, 0), (1, 0, 0)]), ("c2", [(1, 0, 0), (1, 1, 0)])):
        s.member(name, points=pts, elements=2, element="cable3d", section=SEC, material=Material(E=E, density=7850.0))
    with pytest.raises(SceneError, match="cable3d members 'c1' and 'c2'"):
        s.rigid(("c1", "end"), ("c2", "start"))


@pytest.mark.parametrize("method", METHODS)
def test_large_deflection_frame_is_the_same_in_a_turned_scene(method):
    """The joint's rows are sums of dot products, so a frame bent far (tip moved 0.5 m by 3 kN in and normal to its
    plane, 16 elements per member) and the same scene turned by 1.1 rad about an oblique axis give the same shape,
    turned: the statics stop when the Newton increment is below tol = 1e-10 L and answer the point after it (within
    about tol^2 L of the discrete solution), so 1e-10 m bounds the difference (measured 1e-15 m)."""
    ax = np.array([1.0, 2.0, -0.5]) / np.linalg.norm([1.0, 2.0, -0.5])
    K = np.array([[0, -ax[2], ax[1]], [ax[2], 0, -ax[0]], [-ax[1], ax[0], 0]])
    shapes = []
    for R in (np.eye(3), np.eye(3) + np.sin(1.1) * K + (1 - np.cos(1.1)) * K @ K):
        s = Scene(dim=3, gravity=(0.0, 0.0, 0.0))
        kw = dict(element="beam3d", beam_method=method, section=SEC, material=Material(E=E, density=7850.0, poisson=NU),
                  gravity=False, torsion=method == "elastic_line")
        s.member("m1", points=[tuple(R @ p) for p in np.array([(0, 0, 0), (LEG_A, 0, 0)])], elements=16,
                 y_axis=tuple(R @ [0, 1, 0]), **kw)
        s.member("m2", points=[tuple(R @ p) for p in np.array([(LEG_A, 0, 0), (LEG_A, LEG_C, 0)])], elements=16,
                 y_axis=tuple(R @ [-1, 0, 0]), **kw)
        s.clamp("m1", at="start")
        s.rigid(("m1", "end"), ("m2", "start"))
        s.force("m2", at="end", force=tuple(R @ [-3000.0, 0.0, 3000.0]))
        r = solve_static(s)
        assert r.success and r.stable, r.status
        shapes.append(np.asarray(r.nodes("m2")) @ R)
    assert np.linalg.norm(shapes[0][-1] - [LEG_A, LEG_C, 0.0]) > 0.3
    assert np.abs(shapes[1] - shapes[0]).max() < 1e-10
