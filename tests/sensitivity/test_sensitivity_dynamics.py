"""Forward sensitivities of a dynamic run (generalized-alpha, fixed steps) against central differences of runs.

The derivative is that of the discrete scheme's solution; the runs solve each step by Newton to xtol = 1e-13 of
the length (lte_fraction 0: no looser update tolerance), so differences of runs differ from the discrete solution's
by ~1e-13 / h (h = 1e-3 of the value): far below the 1e-5 the dynamic derivatives must meet (issue figure);
Richardson extrapolation removes the O(h^2) truncation of the differences. A missing term (the initial
acceleration's, the mass derivative's, the alpha recursion's history) errs by O(1)."""
from __future__ import annotations

import copy

import numpy as np
import pytest

from ancf_sym.dynamics import DynamicOptions, simulate
from ancf_sym.dynamics.newton import NewtonOptions
from ancf_sym.scene import SceneError
from ancf_sym.io.scene_toml import scene_from_dict
from ancf_sym.sensitivity import get_parameter, with_parameter
from ancf_sym.sensitivity.dynamics import dynamic_sensitivity

DOC = {"scene": {"name": "p", "dim": 2, "gravity": [0.0, -9.81]},
       "materials": {"m": {"E": 5e6, "density": 1200.0}}, "sections": {"s": {"area": 1e-4, "I": 1e-9}},
       "members": [{"name": "rope", "points": [[0, 0], [1.0, 0]], "elements": 6, "material": "m", "section": "s",
                    "bending": True}],
       "supports": [{"type": "pin", "member": "rope", "at": "start"}],
       "loads": [{"type": "force", "member": "rope", "at": "end", "value": [0.0, -0.5]}],
       "masses": [{"member": "rope", "at": "end", "mass": 0.05}]}
TIGHT = NewtonOptions(xtol=1e-13, tol=1e-12, lte_fraction=0.0, single=False)
PATHS = ["materials.m.E", "scene.gravity[1]", "sections.s.I", "masses[0].mass", "loads[0].value[1]",
         "materials.m.density"]


def richardson(doc, path, opts):
    v = get_parameter(doc, path)
    h = 1e-3 * abs(v)

    def D(s):
        return (dynamic_sensitivity(with_parameter(doc, path, v + s), [], opts).x -
                dynamic_sensitivity(with_parameter(doc, path, v - s), [], opts).x) / (2 * s)
    return (4 * D(h / 2) - D(h)) / 3


@pytest.fixture(scope="module")
def swing():
    """A soft rope pendulum with a tip mass, released horizontal: 100 steps of 2 ms (a quarter swing)."""
    opts = DynamicOptions(dt=2e-3, t_end=0.2, integrator="generalized_alpha", newton=TIGHT)
    return opts, dynamic_sensitivity(DOC, PATHS, opts)


@pytest.mark.parametrize("path", PATHS)
def test_forward_sensitivity_matches_differences_of_runs(swing, path):
    opts, r = swing
    fd = richardson(DOC, path, opts)
    assert np.linalg.norm(r.dx[path] - fd) <= 1e-5 * np.linalg.norm(fd)
    assert r.nodes(path, "rope").shape == (len(r.t), 7, 2)


def test_the_states_are_the_integrators(swing):
    """The states differentiated are those of the package's own run (same scheme, same steps)."""
    opts, r = swing
    run = simulate(scene_from_dict(DOC)[0], opts)
    assert np.allclose(run.x, r.x[-1], rtol=0, atol=1e-10)


