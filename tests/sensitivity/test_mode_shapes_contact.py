"""Mode-shape derivatives with exact contact rows (Nelson's bordered system with the held points' rows, their
multipliers, and on a drum the rows' curvature and turn), and the statics sensitivity's contact-state check.

Reference: Richardson-extrapolated central differences of re-solved scenes (truncation O(h^4) at h = 1e-2 |p|),
each perturbed mode signed like the base one (the M-normalisation fixes its size). The free points' IPOPT barrier
forces move the differences by ~1e-8 relative (test_modal_contact.py), far below the 1e-6 asserted (measured: 2e-9
to 1e-7 at h = 0.5, 1 and 2e-2 |p|); a missing term errs by far more (without the drum rows' curvature change and
turn the drum's shapes err by 5e-4 for the load and 5e-3 for E)."""
from __future__ import annotations

import copy

import numpy as np
import pytest

from ancf_sym.io.scene_toml import scene_from_dict
from ancf_sym.modal import modal_analysis
from ancf_sym.sensitivity.api import sensitivities
from ancf_sym.sensitivity.contact_state import ContactStateError
from ancf_sym.sensitivity.modal import ModalSensitivity
from ancf_sym.statics import solve_static
from test_modal_contact import DRUM, PRESSED, richardson

MODES = 3
# the pressed cable of test_modal_contact.py pushed down off-centre (node 3 of 10): its two spans differ, so its modes
# lie apart (15.8, 31.7, 40.0 Hz). Pushed at the middle, the two equal spans give a pair 1.4 % apart whose shapes'
# derivatives (~ 1 / the gap) amplify the re-solved equilibria's own scatter in the differences to ~1e-6.
PRESSED_OFF = copy.deepcopy(PRESSED)
PRESSED_OFF["loads"][0]["at"] = 3


def check_shapes(doc: dict, path: str) -> None:
    scene = scene_from_dict(doc)[0]
    base = modal_analysis(scene, modes=MODES)
    M = base.linearization.assembly.mass_matrix()

    def shapes(d):
        s = modal_analysis(scene_from_dict(d)[0], modes=MODES).shapes
        return s * np.sign(np.sum(s * (M @ base.shapes), axis=0))
    got = ModalSensitivity(base, scene, doc).shape_derivative(path)
    fd = richardson(shapes, doc, path)
    for k in range(MODES):
        assert np.linalg.norm(got[:, k] - fd[:, k]) <= 1e-6 * np.linalg.norm(fd[:, k]), (path, k)


@pytest.mark.parametrize("path", ["loads[0].value[1]", "materials.m.E", "materials.m.density"])
def test_mode_shapes_of_a_cable_pressed_on_the_ground(path):
    f = np.asarray(solve_static(scene_from_dict(PRESSED_OFF)[0]).constraint_forces["contact"])
    assert np.sum(f > 1e-3 * f.max()) >= 1 and f.max() > 10.0  # (held: rows in the modes, > 10 N)
    check_shapes(PRESSED_OFF, path)


@pytest.mark.parametrize("path", ["loads[0].value[1]", "materials.m.E"])
def test_mode_shapes_of_a_rope_held_on_a_drum(path):
    check_shapes(DRUM, path)


def test_statics_sensitivity_refuses_touching_without_pressing():
    """A beam lying flat on the ground, more contact points than coordinates: points at zero gap and zero force,
    whose equilibrium's derivative holds one way only. The statics sensitivity refuses it as the frequencies' does,
    naming the points; the same beam lifted clear of the ground by a smaller load is differentiable."""
    doc = {"scene": {"name": "flat", "dim": 2, "gravity": [0.0, -9.81]},
           "materials": {"m": {"E": 1e8, "density": 2000.0}}, "sections": {"s": {"area": 1e-3, "I": 1e-7}},
           "members": [{"name": "beam", "points": [[0, 0.05], [2, 0.05]], "elements": 10, "material": "m",
                        "section": "s", "bending": True}],
           "supports": [{"type": "clamp", "member": "beam", "at": "start"}],
           "loads": [{"type": "force", "member": "beam", "at": "end", "value": [0.0, -200.0]}],
           "contacts": [{"type": "ground", "member": "beam", "method": "exact", "thickness": 0.0}]}
    with pytest.raises(ContactStateError, match="static sensitivities.*touch without pressing.*member 'beam'"):
        sensitivities(doc, ["materials.m.E"])
    lifted = copy.deepcopy(doc)
    lifted["loads"][0]["value"] = [0.0, 0.0]
    lifted["scene"]["gravity"] = [0.0, -0.1]  # (tip deflection ~ 2 mm, 48 mm above the ground)
    out = sensitivities(lifted, ["materials.m.E"])
    assert np.all(np.isfinite(out["materials.m.E"]["members"]["beam"]["nodes"]))
