"""A slack cable hanging in a vertical plane of a 3-D scene: it starts straight and compressed (prestrain -5 %), its
tangent indefinite in the plane and, by the same amount, out of it, where nothing loads it. It must solve at every
mesh size as the same cable in 2-D does (before the IPOPT fallback held the unloaded out-of-plane coordinates,
statics/held.py, 4 elements ended after 1503 iterations at the start), converge to the extensible catenary, and
equal the planar result."""
import math

import numpy as np
import pytest
import scipy.optimize

from ancf_sym import Material, Scene, SceneError, Section, solve_static
from ancf_sym.statics import StaticProblem

ELEMENTS = (2, 3, 4, 5, 6, 8, 16)
TOL = 1e-10  # the statics' default relative tolerance (StaticOptions.tol)
RHO_W = 1025.0


def slack_scene(dim: int, n: int, bending: bool, water: bool, drive: bool) -> Scene:
    """72.1 m chord from (0, 0, -10) to (60, 0, -50) in the x-z plane; the material 5 % longer than the chord."""
    P = (lambda *c: c) if dim == 3 else (lambda x, y, z: (x, z))
    s = Scene(dim=dim, gravity=[0.0] * (dim - 1) + [-9.81])
    s.member("l", [P(0, 0, -10.0), P(60.0, 0, -50.0)], n, Material(E=2e11, density=7800), Section.circle(0.05),
             axial="biot", bending=bending, prestrain=-0.05)
    if drive:
        s.drive_position(list(P(0.0, 0.0, -10.0)), member="l", at="start", name="top")
    else:
        s.pin("l", "start")
    s.pin("l", "end")
    if water:
        s.set_water(density=RHO_W)
    return s


def elastic_catenary(L0: float, EA: float, w: float, dx: float, dz: float):
    """The extensible catenary (Irvine, Cable Structures, ch. 2) of unstretched length L0, axial stiffness EA and
    weight w per unstretched length, from the origin to (dx, dz): position at unstretched arc length s, solved for
    the horizontal tension H and the start's vertical force V0 (tension along s, z up)."""
    def ends(p, s):
        H, V0 = math.exp(p[0]), p[1]
        x = H * s / EA + H / w * (np.arcsinh((V0 + w * s) / H) - np.arcsinh(V0 / H))
        z = (V0 * s + w * s * s / 2) / EA + (np.hypot(H, V0 + w * s) - np.hypot(H, V0)) / w
        return x, z

    sol = scipy.optimize.root(lambda p: np.subtract(ends(p, L0), (dx, dz)), [math.log(w * L0), -w * L0 / 2],
                              tol=1e-14)
    assert np.max(np.abs(np.subtract(ends(sol.x, L0), (dx, dz)))) < 1e-9 * math.hypot(dx, dz)  # the ends met
    return lambda s: np.stack(ends(sol.x, np.asarray(s, float)), axis=1)


# (a position drive holds its node in the statics in water; a dry statics refuses drives: test below)
CASES = [(b, w, d) for b in (False, True) for w in (False, True) for d in (False, True) if w or not d]


@pytest.mark.parametrize("bending,water,drive", CASES,
                         ids=[f"{'beam' if b else 'cable'}-{'water' if w else 'dry'}-{'drive' if d else 'pin'}"
                              for b, w, d in CASES])
