"""Exact (unilateral) contact statics under mesh refinement and at stationary points that are not minima: a slack rope
on a frictionless ground against the closed form (two elastic catenaries with their vertex at the touchdown), its
penalty form approaching the exact answer as the stiffness grows, a slack rope over a drum at fine meshes, and a
compressed rod between two walls whose straight state is a saddle."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq

from ancf_sym import Material, Scene, Section, solve_static
from ancf_sym.contact import exact as contact_exact
from ancf_sym.elements.hermite import weights
from ancf_sym.statics import problem_for
from ancf_sym.statics.contact import COARSE_MARGIN

# the rope on the ground: EA 1e7 N, 5 N/m, unstretched 12 m between pins at (0, 1.5) and (10, 1.5)
EA, W, SPAN, HEIGHT, LENGTH, AREA = 1e7, 5.0, 10.0, 1.5, 12.0, 1e-4
T = math.sqrt(AREA / math.pi)  # the section's radius: the centre line lies this high where it touches


def rope_scene(n: int, axial: str = "decoupled", stiffness: float | None = None) -> Scene:
    """The straight reference between the pins, compressed to the span (prestrain): the rope falls from there."""
    sc = Scene(dim=2, gravity=(0.0, -9.81))
    sc.member("rope", [(0.0, HEIGHT), (SPAN, HEIGHT)], n, Material(E=EA / AREA, density=W / 9.81 / AREA),
              Section(area=AREA, I=1e-15), axial=axial, prestrain=SPAN / LENGTH - 1)
    sc.pin("rope", "start")
    sc.pin("rope", "end")
    if stiffness is None:
        sc.contact_ground("rope", method="exact")
    else:
        sc.contact_ground("rope", stiffness=stiffness)
    return sc


def hanging(s: float, H: float) -> tuple[float, float]:
    """Elastic catenary from its vertex (Irvine): x and y at unstretched distance s, horizontal force H."""
    return H * s / EA + H / W * math.asinh(W * s / H), W * s**2 / (2 * EA) + (math.hypot(H, W * s) - H) / W


def closed_form() -> tuple[float, float]:
    """(H, hanging length s1): each hanging part is an elastic catenary whose vertex is the touchdown (frictionless
    ground: no vertical force there, so zero slope), rising HEIGHT - T from the ground's centre-line level T; the
    grounded middle carries H, stretched by H / EA; the parts close the span."""
    def s1_of(H):
        return brentq(lambda s: hanging(s, H)[1] - (HEIGHT - T), 0.0, LENGTH / 2, xtol=1e-15, rtol=1e-15)

    def span(H):
        if hanging(LENGTH / 2, H)[1] < HEIGHT - T:  # too flat to reach the pins with half the rope: no touchdown
            return LENGTH
        s1 = s1_of(H)
        return 2 * hanging(s1, H)[0] + (LENGTH - 2 * s1) * (1 + H / EA) - SPAN

    H = brentq(span, 1e-3, 1e4, xtol=1e-14, rtol=1e-15)
    return H, s1_of(H)


H_REF, S1_REF = closed_form()


def _H(r) -> float:
    return abs(r.constraint_forces["pin rope@start"][0])


@pytest.fixture(scope="module")
def ground():
    """Solutions at 32, 64, 128 and 256 elements (decoupled strain)."""
    return {n: solve_static(rope_scene(n)) for n in (32, 64, 128, 256)}


def test_closed_form_is_a_catenary_with_its_vertex_at_touchdown():
    """The reference itself: the pins carry the hanging weight W s1 vertically, and with the touchdown at the vertex
    the horizontal reach 2 x(s1) plus the grounded length fills the span (to brentq's tolerance)."""
    x1, y1 = hanging(S1_REF, H_REF)
    assert y1 == pytest.approx(HEIGHT - T, abs=1e-12)
    assert 2 * x1 + (LENGTH - 2 * S1_REF) * (1 + H_REF / EA) == pytest.approx(SPAN, abs=1e-10)
    # inextensible rope: H / EA ~ 2e-7, so the elastic terms move H by a relative ~1e-6 only
    assert 0 < H_REF / EA < 1e-6


def test_rope_on_ground_converges_to_the_closed_form(ground):
    """Every solve succeeds at a stable state (the second-order check on the active set) and the horizontal force
    (the pins' horizontal multiplier) converges to the closed form: within 1e-3 at 128 and 256 elements, ten times
    closer than at 32 (measured 1.8e-2, 6.9e-4, 1.5e-4, 4.4e-4 at 32, 64, 128, 256). The tolerance: the closed form
    has no bending stiffness, the rope has EI = 1e-4 N m^2, whose bending length sqrt(EI / H) = 8 mm rounds off the
    touchdown and moves H by a few 1e-4 as the mesh resolves it; no contact point penetrates (IPOPT's
    constr_viol_tol 1e-10)."""
    err = {}
    for n, r in ground.items():
        assert r.success and r.stable is True, (n, r.status, r.attempts)
        assert min(contact_exact.gaps(r.assembly, r.x)) > -1e-9
        err[n] = abs(_H(r) / H_REF - 1)
    assert err[128] < 1e-3 and err[256] < 1e-3, err
    assert max(err[128], err[256]) < err[32] / 10, err


def test_rope_on_ground_carries_the_grounded_weight(ground):
    """The pins hold the hanging weight 2 W s1 (each W s1 vertically), the ground the rest: W (L - 2 s1); at 256
    elements within 1e-3 of the total weight (the touchdown's position converges as H does)."""
    r = ground[256]
    f = np.asarray(r.constraint_forces["contact"])
    assert f.min() >= 0
    assert f.sum() == pytest.approx(W * (LENGTH - 2 * S1_REF), abs=1e-3 * W * LENGTH)


def test_finer_mesh_is_not_beaten_by_the_coarser_one(ground):
    """The fine mesh holds every shape of the coarse one (its elements split the coarse ones), so its minimum may not
    lie above the coarse minimum beyond what the denser contact points and strain samples change (COARSE_MARGIN x
    the load work W, 7e-4 J here; measured differences below 5e-5 J); the solver refuses such an answer."""
    for n in (64, 128, 256):
        margin = COARSE_MARGIN * problem_for(rope_scene(n)).work
        assert ground[n].potential <= ground[n // 2].potential + margin, n
    # and the potential converges: from 12.10427 J (32 elements) to within 1e-4 J of the finer meshes
    assert abs(ground[256].potential - ground[128].potential) < 1e-4 < ground[32].potential - ground[256].potential


@pytest.mark.slow
@pytest.mark.parametrize("axial", ["decoupled", "biot"])
def test_rope_on_ground_at_512_elements(axial):
    """512 elements (from the chain of coarser meshes): within 1e-3 of the closed form for the decoupled strain
    (measured 4.1e-4) and for the coupled Biot strain too (5.1e-4), whose elements lock where the rope bends at the
    touchdown (docs/hard_cases.md: 6.8e-3 at 128 elements, 2.3e-4 at 256)."""
    r = solve_static(rope_scene(512, axial))
    assert r.success and r.stable is True, (r.status, r.attempts)
    assert abs(_H(r) / H_REF - 1) < 1e-3


def test_penalty_ground_approaches_the_exact_contact():
    """The linear penalty law k/2 delta^2 per length at growing stiffness k: the rope sinks by delta = W / k where it
    lies, so the potential lies below the exact one by half the grounded weight times delta (the spring's energy is
    half the weight's loss), within 10 % and 5e-5 J (the touchdown zone, where the penalty law spreads the
    touchdown, differs by a further ~2.5e-5 J, measured at k = 1e5 and 1e6); the horizontal force approaches the
    exact one (measured 3.7e-3, 1.1e-3, 1.3e-4 relative at k = 1e4, 1e5, 1e6 N/m^2)."""
    exact = solve_static(rope_scene(64))
    He = _H(exact)
    grounded = float(np.sum(exact.constraint_forces["contact"]))
    diffs = []
    for k in (1e4, 1e5, 1e6):
        r = solve_static(rope_scene(64, stiffness=k))
        assert r.success and r.stable, (k, r.status)
        assert r.potential - exact.potential == pytest.approx(-0.5 * grounded * W / k, rel=0.1, abs=5e-5)
        diffs.append(abs(_H(r) / He - 1))
    assert diffs[0] > diffs[1] > diffs[2] and diffs[2] < 1e-3, diffs


# -- a slack rope over a drum ------------------------------------------------------------------------------------------
CENTRE, RADIUS = np.array([0.0, 0.2]), 0.35


def drum_scene(n: int) -> Scene:
    """A steel rope (d 10 mm) of 2.4 m pinned at (-+1, 0.5), its straight reference cutting a drum of radius 0.35 m at
    (0, 0.2): it falls over the drum and hangs from it in two catenaries."""
    sc = Scene(dim=2, gravity=(0.0, -9.81))
    sc.member("rope", [(-1.0, 0.5), (1.0, 0.5)], n, Material(E=200e9, density=7850.0),
              Section(area=math.pi * 0.01**2 / 4, I=1e-15), axial="decoupled", prestrain=2.0 / 2.4 - 1)
    sc.pin("rope", "start")
    sc.pin("rope", "end")
    sc.contact_drum("rope", tuple(CENTRE), RADIUS, method="exact")
    return sc


def _vertical_contact_force(r) -> float:
    """Vertical resultant of the contact forces (each along the drum's normal at its point)."""
    asm = r.assembly
    mm = asm.mesh.members["rope"]
    X = asm.member_coordinates(r.x, "rope")
    out = 0.0
    for p in contact_exact.points(asm, r.x, r.constraint_forces["contact"]):
        a, b = mm.elem_nodes[p["element"]]
        w = weights(p["xi"], mm.elem_length[p["element"]])[0]
        pos = w[0] * X[a, :2] + w[1] * X[a, 2:4] + w[2] * X[b, :2] + w[3] * X[b, 2:4]
        nrm = (pos - CENTRE) / np.linalg.norm(pos - CENTRE)
        out += p["force"] * nrm[1]
    return out


@pytest.mark.parametrize("n", [256, pytest.param(512, marks=pytest.mark.slow)])
def test_slack_rope_over_a_drum_at_fine_meshes(n):
    """Succeeds at a stable state; no point penetrates; the drum and the pins carry the rope's weight (vertical
    equilibrium, to IPOPT's tolerance: 1e-6 relative); the potential is converged: within 1e-6 relative of the
    128-element one (measured 7e-8 at 256, 2.4e-7 at 512), while 32 elements lie 1e-2 above."""
    r = solve_static(drum_scene(n))
    assert r.success and r.stable is True, (r.status, r.attempts)
    assert min(contact_exact.gaps(r.assembly, r.x)) > -1e-9
    weight = 7850.0 * math.pi * 0.01**2 / 4 * 9.81 * 2.4
    pins = r.constraint_forces["pin rope@start"][1] + r.constraint_forces["pin rope@end"][1]
    assert _vertical_contact_force(r) - pins == pytest.approx(weight, rel=1e-6)
    r128 = solve_static(drum_scene(128))
    assert abs(r.potential - r128.potential) < 1e-6 * abs(r128.potential)


# -- a stationary point that is not a minimum ----------------------------------------------------------------------
def channel() -> Scene:
    """A steel rod (d 10 mm, 1 m) pinned at both ends and compressed to ~3x its Euler load (prestrain -2e-4: 3140 N
    against pi^2 EI / L^2 = 970 N), no gravity, between two frictionless walls 1 mm from its surface (exact contact
    above and below). The straight state is stationary (the walls' barrier forces cancel by symmetry: IPOPT
    converges there in a few iterations) and a saddle."""
    sc = Scene(dim=2, gravity=(0.0, 0.0))
    sc.member("rod", [(0.0, 0.0), (1.0, 0.0)], 16, Material(E=200e9, density=7850.0), Section.circle(0.01),
              axial="biot", prestrain=-2e-4)
    sc.pin("rod", "start")
    sc.pin("rod", "end")
    sc.contact_ground("rod", method="exact", level=-0.006)
    sc.contact_ground("rod", method="exact", normal=(0, -1), level=-0.006)
    return sc


def test_saddle_is_not_reported_as_success():
    """Without leaving saddles, the straight compressed rod (negative curvature on the tangent space of the supports;
    no contact point active) is refused and the reason given."""
    r = solve_static(channel(), escape_saddle=False)
    assert not r.success and r.status == "Unstable_Stationary_Point"
    assert "negative curvature" in r.attempts[-1]["detail"]


def test_saddle_is_left_for_the_buckled_minimum():
    """By default the solver leaves the saddle along its negative curvature: the rod buckles onto a wall (1 mm off),
    a stable state of lower potential than the straight one."""
    sc = channel()
    r = solve_static(sc)
    assert r.success and r.stable is True, (r.status, r.attempts)
    straight = r.assembly.energy(r.assembly.x0)
    assert r.potential < straight - 1e-3 * straight  # (measured 0.3086 against 0.3142 J)
    y = r.nodes("rod")[:, 1]
    assert np.abs(y).max() == pytest.approx(1e-3, abs=1e-6)  # against a wall: its gap closed (nodes lie between the contact points)
    assert min(contact_exact.gaps(r.assembly, r.x)) > -1e-9


def test_inertia_counts_the_rank_of_dependent_rows():
    """Five contact points on an element's four transverse coordinates make dependent rows. H = diag(1, -1, 1) on
    the null space of J = [e1; e1] (span e2, e3) has one negative eigenvalue; counting the rows instead of their
    rank would call it stable (neg(H_rho) + pos(S) - m = 1 + 1 - 2 = 0)."""
    import scipy.sparse as sp

    from ancf_sym.statics.inertia import reduced_inertia

    H = sp.diags([1.0, -1.0, 1.0])
    J = sp.csr_matrix(np.array([[1.0, 0.0, 0.0], [1.0, 0.0, 0.0]]))
    got = reduced_inertia(H, J, rank_tol=1e-9)
    assert got.stable is False and got.negative == 1
    assert abs(got.direction[1]) == pytest.approx(1.0) and abs(got.direction[0]) < 1e-12
    assert reduced_inertia(sp.diags([1.0, 2.0, 1.0]), J, rank_tol=1e-9).stable is True


def test_answer_above_the_coarse_mesh_is_refused(monkeypatch):
    """The continuation check's refusal path: with the margin made negative (-1 x the load work), every fine answer
    lies 'above' the coarse one, and the solve fails saying so, with both potentials, instead of succeeding."""
    from ancf_sym.statics import contact as statics_contact

    monkeypatch.setattr(statics_contact, "COARSE_MARGIN", -1.0)
    r = solve_static(rope_scene(64))
    assert not r.success and r.status == "Coarser_Mesh_Lower_Potential", (r.status, r.attempts)
    assert "above the coarse mesh's" in r.attempts[-1]["detail"]
    assert np.all(np.isfinite(r.x))
