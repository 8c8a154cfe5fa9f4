"""The true smallest gap between a member's centre line and a contact surface (ancf_sym.contact.gap), and the check
that no statics or dynamics result claims success while the centre line passes through a surface the penalty law's
Gauss points missed.

Projection tolerances: the closest point of a cubic is found exactly (ground: the roots of its quadratic
derivative) or by Newton's iteration to round-off (drums); what remains is the round-off of evaluating the cubic
at O(1 m) coordinates, a few ulp: 1e-13 m is 500 ulp."""
from __future__ import annotations

import math

import numpy as np
import pytest

from ancf_sym import Material, Scene, Section, contact, solve_static
from ancf_sym.contact import gap as contact_gap
from ancf_sym.model.assembly import Assembly
from ancf_sym.dynamics import DynamicOptions, Sensor, simulate
from ancf_sym.io.json_out import static_result_dict

ROUND_OFF = 1e-13  # [m], see the module docstring
MAT = Material(E=1e9, density=1000.0)


def _one_element(dim=2, length=2.0):
    """A scene with one cable element of reference length `length`, whose nodal coordinates the tests set."""
    sc = Scene(dim=dim, gravity=(0.0,) * dim)
    end = (length, 0.0) if dim == 2 else (length, 0.0, 0.0)
    sc.member("rope", [(0.0,) * dim, end], 1, MAT, Section.circle(0.01))
    return sc


def _state(asm, r0, t0, r1, t1):
    x = asm.x0.copy()
    x[asm.mesh.members["rope"].elem_dofs()[0]] = np.r_[r0, t0, r1, t1]
    return x


def test_ground_gap_is_the_minimum_of_the_cubic():
    """y(u) = u^3 - u on u in [-1, 1] (element of length 2, material coordinate u + 1): a cubic Hermite element
    holds it exactly; its smallest height is -2 / (3 sqrt 3) at u = 1/sqrt 3. A tilted straight element: at its
    lower end."""
    sc = _one_element()
    c = sc.contact_ground("rope", stiffness=1e4, thickness=0.0, level=0.1)
    asm = Assembly(sc)
    x = _state(asm, (-1.0, 0.0), (1.0, 2.0), (1.0, 0.0), (1.0, 2.0))
    cl = contact_gap.closest(asm, c, x)
    assert cl.gap == pytest.approx(-2 / (3 * math.sqrt(3)) - 0.1, abs=ROUND_OFF)
    assert cl.xi == pytest.approx((1 + 1 / math.sqrt(3)) / 2, abs=1e-12)  # the root of the quadratic: exact
    assert np.allclose(cl.point, (1 / math.sqrt(3), -2 / (3 * math.sqrt(3))), atol=ROUND_OFF)
    x = _state(asm, (0.0, 0.5), (0.8, -0.6), (1.6, -0.7), (0.8, -0.6))  # straight, slope -3/4
    cl = contact_gap.closest(asm, c, x)
    assert (cl.xi, cl.gap) == (1.0, pytest.approx(-0.7 - 0.1, abs=ROUND_OFF))


def test_drum_gap_of_a_bent_element_has_two_interior_minima():
    """The parabola y = u^2 (u in [-1, 1]) against a circle of centre (0, 1), radius 0.5: the distance from the
    centre, sqrt(u^2 + (u^2 - 1)^2), is smallest at u^2 = 1/2 (two points, between the samples the Newton iteration
    starts from): sqrt(3)/2, so the gap is sqrt(3)/2 - 0.5."""
    sc = _one_element()
    c = sc.contact_drum("rope", (0.0, 1.0), 0.5, stiffness=1e4, thickness=0.0)
    asm = Assembly(sc)
    x = _state(asm, (-1.0, 1.0), (1.0, -2.0), (1.0, 1.0), (1.0, 2.0))
    cl = contact_gap.closest(asm, c, x)
    assert cl.gap == pytest.approx(math.sqrt(3) / 2 - 0.5, abs=ROUND_OFF)
    assert abs(cl.point[0]) == pytest.approx(1 / math.sqrt(2), abs=1e-7)  # (flat minimum: xi to sqrt(eps))
    # the same element through the drum: centre (0, 0.3), its nearest point the vertex, gap 0 - 0.3 ... - R
    c2 = sc.contact_drum("rope", (0.0, 0.3), 0.5, stiffness=1e4, thickness=0.0)
    asm = Assembly(sc)
    cl = contact_gap.closest(asm, c2, _state(asm, (-1.0, 1.0), (1.0, -2.0), (1.0, 1.0), (1.0, 2.0)), 1)
    # u^2 + (u^2 - 0.3)^2 is smallest at u = 0 (0.3^2 < the other stationary value): distance 0.3
    assert cl.gap == pytest.approx(0.3 - 0.5, abs=ROUND_OFF) and cl.xi == pytest.approx(0.5, abs=1e-7)


