"""Exudyn's test model ANCFcontactCircleTest (examples/scenes/ancf_contact_circle.toml) at Exudyn's 8 elements: the
penalty law's Gauss points do not resolve the contact, and statics says so; refined, the tip converges.

The cable touches each circle over about 3.5 cm (converged penetrations 0.95 and 1.43 mm, chord 2 sqrt(2 R d)),
less than the 6.7 cm between the law's 5 Gauss points on 0.25 m elements: one or two points carry a circle and
the centre line dips into it between them. The bundled scene therefore has 32 elements (points 1.7 cm apart).
"""
from __future__ import annotations

import tomllib
from pathlib import Path

from ancf_sym import contact
from ancf_sym.contact import gap as contact_gap
from ancf_sym.io.scene_toml import scene_from_dict
from ancf_sym.statics import StaticOptions, solve_static

SCENE = Path(__file__).resolve().parents[2] / "examples" / "scenes" / "ancf_contact_circle.toml"
WEIGHT = 80.0 * 7800.0 * 1e-6 * 2.0  # rho A g L [N]


def _solve(n: int):
    """The bundled scene with n elements and Exudyn's lumped nodal weight (rho A g l per node, half at the tip)."""
    doc = tomllib.loads(SCENE.read_text())
    doc["members"][0]["elements"] = n
    w = WEIGHT / n
    doc["loads"] = [{"type": "force", "member": "cable", "at": k, "value": [0.0, -w if k < n else -w / 2]}
                    for k in range(1, n + 1)]
    scene, analysis = scene_from_dict(doc)
    return solve_static(scene, StaticOptions(**{k: v for k, v in analysis.items() if k != "type"}))


def test_eight_elements_are_refused_and_cut_deeper_than_the_resolved_law():
    """At 8 elements statics refuses (Hidden_Contact_Penetration, naming the cable and both circles), and rightly:
    the centre line reaches deeper into each circle than the resolved law's own penetration (128 elements, where
    points 4 mm apart sample the 3.5 cm contact and its sampled and true penetrations agree), while the coarse
    law's points see less than half of that depth: the force that holds the cable is missing between them."""
    coarse, fine = _solve(8), _solve(128)
    assert coarse.status == contact_gap.STATUS and not coarse.success
    detail = coarse.attempts[-1]["detail"]
    assert "member 'cable'" in detail and "radius 0.1 m" in detail and "radius 0.2 m" in detail
    assert fine.success and fine.stable
    for c8, c128 in zip(contact.report(coarse.assembly, coarse.x), contact.report(fine.assembly, fine.x)):
        resolved = c128["sampled_penetration"]
        assert not c128["hidden_penetration"] and resolved > 0
        assert c8["hidden_penetration"]
        assert c8["smallest_gap"] < -resolved  # deeper than the resolved contact penetrates
        assert c8["sampled_penetration"] < 0.5 * resolved  # the coarse points see under half of it


def test_tip_converges_under_refinement():
    """The tip approaches the 128-element answer as the mesh is refined from 16 to 32 to 64 elements (the contact
    zone resolved by ever more points); at 32 elements (the bundled scene) within 2 mm of it: below the 2.9 mm by
    which the 32-element tip moves between 3 and 7 points per element, the law's sampling error at that mesh.
    Both circles carry more than a quarter of the weight at every mesh."""
    ref = _solve(128).tip("cable")[1]
    err = []
    for n in (16, 32, 64):
        r = _solve(n)
        assert r.success and r.stable, (n, r.status)
        assert all(rep["normal_force"] > 0.25 * WEIGHT for rep in contact.report(r.assembly, r.x))
        err.append(abs(r.tip("cable")[1] - ref))
    assert err[0] > err[1] > err[2]
    assert err[1] < 2e-3
