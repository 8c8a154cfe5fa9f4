"""Fixed drums in scenes (Scene.contact_drum, TOML type = "circle"): bad input refused before any work; statics with
the penalty law balances the supports; every integrator runs a rope falling onto a drum with friction; results
(statics and dynamics result.json, VTK point data) report the contact gap and force."""
from __future__ import annotations

import json
from pathlib import Path

import meshio
import numpy as np
import pytest

from ancf_sym import Material, Scene, SceneError, Section, contact, solve_static
from ancf_sym.dynamics import DynamicOptions, simulate

from helpers import cli


def _scene(gravity=(0.0, 0.0)):
    sc = Scene(dim=2, gravity=gravity)
    sc.member("rope", [(0, 0), (1, 0)], 16, Material(E=2e9, density=1000.0), Section.circle(0.004))
    return sc


@pytest.mark.parametrize("options,pattern", [
    (dict(member="nope", centre=(0, 0), radius=0.1, stiffness=1e4), r"member 'nope' does not exist"),
    (dict(member="rope", centre=(0, 0), radius=0.1, stiffness=-1.0), r"stiffness must be finite and >= 0"),
    (dict(member="rope", centre=(0, 0), radius=0.0, stiffness=1e4), r"radius must be finite and > 0, got 0.0"),
    (dict(member="rope", centre=(0, 0, 0), radius=0.1, stiffness=1e4), r"centre must be a vector of 2 numbers"),
    (dict(member="rope", centre=(0, 0), radius=0.1, stiffness=1e4, axis=(0, 0, 1)), r"axis is for 3D"),
    (dict(member="rope", centre=(0, 0), radius=0.1, stiffness=1e4, mu=-0.2), r"mu must be finite and >= 0"),
    (dict(member="rope", centre=(0, 0), radius=0.1), r"positive stiffness"),
    (dict(member="rope", centre=(0, 0), radius=0.1, method="exact", mu=0.2), r"method=.exact. is frictionless"),
])
def test_bad_drum_input_is_refused(options, pattern):
    sc = _scene()
    with pytest.raises(SceneError, match=pattern):
        sc.contact_drum(**options)
    assert sc.contacts == []


def test_drum_in_3d_needs_a_unit_axis():
    sc = Scene(dim=3, gravity=(0, 0, 0))
    sc.member("rope", [(0, 0, 0), (1, 0, 0)], 4, Material(E=2e9, density=1000.0), Section.circle(0.004))
    with pytest.raises(SceneError, match="axis must be a non-zero vector of 3"):
        sc.contact_drum("rope", (0.5, 0, -0.2), 0.2, axis=(0, 0, 0), stiffness=1e6)
    c = sc.contact_drum("rope", (0.5, 0, -0.2), 0.2, axis=(0, 2.0, 0), stiffness=1e6)
    assert np.allclose(c.axis, (0, 1, 0))


def test_statics_drum_force_balances_the_pins():
    """A rope pinned at both ends, pushed up 2 cm by a drum (no gravity): the drum's normal force (sum of nodal
    magnitudes, contact.report) equals the pins' vertical reactions to within 1 - cos of the rope's slope at the
    contact (< 0.07 rad: 2.5e-3); the rope presses into the drum (gap < 0) by a small fraction of the push."""
    sc = _scene()
    sc.pin("rope", "start")
    sc.pin("rope", "end")
    sc.contact_drum("rope", (0.5, -0.2 + 0.02), 0.2, stiffness=1e7)
    r = solve_static(sc)
    assert r.success, r.status
    (rep,) = contact.report(r.assembly, r.x)
    pins = sum(v[1] for k, v in r.constraint_forces.items() if k.startswith("pin"))
    assert rep["type"] == "circle" and rep["normal_force"] == pytest.approx(abs(pins), rel=5e-3)
    assert -1e-3 < rep["min_gap"] < 0


