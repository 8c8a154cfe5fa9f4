"""TOML for spatial bodies and their joints, closed members ([[loops]]) and initial conditions ([analysis] start,
[[analysis.initial]]): the file builds the same scene as the Python API, the initial states do what they say
physically, and bad input is refused when the file is read, naming the TOML path.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from ancf_sym import Material, Scene, SceneError, Section
from ancf_sym.scene import closed
from ancf_sym.model.assembly import Assembly
from ancf_sym.dynamics import run_dynamics
from ancf_sym.dynamics.initial import velocities
from ancf_sym.io.scene_toml import scene_from_dict

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

CART = """
[scene]
dim = 3
gravity = [0.0, 0.0, -9.81]

[[bodies]]
name = "bob"
mass = 1.0
inertia = [0.02, 0.02, 0.01]
position = [0.0, 0.0, -0.5]
revolute = {point = [0.0, 0.0, 0.0], axis = [0.0, 1.0, 0.0], other = "cart"}

[[bodies]]
name = "cart"
mass = 3.0
inertia = [0.1, 0.2, 0.2]
position = [0.0, 0.0, 0.0]
prismatic = {axis = [1.0, 0.0, 0.0]}

[analysis]
type = "dynamics"
dt = 0.005
t_end = 0.5
output_every = 10
sensors = [{name = "bob", kind = "body", member = "bob"}]

[[analysis.initial]]
member = "bob"
omega = [0.0, 2.0, 0.0]
centre = [0.0, 0.0, 0.0]
"""


def load(text: str):
    return scene_from_dict(tomllib.loads(text))


def test_spatial_bodies_from_toml_match_the_python_api():
    """The cart-pendulum file (a body joined to a body listed after it) gives the Python scene's coordinates, rows
    and mass matrix, and the same motion (the initial rotation of the bob about the hinge: max difference < 1e-12,
    the same arithmetic)."""
    scene, analysis = load(CART)
    s = Scene(dim=3, gravity=(0, 0, -9.81))
    s.body("bob", 1.0, (0.02, 0.02, 0.01), (0, 0, -0.5))
    s.body("cart", 3.0, (0.1, 0.2, 0.2), (0, 0, 0))
    s.revolute("bob", point=(0, 0, 0), axis=(0, 1, 0), other="cart")
    s.prismatic("cart", axis=(1, 0, 0))
    a, b = Assembly(scene), Assembly(s)
    assert a.n == b.n == 24 and a.constraints.m == b.constraints.m == 6 + 6 + 5 + 5
    assert abs(a.mass_matrix() - b.mass_matrix()).max() == 0
    r1 = run_dynamics(scene, analysis)
    v0 = velocities(b, rotation={"bob": ((0, 2.0, 0), (0, 0, 0))})
    opts = {k: v for k, v in analysis.items() if k not in ("type", "initial")}
    r2 = run_dynamics(s, {**opts, "v0": v0})
    assert r1.status == r2.status == "completed"
    assert np.abs(r1.sensors["bob"] - r2.sensors["bob"]).max() < 1e-12
    assert abs(r1.sensors["bob"][0, 4] - 2.0) < 1e-12  # the sensor's angular velocity is the given omega


LOOP = """
[scene]
dim = 2
[materials.rubber]
E = 1e8
density = 1200.0
[sections.belt]
area = 1e-4
I = 1e-10
[[loops]]
name = "belt"
pulleys = [[[0.0, 0.0], 0.1], [[0.5, 0.0], 0.05]]
elements = 24
material = "rubber"
section = "belt"
prestrain = 0.002
gravity = false
[[supports]]
type = "pin"
member = "belt"
at = 0
"""


def test_loop_from_toml_matches_scene_loop():
    """[[loops]] with pulleys builds the member Scene.loop builds along closed.belt_path: the same closed mesh
    (last element ending on node 0) and reference coordinates, its length the belt's path over 1 + prestrain."""
    scene, _ = load(LOOP)
    s = Scene(dim=2)
    path = closed.belt_path([((0.0, 0.0), 0.1), ((0.5, 0.0), 0.05)])
    s.loop("belt", path, 24, Material(E=1e8, density=1200.0), Section(area=1e-4, I=1e-10), prestrain=0.002,
           gravity=False)
    m1, m2 = scene.members["belt"], s.members["belt"]
    assert m1.closed and m1.n_nodes == 24
    assert np.array_equal(Assembly(scene).x0, Assembly(s).x0)
    assert math.isclose(m1.length, closed.check_path(path) / 1.002, rel_tol=1e-12)
    assert Assembly(scene).mesh.members["belt"].elem_nodes[-1].tolist() == [23, 0]


