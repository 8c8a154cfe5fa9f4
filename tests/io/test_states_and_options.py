"""The reader decodes the [analysis] table once into the option object the run uses, and a dynamic run records its
frames as states: the same numbers a coordinates sensor at every node reads, at every output time (fixed steps
and compiled chunks alike)."""
from __future__ import annotations

import numpy as np
import pytest

from ancf_sym import Material, Scene, Section
from ancf_sym.dynamics import DynamicOptions, Sensor, simulate
from ancf_sym.io.scene_toml import scene_from_dict
from ancf_sym.statics import StaticOptions

SCENE = {"scene": {"dim": 2, "gravity": [0.0, -9.81]},
         "materials": {"steel": {"E": 2e11, "density": 7850.0}},
         "sections": {"rod": {"area": 1e-4, "I": 1e-9}},
         "members": [{"name": "rope", "points": [[0, 0], [1, 0]], "elements": 4, "material": "steel",
                      "section": "rod"}],
         "supports": [{"type": "pin", "member": "rope", "at": "start"}]}


def test_statics_and_modal_tables_decode_to_their_options():
    _, a = scene_from_dict({**SCENE, "analysis": {"type": "statics", "tol": 1e-9, "max_iter": 40}})
    assert a == {"type": "statics", "tol": 1e-9, "max_iter": 40}
    assert isinstance(a.options, StaticOptions) and a.options == StaticOptions(tol=1e-9, max_iter=40)
    _, m = scene_from_dict({**SCENE, "analysis": {"type": "modal", "modes": 3, "tol": 1e-9}})
    assert m["modes"] == 3 and m.options == StaticOptions(tol=1e-9)


def test_dynamics_table_decodes_to_dynamic_options():
    _, a = scene_from_dict({**SCENE, "analysis": {"type": "dynamics", "dt": 1e-3, "t_end": 0.01,
                                                  "integrator": "hht", "record_states": True}})
    assert isinstance(a.options, DynamicOptions)
    assert (a.options.dt, a.options.t_end, a.options.integrator, a.options.record_states) == (1e-3, 0.01, "hht", True)


def _pendulum() -> Scene:
    s = Scene(dim=2, gravity=(0.0, -9.81))
    s.member("rope", points=[(0, 0), (1, 0)], elements=4, material=Material(E=2e9, density=7850.0),
             section=Section(area=1e-4, I=1e-9))
    s.pin("rope", at="start")
    return s


@pytest.mark.parametrize("output", [{"output_dt": 0.01}, {"output_every": 3}])
def test_states_are_what_coordinate_sensors_at_every_node_read(output):
    scene = _pendulum()
    nodes = range(5)
    sensors = [Sensor(f"n{j}", "coordinates", "rope", j) for j in nodes]
    r = simulate(scene, DynamicOptions(dt=2e-3, t_end=0.06, sensors=sensors, record_states=True, **output))
    assert r.success
    mm = r.assembly.mesh.members["rope"]
    X = r.states[:, mm.offset:mm.offset + mm.x0.size].reshape(len(r.t), mm.n_nodes, -1)
    assert r.states.shape == (len(r.t), r.assembly.n)
    for j in nodes:  # the same full state read two ways: equal to the last bit
        assert np.array_equal(X[:, j, :], np.asarray(r.sensors[f"n{j}"]))
    assert np.array_equal(r.states[-1], r.x)  # (t_end is an output time)
    # a swinging rope: the states move (a frozen record would pass the comparison above)
    assert np.ptp(X[:, -1, 1]) > 1e-3


def test_states_are_kept_only_when_asked_for():
    r = simulate(_pendulum(), DynamicOptions(dt=2e-3, t_end=0.01))
    assert r.success and r.states is None
