"""What the Python API says, TOML says too: point masses ([[masses]], Scene.point_mass), supports released after a
starting statics ([analysis] release), a start from an earlier result.json ([analysis] from_result), sensors and
time loads declared in the schema and documented; errors name the TOML field (an initial velocity that a support
forbids names its [[analysis.initial]] table)."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from ancf_sym import Material, Scene, SceneError, Section
from ancf_sym.dynamics import DynamicOptions, run_dynamics, simulate
from ancf_sym.io.scene_toml import load_scene, scene_from_dict
from ancf_sym.statics import solve_static

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

STEEL = Material(E=2e11, density=7800.0)
ROD = Section.circle(0.02)
G = 9.81

BEAM = """
[scene]
dim = 2
gravity = [0.0, -9.81]
[materials.steel]
E = 2e11
density = 7800.0
[sections.rod]
shape = "circle"
diameter = 0.02
[[members]]
name = "b"
points = [[0.0, 0.0], [1.0, 0.0]]
elements = 6
material = "steel"
section = "rod"
axial = "biot"
[[supports]]
type = "pin"
member = "b"
at = "start"
[[supports]]
type = "pin"
member = "b"
at = "end"
"""


def load(text: str, base=None):
    return scene_from_dict(tomllib.loads(text), base=base)


# -- point masses ----------------------------------------------------------------------------------------------

def test_point_mass_weight_bends_a_cantilever_as_euler_bernoulli_says():
    """A weightless cantilever carrying a point mass m at a = 0.55 m (inside element 5 of 10): tip deflection
    m g a^2 (3 L - a) / (6 EI). Hermite cubic beam elements with a consistent load vector give exact nodal values
    for the linear beam, so what is left is geometric nonlinearity, of order (w/L)^2 ~ 1e-6: 1e-4 relative."""
    L, a, m = 1.0, 0.55, 4.0
    s = Scene(dim=2, gravity=(0.0, -G))
    s.member("b", [(0, 0), (L, 0)], 10, STEEL, ROD, axial="decoupled", gravity=False)
    s.clamp("b")
    s.point_mass("b", a, m)
    r = solve_static(s)
    assert r.success
    EI = STEEL.E * ROD.I
    w = m * G * a**2 * (3 * L - a) / (6 * EI)
    assert r.tip("b")[1] == pytest.approx(-w, rel=1e-4)


def test_pendulum_with_tip_mass_swings_at_the_rigid_frequency():
    """A stiff steel rod pinned at its top with a point mass at its end (TOML [[masses]]), released at rest from
    3 degrees: the compound pendulum's omega^2 = g (M + m/2) / (L (M + m/3)) (m the rod's mass), period longer by
    (1 + theta0^2/16) at that amplitude. The rod's stretch and bending under the swing are ~1e-6 of L and
    generalized-alpha's period error at 400 steps per period is ~(omega dt)^2 / 12 ~ 2e-5: 1e-3 relative."""
    L, M, th = 0.5, 2.0, math.radians(3.0)
    tip = [L * math.sin(th), -L * math.cos(th)]
    text = BEAM.replace("[[0.0, 0.0], [1.0, 0.0]]", f"[[0.0, 0.0], {tip}]").replace("elements = 6", "elements = 4")
    text = text.split("[[supports]]")[0] + f"""
[[supports]]
type = "pin"
member = "b"
[[masses]]
member = "b"
at = "end"
mass = {M}
"""
    scene, _ = load(text)
    assert len(scene.point_masses) == 1 and scene.point_masses[0].mass == M
    m = STEEL.density * ROD.area * L
    omega = math.sqrt(G * (M + m / 2) / (L * (M + m / 3)))
    T = 2 * math.pi / omega * (1 + th**2 / 16)
    dt = T / 400
    r = simulate(scene, DynamicOptions(dt=dt, t_end=1.1 * T, output_every=1, energies=False,
                                       sensors=[{"name": "tip", "kind": "position", "member": "b"}]))
    assert r.success
    x, t = r.sensors["tip"][:, 0], r.t
    k = np.nonzero((x[:-1] > 0) & (x[1:] <= 0) | (x[:-1] < 0) & (x[1:] >= 0))[0]
    cross = t[k] - x[k] * (t[k + 1] - t[k]) / (x[k + 1] - x[k])  # zero crossings (T/4, 3T/4)
    assert len(cross) >= 2
    assert 2 * (cross[1] - cross[0]) == pytest.approx(T, rel=1e-3)