ROPE = """
[scene]
dim = 2
gravity = [0.0, -9.81]
[materials.steel]
E = 2e11
density = 7800.0
[sections.rod]
shape = "circle"
diameter = 0.01
[[members]]
name = "rod"
points = [[0.0, 0.0], [1.0, 0.0]]
elements = 4
material = "steel"
section = "rod"
[analysis]
type = "dynamics"
dt = 0.001
t_end = 0.1
output_every = 10
sensors = [{name = "tip", kind = "position", member = "rod", at = "end"}]
"""


def test_uniform_initial_velocity_translates_a_free_member():
    """A free steel rod launched at v = (2, 3) m/s without supports, in gravity: every point follows the ballistic
    path r0 + v t + g t^2 / 2 (no strain appears; the Newmark family integrates a constant acceleration exactly, so
    the error is Newton's tolerance level: < 1e-9 m)."""
    scene, analysis = load(ROPE + '[[analysis.initial]]\nmember = "rod"\nvelocity = [2.0, 3.0]\n')
    r = run_dynamics(scene, analysis)
    assert r.status == "completed"
    t = r.t[:, None]
    expect = np.array([1.0, 0.0]) + np.array([2.0, 3.0]) * t + 0.5 * np.array([0.0, -9.81]) * t**2
    assert np.abs(r.sensors["tip"] - expect).max() < 1e-9


def test_start_from_static_stays_at_rest():
    """A clamped rod under its own weight started from its static equilibrium (start = "static") stays there: tip
    motion < 1e-9 m, while from the unloaded reference it falls and oscillates about it by ~ its static deflection
    (rho g A L^4 / (8 EI) = 7.7e-3 m for this rod)."""
    text = ROPE + '[[supports]]\ntype = "clamp"\nmember = "rod"\nat = "start"\n'
    static_text = text.replace('type = "dynamics"', 'type = "dynamics"\nstart = "static"')
    s1, a1 = load(static_text)
    s0, a0 = load(text)
    r1, r0 = run_dynamics(s1, a1), run_dynamics(s0, a0)
    assert r1.status == r0.status == "completed"
    w = 7800 * 9.81 * (math.pi * 0.01**2 / 4) / (8 * 2e11 * math.pi * 0.01**4 / 64)
    assert np.abs(r1.sensors["tip"] - r1.sensors["tip"][0]).max() < 1e-9
    assert abs(r1.sensors["tip"][0, 1] + w) < 1e-2 * w  # started at the static deflection
    assert np.abs(r0.sensors["tip"][:, 1]).max() > 1.5 * w  # from the reference it overshoots it


@pytest.mark.parametrize("text, path", [
    (CART.replace('axis = [0.0, 1.0, 0.0], other = "cart"', 'other = "cart"'), "bodies[0].revolute.axis"),
    (CART.replace('other = "cart"', 'other = "ghost"'), "bodies[0].revolute.other"),
    (CART.replace("mass = 3.0", "mass = -3.0"), "bodies[1].mass"),
    (CART.replace("inertia = [0.1, 0.2, 0.2]", "inertia = [0.1, 0.1, 0.3]"), "bodies[1].inertia"),
    (CART.replace('position = [0.0, 0.0, 0.0]', 'position = [0.0, 0.0, 0.0]\nangle = 0.2'), "bodies[1].angle"),
    (CART.replace('position = [0.0, 0.0, 0.0]', 'position = [0.0, 0.0, 0.0]\ncolour = "red"'), "bodies[1].colour"),
    (CART.replace('member = "bob"\nomega', 'member = "nobody"\nomega'), "analysis.initial[0].member"),
    (CART.replace('centre = [0.0, 0.0, 0.0]', 'velocity = [1.0, 0.0, 0.0]'), "analysis.initial[0]"),
    (CART.replace('t_end = 0.5', 't_end = 0.5\nstart = "equilibrium"'), "analysis.start"),
    (LOOP.replace("elements = 24", "elements = 24\npath = []"), "loops[0]"),
    (LOOP.replace('material = "rubber"', 'material = "steel"'), "loops[0].material"),
    (LOOP.replace("[[[0.0, 0.0], 0.1], [[0.5, 0.0], 0.05]]", "[[[0.0, 0.0], 0.1]]"), "loops[0].pulleys"),
])
def test_bad_toml_refused_naming_the_path(text, path):
    with pytest.raises(SceneError) as exc:
        load(text)
    assert str(exc.value).startswith(path), str(exc.value)


