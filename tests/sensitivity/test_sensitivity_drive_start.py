"""The dynamic sensitivities refuse, before any step, a start that the run itself refuses: a fairlead drive that
starts moving at t = 0 with a velocity jump (the line starts at rest)."""
from __future__ import annotations

import pytest

from ancf_sym.dynamics import DynamicOptions, simulate
from ancf_sym.io.scene_toml import scene_from_dict
from ancf_sym.scene import SceneError
from ancf_sym.sensitivity.adjoint import SensorOutput, dynamic_gradient
from ancf_sym.sensitivity.dynamics import dynamic_sensitivity


def _doc(position: list) -> dict:
    return {"scene": {"name": "line", "dim": 2, "gravity": [0.0, -9.81]},
            "materials": {"steel": {"E": 2e9, "density": 7800.0}},
            "sections": {"rope": {"shape": "circle", "diameter": 0.03}},
            "members": [{"name": "line", "points": [[0.0, 0.0], [10.0, 0.0]], "elements": 3, "material": "steel",
                         "section": "rope", "axial": "biot", "bending": False, "prestrain": 0.001}],
            "supports": [{"type": "pin", "member": "line", "at": "start"}],
            "drives": [{"type": "position", "member": "line", "at": "end", "name": "fairlead",
                        "position": position}],
            "analysis": {"type": "dynamics", "dt": 0.05, "t_end": 0.2}}


OPTS = DynamicOptions(dt=0.05, t_end=0.2, sensors=[{"name": "tip", "kind": "position", "member": "line", "at": 0.5}])


def test_a_drive_with_a_velocity_jump_is_refused_as_simulate_refuses_it():
    """x = 10 + t: 1 m/s at t = 0 while the line starts at rest. x = 10 + t^2 starts from rest: accepted (its run's
    sensitivity is computed, the check is no blanket refusal)."""
    o = OPTS
    jump = _doc([[[0.0, [10.0, 1.0]]], 0.0])
    with pytest.raises(SceneError, match=r"v0 \(velocity form\) violates drive 'fairlead\[0\]'") as ran:
        simulate(scene_from_dict(jump)[0], o)
    with pytest.raises(SceneError, match=r"v0 \(velocity form\) violates drive 'fairlead\[0\]'") as fw:
        dynamic_sensitivity(jump, ["materials.steel.density"], o)
    with pytest.raises(SceneError, match=r"v0 \(velocity form\) violates drive 'fairlead\[0\]'") as adj:
        dynamic_gradient(jump, ["materials.steel.density"], o, SensorOutput("tip", 1, "integral"))
    assert str(fw.value) == str(ran.value) == str(adj.value)
    smooth = _doc([[[0.0, [10.0, 0.0, 1.0]]], 0.0])
    assert dynamic_sensitivity(smooth, ["materials.steel.density"], o).t[-1] == pytest.approx(0.2)