def test_point_mass_refused_naming_the_toml_field():
    for extra, path in (('[[masses]]\nmember = "b"\nat = "end"\nmass = -1.0\n', "masses[0].mass"),
                        ('[[masses]]\nmember = "c"\nat = "end"\nmass = 1.0\n', "masses[0].member"),
                        ('[[masses]]\nmember = "b"\nat = 3.5\nmass = 1.0\n', "masses[0].at"),
                        ('[[masses]]\nmember = "b"\nmass = 1.0\n', "masses[0].at"),
                        ('[[masses]]\nmember = "b"\nat = 0\nmass = 1.0\ninertia = 2.0\n', "masses[0].inertia")):
        with pytest.raises(SceneError) as exc:
            load(BEAM + extra)
        assert str(exc.value).startswith(path), str(exc.value)


# -- supports released after the starting statics ----------------------------------------------------------------

def test_prop_released_after_the_static_start_lets_the_beam_fall_as_a_pinned_bar():
    """A beam pinned at both ends under its own weight; the end pin holds the starting statics and is released
    ([analysis] release): the beam then swings about its start pin as a rigid bar, tip acceleration 3 g / 2, so
    its tip falls 3 g t^2 / 4. The release also starts a bending vibration of the amplitude of the static
    deflection delta = 5 q L^4 / (384 EI) (2e-4 m here): the tip stays within 3 delta of the rigid fall, which
    reaches 0.026 m (130 delta) at 0.06 s. Without the release it stays where it is (within delta)."""
    text = BEAM + """
[analysis]
type = "dynamics"
dt = 1e-3
t_end = 0.06
output_dt = 0.01
start = "static"
release = ["pin b@end"]
sensors = [{name = "tip", kind = "displacement", member = "b", at = "end"}]
"""
    scene, analysis = load(text)
    r = run_dynamics(scene, analysis)
    assert r.success
    q = STEEL.density * ROD.area * G
    delta = 5 * q / (384 * STEEL.E * ROD.I)
    fall = -0.75 * G * r.t**2
    assert np.max(np.abs(r.sensors["tip"][:, 1] - fall)) < 3 * delta
    assert r.sensors["tip"][-1, 1] < -100 * delta
    held = run_dynamics(scene, {k: v for k, v in analysis.items() if k != "release"})
    assert np.max(np.abs(held.sensors["tip"])) < delta
    by_index = run_dynamics(scene, {**analysis, "release": [1]})  # the same support by its [[supports]] index
    assert np.allclose(by_index.sensors["tip"], r.sensors["tip"], rtol=0, atol=1e-12)


@pytest.mark.parametrize("extra, path", [
    ('release = ["pin b@middle"]', "analysis.release[0]"),
    ('release = [2]', "analysis.release[0]"),
    ('release = "pin b@end"\nstart = "reference"', "analysis.release"),
    ('release = [true]', "analysis.release[0]"),
])
def test_release_refused_naming_the_field(extra, path):
    text = BEAM + f'[analysis]\ntype = "dynamics"\ndt = 1e-3\nt_end = 0.01\n{extra}\n'
    if "start" not in extra:
        text += 'start = "static"\n'
    with pytest.raises(SceneError) as exc:
        load(text)
    assert str(exc.value).startswith(path), str(exc.value)


# -- a start from an earlier result ----------------------------------------------------------------------------