def test_cylinder_gap_of_a_straight_element_is_the_line_distance():
    """A straight cable3d element against a cylinder of skew axis: the distance between two lines,
    |(c - p).(d x a)| / |d x a|, where the closest point lies inside the element."""
    sc = _one_element(dim=3, length=1.0)
    axis = np.array([0.0, 1.0, 1.0]) / math.sqrt(2)
    centre = np.array([0.3, 0.2, 0.5])
    c = sc.contact_drum("rope", centre, 0.1, axis=axis, stiffness=1e4, thickness=0.0)
    asm = Assembly(sc)
    p0, p1 = np.array([-0.2, 0.1, 0.0]), np.array([0.9, -0.3, 0.2])
    d = p1 - p0
    x = _state(asm, p0, d, p1, d)  # r_x = d / L with L = 1: the straight segment
    cl = contact_gap.closest(asm, c, x)
    n = np.cross(d, axis)
    dist = abs((centre - p0) @ n) / np.linalg.norm(n)
    assert 0 < cl.xi < 1 and cl.gap == pytest.approx(dist - 0.1, abs=ROUND_OFF)


def test_projection_finds_the_global_minimum_of_random_cubics():
    """Random bent elements near a ground and a drum: the hull bound lies below the projected gap, and the
    projected gap equals the minimum over 4 001 points of the cubic to their sampling error (at most
    spacing^2 / 8 x the gap's largest second derivative in xi, taken from the samples' second differences, with a
    factor 2 for their own error) and never lies above it (a missed basin would)."""
    rng = np.random.default_rng(7)
    sc = _one_element()
    ground = sc.contact_ground("rope", stiffness=1e4, thickness=0.0)
    drum = sc.contact_drum("rope", (0.3, -0.2), 0.15, stiffness=1e4, thickness=0.0)
    asm = Assembly(sc)
    mm = asm.mesh.members["rope"]
    X = np.tile(asm.x0, (200, 1))
    X[:, mm.elem_dofs()[0]] = rng.normal(scale=0.6, size=(200, 8))
    u = np.linspace(0.0, 1.0, 4001)
    for c in (ground, drum):
        A, _ = contact_gap._rows(asm, c, X)
        xi, g = contact_gap.project(c, A)
        lb = contact_gap.gap_lower_bound(c, A)
        r = contact_gap._poly(A, np.broadcast_to(u, (len(A), len(u))))
        dense = (r @ c.normal - c.level) if c is ground else np.linalg.norm(r, axis=2) - c.radius
        assert np.all(lb <= g + ROUND_OFF)
        assert np.all(g <= dense.min(axis=1) + ROUND_OFF)
        du = u[1] - u[0]
        curv = np.abs(np.diff(dense, 2, axis=1)).max(axis=1) / du**2
        assert np.all(g >= dense.min(axis=1) - 2 * du**2 / 8 * curv - ROUND_OFF)


R, T = 0.02, 0.002  # a small drum, a rope of 4 mm diameter