def test_static_start_and_newmark():
    """From the static equilibrium (its sensitivity starts the recursion), Newmark, a sideways load."""
    doc = copy.deepcopy(DOC)
    doc["supports"].append({"type": "pin", "member": "rope", "at": "end"})
    doc["members"][0]["points"] = [[0, 0], [1.0, 0]]
    opts = DynamicOptions(dt=2e-3, t_end=0.06, integrator="newmark", start="static", newton=TIGHT)
    r = dynamic_sensitivity(doc, ["scene.gravity[1]"], opts)
    fd = richardson(doc, "scene.gravity[1]", opts)
    assert np.linalg.norm(r.dx["scene.gravity[1]"] - fd) <= 1e-5 * np.linalg.norm(fd)
    # at rest in equilibrium the state stays there: the derivative is the static one at every step
    assert np.allclose(r.dx["scene.gravity[1]"], r.dx["scene.gravity[1]"][0], rtol=1e-6, atol=1e-12)


def test_refused_before_any_step():
    """Collocation with stiffness-proportional damping (the run's K_el at each step's start): refused by name."""
    opts = DynamicOptions(dt=2e-3, t_end=0.02, integrator="radau", newton=TIGHT)
    doc = copy.deepcopy(DOC)
    doc["dampings"] = [{"type": "rayleigh", "alpha": 1.0, "beta": 1e-4}]
    with pytest.raises(SceneError, match="integrator 'radau' with constraint rows"):
        dynamic_sensitivity(doc, ["materials.m.E"], opts)


def test_sensor_derivatives():
    """Position, velocity, strain and curvature sensors: their records' derivatives against differences of the
    records."""
    sensors = [{"name": "tip", "kind": "position", "member": "rope", "at": "end"},
               {"name": "mid_v", "kind": "velocity", "member": "rope", "at": 3},
               {"name": "stretch", "kind": "strain", "member": "rope", "at": 0.25},
               {"name": "bend", "kind": "curvature", "member": "rope", "at": 0.25}]
    opts = DynamicOptions(dt=2e-3, t_end=0.1, integrator="generalized_alpha", newton=TIGHT, sensors=sensors)
    path = "materials.m.E"
    r = dynamic_sensitivity(DOC, [path], opts)

    def records(doc, name):
        run = dynamic_sensitivity(doc, [], opts)
        ev = next(e for e in run.sensors if e.sensor.name == name)
        return np.array([ev(x, v) for x, v in zip(run.x, run.v)])
    v = get_parameter(DOC, path)
    h = 1e-3 * v
    for name in ("tip", "mid_v", "stretch", "bend"):
        def D(s):
            return (records(with_parameter(DOC, path, v + s), name) -
                    records(with_parameter(DOC, path, v - s), name)) / (2 * s)
        fd = (4 * D(h / 2) - D(h)) / 3
        got = r.sensor(path, name)
        assert got.shape == fd.shape
        assert np.linalg.norm(got - fd) <= 1e-5 * np.linalg.norm(fd), name


def test_cli_dynamics_sensitivities(tmp_path):
    """`ancf-sym run` of a dynamics scene with --sensitivity: sensitivities[PATH].sensors.NAME beside each sensor
    record, at its output times."""
    import json
    import subprocess
    import sys
    from pathlib import Path
    scene_file = Path(__file__).resolve().parents[2] / "examples" / "scenes" / "pendulum.toml"
    out = tmp_path / "d"
    subprocess.run([sys.executable, "-m", "ancf_sym.cli", "run", str(scene_file), "--out", str(out), "--quiet",
                    "--no-animation", "--sensitivity", "scene.gravity[1]"], check=True, cwd=tmp_path)
    data = json.loads((out / "result.json").read_text())
    got = data["sensitivities"]["scene.gravity[1]"]
    assert got["t"] == data["t"]
    assert np.asarray(got["sensors"]["tip"]).shape == np.asarray(data["sensors"]["tip"]).shape
    # released horizontal, the pendulum swings down faster with stronger gravity: before it passes the bottom
    # (a quarter period, ~0.8 s for this 3 m rod), d(tip y)/d(g_y) > 0 (g_y < 0: a larger g_y is weaker gravity)
    t = np.asarray(got["t"])
    early = (t > 0) & (t <= 0.5)
    assert early.sum() > 10 and np.all(np.asarray(got["sensors"]["tip"])[early, 1] > 0)
