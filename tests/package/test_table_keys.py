"""Keys of the per-item tables of a dynamic analysis (sensors, time loads) are checked by the one key check of the
package (checks.check_keys): an unknown or missing key is refused before any step, naming its full path and, for an
unknown one, the allowed keys."""
from __future__ import annotations

import pytest

from ancf_sym import Material, Scene, SceneError, Section
from ancf_sym.dynamics import run_dynamics


def beam() -> Scene:
    s = Scene(dim=2, gravity=(0, -9.81))
    s.member("beam", [(0, 0), (1, 0)], 2, Material(E=2e11, density=7800), Section.circle(0.01))
    s.pin("beam", "start")
    return s


@pytest.mark.parametrize("extra,match", [
    ({"sensors": [{"kind": "position", "member": "beam", "colour": "red"}]},
     r"sensors\[0\]\.colour: unknown key \(allowed: name, kind, member, at\)"),
    ({"loads": [{"member": "beam", "force": [0, 1], "history": [[0, 1]], "ramp": 2}]},
     r"loads\[0\]\.ramp: unknown key \(allowed: member, at, force, history\)"),
    ({"loads": [{"member": "beam", "force": [0, 1]}]}, r"loads\[0\]\.history: missing"),
])
def test_unknown_and_missing_keys_name_their_path(extra, match):
    steps = []
    with pytest.raises(SceneError, match=match):
        run_dynamics(beam(), {"dt": 1e-3, "t_end": 0.01, **extra}, progress=lambda t, te: steps.append(t))
    assert steps == []
