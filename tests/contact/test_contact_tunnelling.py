"""Penalty contact statics never carries a cable through a drum (ancf_sym.contact.steps).

Reference: Exudyn's test model ANCFcontactCircleTest as the bundled scene examples/scenes/ancf_contact_circle.toml
(a 2 m cable clamped at one end, loaded by its weight, falling onto two circles), meshed with 32 elements where
Exudyn's test has 8 (at 8 the law's points do not resolve the contact: tests/contact/test_contact_circle_resolution.py).
Before the step limit the first Newton step carried the cable through both circles and statics reported success
with the tip at y = -1.86 m and no contact force.
"""
from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
import pytest

from ancf_sym import contact
from ancf_sym.statics import problem as statics
from ancf_sym.contact.steps import DEPTH, StepLimit
from ancf_sym.io.scene_toml import load_scene, scene_from_dict
from ancf_sym.statics import StaticOptions, solve_static

SCENE = Path(__file__).resolve().parents[2] / "examples" / "scenes" / "ancf_contact_circle.toml"
# Exudyn's tip y of ANCFcontactCircleTest.py with nElements = 32, everything else as in the test (k = 1e3 N/m per
# contact segment, 4 segments per element, 40 geometric load steps), measured with exudyn 1.13.6; its own reference
# value at 8 elements is -0.4842656547442095 m
EXUDYN_TIP_Y_32 = -0.467207
WEIGHT = 80.0 * 7800.0 * 1e-6 * 2.0  # the cable's load [N]: rho A g L with g = 80 m/s^2


def _solve(doc: dict):
    scene, analysis = scene_from_dict(doc)
    opts = StaticOptions(**{k: v for k, v in analysis.items() if k != "type"})
    return solve_static(scene, opts)


def _doc() -> dict:
    return tomllib.loads(SCENE.read_text())


def test_exudyn_contact_circle_scene_finds_the_contact_branch():
    """The bundled scene, solved as the command line solves it (full load, no load steps written): success, stable,
    both circles carry the cable, and the tip lies within 5 mm of Exudyn's at the same mesh (32 elements). Why
    5 mm: the two models sample the contact differently (Exudyn: a point force at the closest point of 4 straight
    segments per element; here the line law at 5 Gauss points per element); at 32 elements this law's tip moves by
    2.9 mm between 3 and 7 points per element and lies 0.9 mm from its 128-element value, Exudyn's moves by 0.4 mm
    between 16 and 64 elements (measured 0.07 mm apart); the tunnelled answer lies 1.4 m away. The circles carry
    most of the weight (the clamp the rest): each more than a quarter of it."""
    scene, analysis = load_scene(SCENE)
    r = solve_static(scene, StaticOptions(**{k: v for k, v in analysis.items() if k != "type"}))
    assert r.success and r.stable, (r.status, r.attempts)
    assert abs(r.tip("cable")[1] - EXUDYN_TIP_Y_32) < 5e-3
    forces = [rep["normal_force"] for rep in contact.report(r.assembly, r.x)]
    assert all(f > 0.25 * WEIGHT for f in forces), forces
    assert sum(forces) < WEIGHT


def test_load_steps_from_toml_give_the_automatic_answer():
    """[analysis] load_stepping = true (8 steps of 1/8 from the start) reaches the same equilibrium as the automatic
    path: both converge to the relative tolerance 1e-10 (increment in units of L = 2 m), so the tips agree to far
    below 1e-8 m; the stepped run did no direct full-load Newton."""
    auto = _solve(_doc())
    doc = _doc()
    doc["analysis"]["load_stepping"] = True
    stepped = _solve(doc)
    assert stepped.success and stepped.stable
    assert stepped.attempts[0]["method"] == "newton load steps"
    assert np.abs(stepped.tip("cable") - auto.tip("cable")).max() < 1e-8


def test_consistent_gravity_variant_lands_on_the_drums():
    """The same cable under gravity (consistent nodal loads): the direct Newton stalls, the continuation and IPOPT
    follow; no step through a circle, so the answer is on the contact branch (both circles loaded, the tip within
    3 cm of Exudyn's: the consistent and lumped loads differ by the nodal moments, 1.1 mm measured at 32 elements,
    ~1 cm at 8), never the tunnelled -1.86 m."""
    doc = _doc()
    doc.pop("loads")
    doc["scene"]["gravity"] = [0.0, -80.0]
    r = _solve(doc)
    assert r.success, (r.status, r.attempts)
    assert abs(r.tip("cable")[1] - EXUDYN_TIP_Y_32) < 3e-2
    assert all(rep["normal_force"] > 0.25 * WEIGHT for rep in contact.report(r.assembly, r.x))


