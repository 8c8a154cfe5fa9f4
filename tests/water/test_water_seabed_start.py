"""A slack line resting on the seabed, solved from the straight start: IPOPT's full steps can land on a folded line
(compressed elements, a fold whose cubic centre line dips through the seabed between the penalty law's points).
Such an answer is refused as a hidden penetration (rightly: the centre line does pass 6 cm through the ground) and the
next attempt is tried, which finds the line lying on the seabed; a fold that stays above the seabed (a higher local
minimum) gives way to the line search's lower answer."""
from __future__ import annotations

import pytest

from ancf_sym.io.scene_toml import scene_from_dict
from ancf_sym.statics.problem import StaticOptions, problem_for


def _doc(steel_density: float, water_density: float = 1025.0) -> dict:
    """The sensitivity tests' seabed case: a steel rope 30 % longer than the span between an anchor on the seabed at
    20 m depth and a fairlead 2 m below the surface, in a 0.6 m/s current."""
    return {"scene": {"name": "mooring", "dim": 2, "gravity": [0.0, -9.81]},
            "materials": {"steel": {"E": 2e9, "density": steel_density}},
            "sections": {"rope": {"shape": "circle", "diameter": 0.03}},
            "members": [{"name": "line", "points": [[0.0, -20.0], [24.0, -2.0]], "elements": 10,
                         "material": "steel", "section": "rope", "axial": "biot", "bending": False,
                         "prestrain": -0.3}],
            "supports": [{"type": "pin", "member": "line", "at": "start"},
                         {"type": "pin", "member": "line", "at": "end"}],
            "water": {"density": water_density, "depth": 20.0, "current": [0.6, 0.0], "seabed": {"stiffness": 1e5},
                      "lines": {"line": {"cd": 1.2, "cd_axial": 0.05, "ca": 1.0, "ca_axial": 0.5}}}}


def test_a_slack_line_on_the_seabed_from_the_straight_start():
    """Steel density 0.1 % below 7800 (a difference quotient's scene) used to end in Hidden_Contact_Penetration on a
    folded line (axial energy 2.0 kJ, potential -27.3 kJ); water density 0.5 % above 1025 in success on another fold
    (axial energy 2.4 kJ, potential -26.8 kJ). The line lying on the seabed: axial energy ~9 J and a
    potential within 0.1 % x its weight's share of the unperturbed one (-32.47 kJ); 1 % allows for that many times
    over and rejects the folded state (16 % higher)."""
    rs = [problem_for(scene_from_dict(_doc(*rho))[0]).solve(StaticOptions(tol=1e-13))
          for rho in ((7800.0,), (7792.2,), (7800.0, 1030.125))]
    for r in rs:
        assert r.success and r.stable, r.status
        assert r.energies["axial"] < 100.0 and r.energies["contact"] > 0  # (unfolded, on the seabed)
    assert rs[1].potential == pytest.approx(rs[0].potential, rel=1e-2)
    assert rs[2].potential == pytest.approx(rs[0].potential, rel=1e-2)