def test_dynamics_starts_from_a_static_result_json_and_stays_in_equilibrium(tmp_path):
    """The statics' result.json (as `ancf-sym run` writes it) read back by [analysis] from_result: the run starts
    at that equilibrium at rest and stays there (the tip moves by less than 1e-4 of the static deflection, the
    equilibrium's own tolerance being ~1e-10 of it); a result of another mesh is refused naming the field."""
    from ancf_sym.io.json_out import static_result_dict, write_json

    # a cantilever: pin and slope support at the start
    scene, _ = load(BEAM.replace('type = "pin"\nmember = "b"\nat = "end"', 'type = "slope"\nmember = "b"\n'
                                 'at = "start"'))
    st = solve_static(scene)
    assert st.success
    run1 = tmp_path / "run1"
    run1.mkdir()
    write_json(run1 / "result.json", static_result_dict(st))
    sag = abs(st.tip("b")[1])
    text = BEAM.replace('type = "pin"\nmember = "b"\nat = "end"', 'type = "slope"\nmember = "b"\nat = "start"') + """
[analysis]
type = "dynamics"
dt = 1e-3
t_end = 0.02
from_result = "run1/result.json"
sensors = [{name = "tip", kind = "position", member = "b", at = "end"}]
"""
    (tmp_path / "again.toml").write_text(text)
    scene2, analysis = load_scene(tmp_path / "again.toml")  # (the path is taken from the scene file's folder)
    r = run_dynamics(scene2, analysis)
    assert r.success
    assert np.max(np.abs(r.sensors["tip"] - st.tip("b"))) < 1e-4 * sag
    (tmp_path / "other.toml").write_text(text.replace("elements = 6", "elements = 7"))
    with pytest.raises(SceneError, match=r"^analysis\.from_result: 'x' has 28 coordinates, this scene's mesh 32"):
        load_scene(tmp_path / "other.toml")
    (tmp_path / "missing.toml").write_text(text.replace("run1/", "run2/"))
    with pytest.raises(SceneError, match=r"^analysis\.from_result: no such file"):
        load_scene(tmp_path / "missing.toml")


def test_dynamics_continues_from_a_dynamic_result_json(tmp_path):
    """A dynamic result.json gives its final coordinates AND velocities: the next run's first record is the
    previous run's last state, exactly (the file holds every digit: JSON floats round-trip)."""
    from ancf_sym.io.dynamics_output import result_dict
    from ancf_sym.io.json_out import write_json

    text = BEAM.replace('[[supports]]\ntype = "pin"\nmember = "b"\nat = "end"\n', "")
    sensors = 'sensors = [{name = "tip", kind = "coordinates", member = "b", at = "end"}, ' \
              '{name = "v", kind = "velocity", member = "b", at = "end"}]\n'
    head = '[analysis]\ntype = "dynamics"\ndt = 2e-3\nt_end = 0.1\n' + sensors
    scene, analysis = load(text + head)
    r1 = run_dynamics(scene, analysis)
    assert r1.success and abs(r1.sensors["v"][-1, 1]) > 0.1  # it swings
    write_json(tmp_path / "result.json", result_dict(r1, "x.toml", analysis, 0.0))
    scene2, analysis2 = load(text + head + 'from_result = "result.json"\n', base=tmp_path)
    r2 = run_dynamics(scene2, analysis2)
    assert np.array_equal(r2.sensors["tip"][0], r1.sensors["tip"][-1])
    assert np.array_equal(r2.sensors["v"][0], r1.sensors["v"][-1])


# -- errors name the TOML field ----------------------------------------------------------------------------------

def test_initial_velocity_against_a_support_names_its_initial_table():
    """A uniform velocity of a pinned beam violates the pin: the error names [[analysis.initial]] 0 and its
    member, not the internal vector v0."""
    text = BEAM.replace('[[supports]]\ntype = "pin"\nmember = "b"\nat = "end"\n', "") + """
[analysis]
type = "dynamics"
dt = 1e-3
t_end = 0.01
[[analysis.initial]]
member = "b"
velocity = [0.0, 1.0]
"""
    scene, analysis = load(text)
    with pytest.raises(SceneError) as exc:
        run_dynamics(scene, analysis)
    msg = str(exc.value)
    assert msg.startswith("analysis.initial[0] (member 'b'): violates") and "pin b@start" in msg, msg


# -- documented: every key of the schema tables ------------------------------------------------------------------

def test_docs_show_the_declared_sensor_time_load_and_mass_keys():
    from ancf_sym.scene.schema import POINT_MASS, SENSOR, TIME_LOAD, analysis_table, fields_table

    page = (Path(__file__).resolve().parents[2] / "docs" / "scenes.md").read_text()
    for table in (SENSOR, TIME_LOAD, POINT_MASS):
        assert fields_table(table) in page
    assert analysis_table() in page