def _closest(limit: StepLimit, x: np.ndarray, dz: np.ndarray, t: float) -> float:
    """Smallest distance to a drum axis over the points along x + s dz, s in [0, t] (sampled finely), relative to
    the drum's contact radius, among points that start outside DEPTH rho (independent of the limit's algebra)."""
    worst = np.inf
    for c, P, rho in limit.blocks:
        d0 = np.linalg.norm(limit.relative(c, P, x), axis=1)
        out = d0 > DEPTH * rho
        for s in np.linspace(0.0, t, 401):
            d = np.linalg.norm(limit.relative(c, P, x + s * dz), axis=1)
            worst = min(worst, float(np.min(d[out] / rho, initial=np.inf)))
    return worst


def test_no_newton_step_crosses_a_declared_surface():
    """Every step of the Newton runs of a solve (recorded at the limit: x, the full step, the cut) keeps every point
    that starts outside at least DEPTH x rho from each drum's axis: sampled along the cut step, the closest
    approach stays >= DEPTH rho (less 1e-9 for the sampling's round-off). The first step is cut (it would carry the
    cable 36 lengths down)."""
    scene, _ = load_scene(SCENE)
    statics._CACHE.clear()
    prob = statics.problem_for(scene)
    limit = prob.newton.step_limit
    steps = []

    def record(x, dz):
        t = StepLimit.__call__(limit, x, dz)
        steps.append((x.copy(), dz.copy(), t))
        return t

    prob.newton.step_limit = record
    try:
        r = prob.solve()
    finally:
        prob.newton.step_limit = limit
        statics._CACHE.clear()
    assert r.success
    assert steps[0][2] < 0.05
    for x, dz, t in steps[:40]:  # (the first ones carry the cable onto the drums; later ones are short)
        assert _closest(limit, x, dz, t) >= DEPTH - 1e-9


def test_limit_of_a_point_moving_through_a_drum():
    """A cable lying above a drum (radius 0.1 m, centre 0.3 m below it), moved straight down by 1 m: the limit is the
    time at which its nearest point reaches DEPTH rho from the centre, (0.3 - DEPTH 0.1) / 1; moved sideways it is
    not limited; moved up (away) neither."""
    doc = {"scene": {"dim": 2, "gravity": [0, 0]}, "materials": {"m": {"E": 1e9, "density": 1000}},
           "sections": {"s": {"area": 1e-6, "I": 1e-13}},
           "members": [{"name": "c", "points": [[-1, 0], [1, 0]], "elements": 4, "material": "m", "section": "s"}],
           "supports": [{"type": "clamp", "member": "c", "at": "start"}],
           "contacts": [{"type": "circle", "member": "c", "centre": [0, -0.3], "radius": 0.1, "stiffness": 1e4,
                         "thickness": 0.0}]}
    scene, _ = scene_from_dict(doc)
    from ancf_sym.model.assembly import Assembly
    from ancf_sym.contact.steps import limiter

    asm = Assembly(scene)
    lim = limiter(asm)
    x = asm.x0.copy()
    down, side = np.zeros(asm.n), np.zeros(asm.n)
    mm = asm.mesh.members["c"]
    for k in range(mm.n_nodes):
        down[mm.offset + k * mm.node_size + 1] = -1.0
        side[mm.offset + k * mm.node_size] = 0.05
    assert lim(x, down) == pytest.approx((0.3 - DEPTH * 0.1) / 1.0, rel=1e-12)
    assert lim(x, side) == 1.0
    assert lim(x, -down) == 1.0


def test_ipopt_step_through_a_drum_is_rejected():
    """IPOPT's full steps cannot be cut: from the straight cable under gravity they carry it through the circles
    (measured: it converged on the tunnelled branch, tip at -1.86 m). The iteration watch flags that run, whose
    status then says why it was not taken."""
    doc = _doc()
    doc.pop("loads")
    doc["scene"]["gravity"] = [0.0, -80.0]
    scene, _ = scene_from_dict(doc)
    prob = statics.StaticProblem(scene)
    ok, status, _, x, _ = prob._run(prob.asm.x0, None, 1.0, False, StaticOptions())
    assert not ok and status == statics.TUNNELLED