def _rope_over_small_drum(n: int, gravity: float = -9.81, drum_y: float = -0.012 - R - T):
    """A rope 2 m long pinned at both ends, sagging under its weight (1.5 cm without the drum) onto a drum of radius
    2 cm whose top lies 1.2 cm below the pins, 9 cm beside the middle: at 8 elements between two Gauss points."""
    sc = Scene(dim=2, gravity=(0.0, gravity))
    sc.member("rope", [(0, 0), (2, 0)], n, MAT, Section.circle(2 * T))
    sc.pin("rope", "start")
    sc.pin("rope", "end")
    sc.contact_drum("rope", (1.09, drum_y), R, stiffness=1e6)
    return sc


def test_small_drum_between_gauss_points_is_refused_then_found_on_a_finer_mesh():
    """At 8 elements (law's points up to 6.7 cm apart) the rope sags through the 2 cm drum and no point sees it:
    statics refuses, naming the member, the drum and the element length needed. Meshed as the message asks
    (elements of at most 2 cm: 128), the law finds the drum: success, the rope lies on it, the smallest true gap is
    negative and within the law's own sampled penetration (3x, contact_gap.HIDDEN_FACTOR). In between (32, 64
    elements) the points see the drum but the centre line cuts it between them by 80 and 7 times the law's
    penetration: refused too (there the contact force was 42 % and 2 % off)."""
    coarse = solve_static(_rope_over_small_drum(8))
    assert not coarse.success and coarse.status == contact_gap.STATUS
    detail = coarse.attempts[-1]["detail"]
    assert "member 'rope'" in detail and "drum of radius 0.02 m" in detail and "no longer than 0.0204 m" in detail
    (rep,) = contact.report(coarse.assembly, coarse.x)
    assert rep["hidden_penetration"] and rep["smallest_gap"] < -5e-3 and rep["sampled_penetration"] == 0.0
    for n in (32, 64):
        assert solve_static(_rope_over_small_drum(n)).status == contact_gap.STATUS
    fine = solve_static(_rope_over_small_drum(128))
    assert fine.success and fine.stable
    doc = static_result_dict(fine)
    (rep,) = doc["contacts"]
    assert not rep["hidden_penetration"] and rep["normal_force"] > 0
    assert -3 * rep["sampled_penetration"] < rep["smallest_gap"] < 0
    assert rep["point"][0] == pytest.approx(1.09, abs=R)  # on the drum's crown


def test_unloaded_rope_through_a_small_drum_is_not_a_solution():
    """No gravity, the straight reference state cutting a drum 1 cm deep between two Gauss points: the start has no
    force, and used to be returned as the solution."""
    r = solve_static(_rope_over_small_drum(8, gravity=0.0, drum_y=-0.01))
    assert not r.success and r.status == contact_gap.STATUS


def _bar_on_ground(n: int):
    """A 1 m steel wire (4 mm) clamped 5 cm above a stiff ground (k = 1e7 N/m^2), bending down onto it under its
    weight."""
    sc = Scene(dim=2, gravity=(0.0, -9.81))
    sc.member("bar", [(0, 0.05), (1, 0.05)], n, Material(E=2e9, density=7800.0), Section.circle(0.004))
    sc.clamp("bar", "start")
    sc.contact_ground("bar", stiffness=1e7)
    return sc


def test_ground_seen_between_points_too():
    """At 2 elements the wire's free end lies on the ground beyond the last Gauss point (0.047 h from the end): it
    sinks 0.38 mm where the law sees 0.3 um, and the ground force is 24 % below the converged one: refused, naming
    the ground. At 16 elements the true gap is within the law's penetration and the force within 0.1 % of 32
    elements' (measured 0.6089 N both)."""
    coarse = solve_static(_bar_on_ground(2))
    assert coarse.status == contact_gap.STATUS and "the ground" in coarse.attempts[-1]["detail"]
    (rep,) = contact.report(coarse.assembly, coarse.x)
    assert rep["xi"] == 1.0 and rep["element"] == 1  # the tip
    fine = [solve_static(_bar_on_ground(n)) for n in (16, 32)]
    assert all(r.success for r in fine)
    reps = [contact.report(r.assembly, r.x)[0] for r in fine]
    assert not reps[0]["hidden_penetration"] and reps[0]["smallest_gap"] >= -3 * reps[0]["sampled_penetration"]
    assert reps[0]["normal_force"] == pytest.approx(reps[1]["normal_force"], rel=1e-3)
    assert rep["normal_force"] < 0.9 * reps[1]["normal_force"]