def test_sensor_and_time_load_keys_come_from_the_schema():
    from ancf_sym.scene.schema import SENSOR, TIME_LOAD

    with pytest.raises(SceneError, match=r"^analysis\.sensors\[0\]\.where: unknown key \(allowed: "
                       + ", ".join(SENSOR)):
        DynamicOptions(dt=1e-3, t_end=0.1, sensors=[{"kind": "position", "member": "b", "where": 1}])
    with pytest.raises(SceneError, match=r"^analysis\.loads\[0\]\.amplitude: unknown key \(allowed: "
                       + ", ".join(TIME_LOAD)):
        from ancf_sym.dynamics import options_from_dict
        options_from_dict({"type": "dynamics", "dt": 1e-3, "t_end": 0.1,
                           "loads": [{"member": "b", "force": [0, 1], "history": [[0, 1]], "amplitude": 2}]})


def test_bundled_hook_scene_uses_the_features_and_runs():
    """examples/scenes/hook_release.toml: an arc, a point mass, a released prop, sensors and a time load. Its first
    0.05 s: the payload falls once the prop is gone (the hook's tip deflection under 2 kg is millimetres), and the
    root curvature starts at the drawn 1/R = 3.33 1/m changed by the propped static load (< 5 %)."""
    scene, analysis = load_scene(Path(__file__).resolve().parents[2] / "examples" / "scenes" / "hook_release.toml")
    assert scene.members["hook"].arc_curvature == pytest.approx(-1 / 0.3)
    assert scene.point_masses[0].mass == 2.0 and analysis["release"] == ["pin hook@end"]
    r = run_dynamics(scene, {**analysis, "t_end": 0.05})
    assert r.success
    assert r.sensors["payload"][-1, 1] < -1e-3
    assert r.sensors["root curvature"][0, 0] == pytest.approx(1 / 0.3, rel=0.05)


@pytest.mark.parametrize("load, path", [
    ('{member = "b", force = [0.0, 1.0], history = [[0.0, 1.0], [0.0, 2.0]]}', "analysis.loads[0].history"),
    ('{member = "b", force = [0.0, 1.0], history = [[0.0, "1"]]}', "analysis.loads[0].history[0][1]"),
    ('{member = "b", force = [0.0, 1.0, 2.0], history = [[0.0, 1.0]]}', "analysis.loads[0].force"),
    ('{member = "c", force = [0.0, 1.0], history = [[0.0, 1.0]]}', "analysis.loads[0].member"),
    ('{member = "b", at = 9, force = [0.0, 1.0], history = [[0.0, 1.0]]}', "analysis.loads[0].at"),
])
def test_time_loads_refused_when_the_file_is_read(load, path):
    text = BEAM + f'[analysis]\ntype = "dynamics"\ndt = 1e-3\nt_end = 0.01\nloads = [{load}]\n'
    with pytest.raises(SceneError) as exc:
        load_scene_text(text)
    assert str(exc.value).startswith(path), str(exc.value)


def test_sensors_refused_when_the_file_is_read():
    for sensor, path in (('{kind = "position", member = "c"}', "analysis.sensors[0].member"),
                         ('{kind = "coordinates", member = "b", at = 0.5}', "analysis.sensors[0].at"),
                         ('{kind = "body", member = "b"}', "analysis.sensors[0].member"),
                         ('{kind = "spin", member = "b"}', "analysis.sensors[0].kind")):
        text = BEAM + f'[analysis]\ntype = "dynamics"\ndt = 1e-3\nt_end = 0.01\nsensors = [{sensor}]\n'
        with pytest.raises(SceneError) as exc:
            load_scene_text(text)
        assert str(exc.value).startswith(path), str(exc.value)


load_scene_text = load


def test_a_result_that_breaks_a_support_names_from_result(tmp_path):
    """The sagged cantilever's state read into a scene that also pins the tip where it was drawn: refused naming
    analysis.from_result and the support (the tip sits its sag, ~1e-3 m, off the pin)."""
    from ancf_sym.io.json_out import static_result_dict, write_json

    cantilever = BEAM.replace('type = "pin"\nmember = "b"\nat = "end"', 'type = "slope"\nmember = "b"\nat = "start"')
    st = solve_static(load(cantilever)[0])
    write_json(tmp_path / "result.json", static_result_dict(st))
    text = cantilever + """[[supports]]
type = "pin"
member = "b"
at = "end"
[analysis]
type = "dynamics"
dt = 1e-3
t_end = 0.01
from_result = "result.json"
"""
    scene, analysis = load(text, base=tmp_path)
    with pytest.raises(SceneError, match=r"^analysis\.from_result \(its coordinates\) violates constraint "
                                         r"'pin b@end'"):
        run_dynamics(scene, analysis)