def test_slack_catenary_3d_solves_at_every_mesh_and_equals_2d(bending, water, drive):
    for n in ELEMENTS:
        r3 = StaticProblem(slack_scene(3, n, bending, water, drive)).solve()
        r2 = StaticProblem(slack_scene(2, n, bending, water, drive)).solve()
        assert r3.success and r2.success, (n, r3.status, r3.attempts)
        assert r3.stable is not False
        n3, n2 = r3.nodes("l"), r2.nodes("l")
        L = 72.1
        # each answer lies within tol L of its discrete equilibrium (the Newton increment bound), and the planar
        # problem is the 3-D one restricted to its plane: they differ by at most 2 tol L, and nothing moves out of it
        assert np.max(np.abs(n3[:, [0, 2]] - n2)) <= 2 * TOL * L, n
        assert np.max(np.abs(n3[:, 1])) <= 2 * TOL * L, n
        if drive:  # the drive holds its node where a pin does
            pinned = StaticProblem(slack_scene(3, n, bending, water, False)).solve()
            assert np.max(np.abs(n3 - pinned.nodes("l"))) <= 2 * TOL * L, n
        below = (-10.0 - 40.0 * n3[1:-1, 0] / 60.0) - n3[1:-1, 2]  # below the chord (5 % slack: metres of sag)
        assert below.min() > 0.0 and below.max() > 1.0, n  # it hangs, not the straight compressed saddle


@pytest.mark.parametrize("water", [False, True], ids=["dry", "water"])
def test_slack_catenary_3d_converges_to_the_elastic_catenary(water):
    """Node positions of the cubic-Hermite cable against the closed form at the nodes' unstretched arc lengths:
    the nodal error of cubic Hermite elements falls as h^4 (measured 1.1e-2, 1.0e-3, 6.4e-5 m at 4, 8, 16
    elements); the test asks for errors falling at each doubling, better than h^3 from 4 to 16 elements, and the
    last doubling within a factor 2 of h^4 (pre-asymptotic margin)."""
    errors = []
    for n in (4, 8, 16):
        s = slack_scene(3, n, False, water, False)
        m = s.members["l"]
        w = (m.material.density - (RHO_W if water else 0.0)) * m.section.area * 9.81  # net weight in water
        at = elastic_catenary(m.length, m.material.E * m.section.area, w, 60.0, -40.0)
        r = StaticProblem(s).solve()
        assert r.success, (n, r.status)
        ref = at(np.linspace(0.0, m.length, n + 1)) + [0.0, -10.0]
        errors.append(float(np.max(np.abs(r.nodes("l")[:, [0, 2]] - ref))))
    assert errors[0] > errors[1] > errors[2]
    assert errors[2] < errors[0] * (4 / 16) ** 3
    assert errors[2] < 2 * errors[1] / 2 ** 4


def test_dry_statics_refuses_a_drive_rather_than_leaving_it_out():
    """A dry statics has no rows for drives (the dynamics' prescribed motion): StaticProblem.solve refuses the scene
    as solve_static does (it once solved it with the drive left out: the cable hanging straight down from its
    other pin, reported as a success)."""
    for solve in (solve_static, lambda s: StaticProblem(s).solve()):
        with pytest.raises(SceneError, match="drives: 'top'"):
            solve(slack_scene(3, 4, False, False, True))


def test_no_held_phase_where_no_mirror_holds_the_coordinates():
    # a straight rope along x under a transverse end load: its axial coordinates are unloaded and decoupled at the
    # straight start (first order), but bending couples them at once; a held phase would cost two IPOPT runs whose
    # answers are rejected. Only a mirror symmetry (the slack catenary's out-of-plane coordinates) gets one.
    s = Scene(dim=3, gravity=[0.0, 0.0, -9.81])
    s.member("rope", [(0.0, 0.0, 0.0), (10.0, 0.0, 0.0)], 30, Material(E=5e6, density=1100.0), Section.circle(0.01))
    s.clamp("rope", "start")
    s.force("rope", "end", [0.0, 30.0, 50.0])
    r = StaticProblem(s).solve()
    assert r.success
    assert not any("held" in a["method"] for a in r.attempts)
    c = Scene(dim=3, gravity=[0.0, 0.0, -9.81])
    c.member("l", [(0.0, 0.0, -10.0), (60.0, 0.0, -50.0)], 4, Material(E=2e11, density=7800), Section.circle(0.05),
             axial="biot", bending=False, prestrain=-0.05)
    c.pin("l", "start")
    c.pin("l", "end")
    r = StaticProblem(c).solve()
    assert r.success and any("held" in a["method"] for a in r.attempts)