def test_exact_contact_reports_the_true_gap_between_its_rows():
    """Exact contact holds the same Gauss points (rows g >= 0) and is not checked between them (no penetration scale
    of its own): its result.json record carries the true smallest gap, which shows the 8-element rope through the
    small drum while every row holds (gaps at the points >= -1e-9 m, IPOPT's constraint tolerance 1e-10)."""
    sc = _rope_over_small_drum(8)
    sc.contacts.clear()
    sc.contact_drum("rope", (1.09, -0.012 - R - T), R, method="exact")
    r = solve_static(sc)
    (rep,) = static_result_dict(r)["contacts"]
    assert rep["method"] == "exact" and rep["min_gap"] > -1e-9
    assert rep["smallest_gap"] < -5e-3 and "hidden_penetration" not in rep


@pytest.mark.parametrize("integrator", ["generalized_alpha", "radau"])  # compiled chunks; single steps
def test_dynamics_stop_when_a_rope_falls_through_a_small_drum(integrator):
    """The coarse rope released straight falls through the drum between its points: the run ends with status
    contact_penetration_hidden at the time it happened, naming member and drum; free fall to the 1.2 cm gap takes
    about 50 ms (the pinned rope falls slower)."""
    res = simulate(_rope_over_small_drum(8), DynamicOptions(dt=1e-3, t_end=0.3, integrator=integrator))
    assert not res.success and res.status == contact_gap.DYNAMIC_STATUS
    assert "member 'rope'" in res.message and "drum of radius 0.02 m" in res.message
    assert 0.04 < res.t[-1] < 0.3
    (deep,) = res.contact_gaps  # the deepest true gap over the accepted steps: through the drum
    assert deep["smallest_gap"] < -R / 4 and deep["sampled_penetration"] == 0.0


def test_dynamics_find_the_small_drum_on_the_finer_mesh():
    """At 128 elements the falling rope lands on the drum (about 50 ms) and bounces on it: the run completes, and
    the rope's point over the drum never sinks below the drum's crown (its centre line at -12 mm) by more than
    1 mm (without the drum it would swing down past -20 mm); the law's penetration is of order 1e-5 m."""
    res = simulate(_rope_over_small_drum(128), DynamicOptions(dt=1e-3, t_end=0.3, output_dt=0.005,
                                                              sensors=[Sensor("y", "position", "rope", 1.09)]))
    assert res.success, res.message
    y = np.asarray(res.sensors["y"])[:, 1]
    assert -0.013 < y.min() < -0.0115
    (deep,) = res.contact_gaps  # it touched (the law's penetration is ~1e-5 m) and never went through
    assert -1e-3 < deep["smallest_gap"] < 0 and 0.04 < deep["t"] < 0.3
    assert res.to_dict()["contact_gaps"] == res.contact_gaps


def test_scenes_pay_only_for_penalty_contact():
    """No penalty contact, no check: the statics problem and the time loop build nothing for it."""
    from ancf_sym.statics import StaticProblem

    sc = _one_element()
    assert StaticProblem(sc)._gaps is False
    assert contact_gap.checked_contacts(sc) == []


if __name__ == "__main__":  # the table of docs/contact.md (What the law samples)
    for n in (8, 24, 32, 64, 128):
        r = solve_static(_rope_over_small_drum(n))
        (rep,) = contact.report(r.assembly, r.x)
        print(f"{n:4d} elements: {r.status}, smallest true gap {rep['smallest_gap']:.3g} m, law's penetration "
              f"{rep['sampled_penetration']:.3g} m, drum force {rep['normal_force']:.4g} N")