def test_docs_tables_match_the_schema():
    """docs/scenes.md shows the declared [[bodies]], body-joint, [[loops]] and [[analysis.initial]] keys."""
    from pathlib import Path

    from ancf_sym.scene.schema import BODY, BODY_JOINT, INITIAL, LOOP as LOOP_KEYS, fields_table

    page = (Path(__file__).resolve().parents[2] / "docs" / "scenes.md").read_text()
    for table in (BODY, BODY_JOINT, LOOP_KEYS, INITIAL):
        assert fields_table(table) in page


BLOCK = """
# a steel block hung from two steel wires 0.4 m apart by pins: no neutral mode, a unique static equilibrium
[scene]
name = "block3d"
dim = 3
gravity = [0.0, 0.0, -9.81]
[materials.steel]
E = 2e11
density = 7800.0
[sections.wire]
shape = "circle"
diameter = 0.004
[[members]]
name = "left"
points = [[-0.2, 0.0, 0.0], [-0.2, 0.0, -1.0]]
elements = 3
material = "steel"
section = "wire"
gravity = false
[[members]]
name = "right"
points = [[0.2, 0.0, 0.0], [0.2, 0.0, -1.0]]
elements = 3
material = "steel"
section = "wire"
gravity = false
[[supports]]
type = "pin"
member = "left"
[[supports]]
type = "pin"
member = "right"
[[bodies]]
name = "block"
mass = 20.0
inertia = [0.2, 0.3, 0.4]
position = [0.0, 0.0, -1.2]
pin = [["left", "end"], ["right", "end"]]
[analysis]
type = "dynamics"
dt = 2e-3
t_end = 0.1
start = "static"
output_dt = 0.02
sensors = [{ name = "block", kind = "body", member = "block" }]
"""


def test_cli_runs_a_spatial_body_from_its_static_equilibrium(tmp_path):
    """`ancf-sym run` on a 3D scene with a body on two wires, start = "static": the run completes and the block,
    started at its equilibrium, stays at rest (centre motion < 1e-9 m over 0.1 s; it hangs 0.2 m below the wire
    ends, which stretched by m g L / (2 EA) = 39 um each, so the centre sits 1.2 m + 39 um down, to 1e-3 relative
    on the stretch: Green strain differs from the engineering one by ~eps/2)."""
    from helpers import cli

    (tmp_path / "block3d.toml").write_text(BLOCK)
    p = cli("run", "block3d.toml", "--out", "out", cwd=tmp_path)
    assert p.returncode == 0, p.stderr
    import json

    d = json.loads((tmp_path / "out" / "result.json").read_text())
    assert d["status"] == "completed"
    S = np.asarray(d["sensors"]["block"])
    assert np.abs(S[:, :3] - S[0, :3]).max() < 1e-9
    stretch = 20 * 9.81 * 1.0 / (2 * 2e11 * math.pi * 0.004**2 / 4)
    assert abs((-S[0, 2] - 1.2) / stretch - 1) < 1e-3


WHEEL = """
[scene]
dim = 3
[[bodies]]
name = "wheel"
mass = 2.0
inertia = [0.1, 0.1, 0.2]
position = [0.0, 0.0, 0.0]
revolute = {axis = [0.0, 0.0, 1.0]}
[[drives]]
type = "torque"
body = "wheel"
torque = [0.3, -0.2, 0.4]
[analysis]
type = "dynamics"
dt = 1e-3
t_end = 1.0
output_every = 50
sensors = [{ name = "wheel", kind = "body", member = "wheel" }]
"""


def test_toml_torque_on_a_spatial_body_spins_it_up():
    """A [[drives]] torque (world components) on a wheel on a revolute joint about z: only its z component does
    work, so omega = (0, 0, tau_z t / J_z) = 2 t rad/s; the x and y components are carried by the joint. The
    natural-coordinate integration of a uniformly accelerated rotation is second order: (omega h)^2 <= 4e-6 at the
    end, tolerance 1e-5 relative."""
    scene, analysis = load(WHEEL)
    r = run_dynamics(scene, analysis)
    assert r.status == "completed"
    w = r.sensors["wheel"][:, 3:6]
    assert np.abs(w - np.c_[0 * r.t, 0 * r.t, 2.0 * r.t]).max() < 1e-5 * 2.0