@pytest.mark.parametrize("integrator", ["newmark", "hht", "generalized_alpha", "radau", "gauss"])
def test_rope_falls_onto_a_drum_with_friction_in_every_integrator(integrator):
    """A rope released 5 mm above a drum under gravity lands on it within 0.05 s (free fall: 32 ms): the run
    completes, and at the end the drum carries a force of the order of the rope's weight (it lands and bounces on
    a damped penalty law: between 0 and 20 times the weight)."""
    sc = _scene(gravity=(0.0, -9.81))
    t = 0.002
    sc.contact_drum("rope", (0.5, -0.3 - t - 0.005), 0.3, stiffness=1e5, damping=1e3, mu=0.3, eps=1e-2)
    res = simulate(sc, DynamicOptions(dt=2e-3, t_end=0.06, integrator=integrator))
    assert res.success, res.message
    (rep,) = contact.report(res.assembly, res.x)
    W = 1000.0 * np.pi * t**2 * 9.81
    assert 0 < rep["normal_force"] < 20 * W


TOML = """
[scene]
dim = 2
gravity = [0, 0]
[materials.rope]
E = 2e9
density = 1000
[sections.d8]
shape = "circle"
diameter = 0.008
[[members]]
name = "rope"
points = [[0, 0], [1, 0]]
elements = 16
material = "rope"
section = "d8"
[[supports]]
type = "pin"
member = "rope"
at = "start"
[[supports]]
type = "pin"
member = "rope"
at = "end"
[[contacts]]
type = "circle"
member = "rope"
centre = [0.5, -0.18]
radius = 0.2
stiffness = 1e7
"""


def test_toml_circle_contact_and_results_report_gap_and_force(tmp_path):
    """TOML [[contacts]] type = "circle" runs through the command line; result.json carries the contact's gap and
    force (the same numbers as contact.report), the VTK file its point data, negative gap where it touches."""
    from ancf_sym.io.scene_toml import load_scene

    f = tmp_path / "drum.toml"
    f.write_text(TOML)
    sc, _ = load_scene(f)
    (c,) = sc.contacts
    assert isinstance(c, contact.DrumContact) and c.radius == 0.2 and list(c.centre) == [0.5, -0.18]
    for bad, pattern in (("radius = 0.2", r"contacts\[0\].*radius: missing"),
                         ("centre = [0.5, -0.18]", r"contacts\[0\].*centre: missing"),
                         ('type = "circle"', r"contacts\[0\].*unknown key 'centre'")):
        f.write_text(TOML.replace(bad, 'type = "ground"' if bad.startswith("type") else ""))
        with pytest.raises(SceneError, match=pattern):
            load_scene(f)
    f.write_text(TOML)
    out = tmp_path / "out"
    r = cli("run", f, "--out", out, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    doc = json.loads((out / "result.json").read_text())
    (rep,) = doc["contacts"]
    assert rep["type"] == "circle" and rep["min_gap"] < 0 and rep["normal_force"] > 0
    (vtu,) = list(Path(out).glob("*.vtu"))
    pd = meshio.read(vtu).point_data
    assert pd["contact_gap"].min() == pytest.approx(rep["min_gap"], rel=1e-9)
    assert pd["contact_force"].max() > 0 and np.all(pd["contact_force"] >= -1e-9 * rep["normal_force"])


def test_dynamics_results_carry_contact_series(tmp_path):
    """The dynamics result.json lists per contact min_gap and normal_force at every output time: 1 mm and no force
    at the start, touching with a force at the end; the VTK frames carry the point data."""
    from ancf_sym.io.scene_toml import load_scene

    f = tmp_path / "drum.toml"
    # the drum 1 mm below the rope's surface: it lands after 14 ms of free fall
    f.write_text(TOML.replace("gravity = [0, 0]", "gravity = [0, -9.81]").replace("-0.18", "-0.205")
                 .replace("stiffness = 1e7", "stiffness = 1e5\ndamping = 1e3\nmu = 0.3\neps = 0.01")
                 + '[analysis]\ntype = "dynamics"\ndt = 1e-3\nt_end = 0.03\noutput_dt = 0.01\n')
    load_scene(f)
    out = tmp_path / "out"
    r = cli("run", f, "--out", out, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    doc = json.loads((out / "result.json").read_text())
    (rep,) = doc["contacts"]
    assert len(rep["min_gap"]) == len(rep["normal_force"]) == len(doc["t"])
    assert rep["min_gap"][0] == pytest.approx(1e-3) and rep["normal_force"][0] == 0
    assert rep["min_gap"][-1] < 0 and rep["normal_force"][-1] > 0
    frame = sorted((out / "frames").glob("*.vtu"))[-1]
    assert "contact_gap" in meshio.read(frame).point_data
