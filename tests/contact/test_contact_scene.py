"""Contact declarations: bad input refused before any work, naming the field and value; exact contact is statics
only; a rope pressed on the ground by exact contact carries its weight through the contact multipliers."""
from __future__ import annotations

import numpy as np
import pytest

from ancf_sym import Material, Scene, SceneError, Section, solve_static
from ancf_sym.dynamics import DynamicOptions, simulate


def _scene():
    sc = Scene(dim=2, gravity=[0, -9.81])
    sc.member("rope", [[0, 0.01], [1.0, 0.01]], 8, Material(E=2e9, density=1000.0), Section.circle(0.01))
    return sc


@pytest.mark.parametrize("options,pattern", [
    (dict(member="nope", stiffness=1e4), r"member 'nope' does not exist"),
    (dict(member="rope", stiffness=-1.0), r"stiffness must be finite and >= 0, got -1.0"),
    (dict(member="rope", hertz=float("nan")), r"hertz must be finite"),
    (dict(member="rope", stiffness=1e4, mu=-0.1), r"mu must be finite and >= 0, got -0.1"),
    (dict(member="rope", stiffness=1e4, damping=-1), r"damping"),
    (dict(member="rope", stiffness=1e4, mu=0.3, eps=0.0), r"eps"),
    (dict(member="rope"), r"positive stiffness"),
    (dict(member="rope", stiffness=1e4, normal=[0, 0]), r"normal"),
    (dict(member="rope", stiffness=1e4, gauss=4), r"gauss"),
    (dict(member="rope", method="exact", stiffness=1e4), r"method='exact'"),
    (dict(member="rope", method="exact", mu=0.2), r"method='exact'"),
    (dict(member="rope", method="lagrange"), r"method must be"),
])
def test_bad_contact_input_is_refused(options, pattern):
    sc = _scene()
    with pytest.raises(SceneError, match=pattern):
        sc.contact_ground(**options)
    assert sc.contacts == []


def test_exact_contact_is_refused_in_dynamics():
    sc = _scene()
    sc.contact_ground("rope", method="exact")
    with pytest.raises(SceneError, match="statics"):
        simulate(sc, DynamicOptions(dt=1e-3, t_end=0.01))


def test_exact_contact_carries_the_weight():
    """A rope pinned at its left end lying on the ground (its centre line at the section radius): the contact
    multipliers and the pin's vertical reaction together carry the weight exactly (force balance of an
    equilibrium; IPOPT's tolerance, 1e-6 relative), no point below the ground, and no contact force pulls."""
    sc = Scene(dim=2, gravity=[0, -9.81])
    sec = Section.circle(0.01)
    sc.member("rope", [[0, 0.005], [1.0, 0.005]], 8, Material(E=2e9, density=1000.0), sec)
    sc.pin("rope", "start")
    sc.contact_ground("rope", method="exact")
    r = solve_static(sc)
    assert r.success, r.status
    W = 1000.0 * sec.area * 9.81
    f = np.asarray(r.constraint_forces["contact"])
    pin = r.constraint_forces["pin rope@start"]
    assert np.all(f >= 0) and r.constraint_violation < 1e-9
    assert f.sum() - pin[1] == pytest.approx(W, rel=1e-6)  # the pin force on the rope is minus its multiplier


TOML = """
[scene]
dim = 2
gravity = [0, -9.81]
[materials.rope]
E = 2e9
density = 1000
[sections.d10]
shape = "circle"
diameter = 0.01
[[members]]
name = "rope"
points = [[0, 0.05], [1, 0.05]]
elements = 20
material = "rope"
section = "d10"
[[contacts]]
type = "ground"
member = "rope"
stiffness = 1e4
damping = 3e4
mu = 0.3
eps = 0.01
[analysis]
type = "dynamics"
dt = 1e-3
t_end = 0.1
"""


def test_toml_contacts(tmp_path):
    from ancf_sym.io.scene_toml import load_scene

    f = tmp_path / "drop.toml"
    f.write_text(TOML)
    sc, _ = load_scene(f)
    (c,) = sc.contacts
    assert (c.member, c.stiffness, c.damping, c.mu, c.eps) == ("rope", 1e4, 3e4, 0.3, 0.01)
    for bad, pattern in (("mu = 0.3", r"contacts\[0\].*mu must be finite and >= 0, got -0.3"),
                         ('member = "rope"', r"contacts\[0\].*member 'rop' does not exist"),
                         ("stiffness = 1e4", r"contacts\[0\].*stiffness must be a number")):
        f.write_text(TOML.replace(bad, {"mu = 0.3": "mu = -0.3", 'member = "rope"': 'member = "rop"',
                                        "stiffness = 1e4": 'stiffness = "stiff"'}[bad]))
        with pytest.raises(SceneError, match=pattern):
            load_scene(f)
    f.write_text(TOML.replace("eps = 0.01", "eps = 0.01\nfriction = 1"))
    with pytest.raises(SceneError, match=r"contacts\[0\].*unknown key 'friction'"):
        load_scene(f)
