"""Statics sensitivities to an exact contact's geometry (ancf_sym.sensitivity.exact_contact_geometry): a rope pulled
over a fixed drum in exact contact (radius, centre, thickness) and a clamped beam pressed onto an exact ground (level,
thickness). The active gap rows g_i(x, p) = 0 carry dg/dp into the implicit function theorem's rows and the forces'
f_i d(grad g_i)/dp into its residual.

Reference: Richardson-extrapolated central differences of re-solved scenes (truncation O(h^4); IPOPT's
complementarity ~1e-8 stays below 1e-7 relative in the differences where the held point's neighbours' gaps change
alike: the active set does not change within +-h), against the 1e-6 the derivatives must meet (the drum's horizontal
centre: see CASES); the adjoint gradient equals the direct one to 1e-9 (the same
factorisation transposed). Leaving out the rows' dg/dp leaves dx zero for these paths (an error of 100 %)."""
from __future__ import annotations

import json

import copy

import numpy as np
import pytest

from ancf_sym.io.scene_toml import scene_from_dict
from ancf_sym.sensitivity import get_parameter, with_parameter
from ancf_sym.sensitivity.static import StaticSensitivity
from ancf_sym.statics import solve_static

DRUM = {"scene": {"name": "drum", "dim": 2, "gravity": [0.0, -9.81]},
        "materials": {"m": {"E": 2e9, "density": 1000.0}},
        "sections": {"s": {"shape": "circle", "diameter": 0.004}},
        "members": [{"name": "rope", "points": [[0, 0], [1, 0]], "elements": 16, "material": "m", "section": "s"}],
        "supports": [{"type": "pin", "member": "rope", "at": "start"}, {"type": "pin", "member": "rope", "at": "end"}],
        "loads": [{"type": "force", "member": "rope", "at": 4, "value": [0.0, -3.0]}],
        "contacts": [{"type": "circle", "member": "rope", "centre": [0.5, -0.18], "radius": 0.2, "method": "exact",
                      "thickness": 0.002}]}
GROUND = {"scene": {"name": "ground", "dim": 2, "gravity": [0.0, -9.81]},
          "materials": {"m": {"E": 1e8, "density": 2000.0}},
          "sections": {"s": {"area": 1e-3, "I": 1e-7}},
          "members": [{"name": "beam", "points": [[0, 0.05], [2, 0.05]], "elements": 10, "material": "m",
                       "section": "s", "bending": True}],
          "supports": [{"type": "clamp", "member": "beam", "at": "start"}],
          "loads": [{"type": "force", "member": "beam", "at": "end", "value": [0.0, -200.0]}],
          "contacts": [{"type": "ground", "member": "beam", "method": "exact", "level": 0.01, "thickness": 0.005,
                        "gauss": 3}]}


def outputs(doc):
    r = solve_static(scene_from_dict(doc)[0])
    assert r.success
    cf = r.constraint_forces
    return r, np.r_[r.x, r.potential, np.concatenate([np.asarray(cf[k]) for k in sorted(cf)])]


# (doc, path, relative step, tolerance): steps that keep the active set (the drum's: +-0.2 mm, below its
# neighbours' gaps of ~0.1 mm); the drum's horizontal centre moves the held point's neighbours' gaps oppositely, so
# IPOPT's barrier forces mu / g (mu ~ 8e-11 N m, g ~ 1e-4 m: ~1e-6 N) change by mu / g^2 dg/dc ~ 2e-4 N/m against the
# held force's 3.5 N/m: the re-solved scenes carry ~5e-5 of it, and that case is held to 5e-5.
CASES = [(DRUM, "contacts[0].radius", 1e-3, 1e-6), (DRUM, "contacts[0].centre[1]", 1e-3, 1e-6),
         (DRUM, "contacts[0].centre[0]", 4e-4, 5e-5), (DRUM, "contacts[0].thickness", 1e-2, 1e-6),
         (GROUND, "contacts[0].level", 1e-2, 1e-6), (GROUND, "contacts[0].thickness", 1e-2, 1e-6)]


@pytest.mark.parametrize("doc,path,rel,tol", CASES, ids=["drum_radius", "drum_centre_y", "drum_centre_x",
                                                         "drum_thickness", "ground_level", "ground_thickness"])
def test_exact_contact_geometry_matches_differences(doc, path, rel, tol):
    res, _ = outputs(doc)
    S = StaticSensitivity(scene_from_dict(doc)[0], res, doc)
    d = S.derivative(path)
    exact = np.r_[S.dx(path), d["potential"],
                  np.concatenate([np.asarray(d["constraint_forces"][k]) for k in sorted(d["constraint_forces"])])]
    v = get_parameter(doc, path)
    h = rel * abs(v)

    def D(s):
        return (outputs(with_parameter(doc, path, v + s))[1] - outputs(with_parameter(doc, path, v - s))[1]) / (2 * s)
    fd = (4 * D(h / 2) - D(h)) / 3
    n = len(res.x)
    for part in (slice(0, n), slice(n, n + 1), slice(n + 1, None)):
        err = np.linalg.norm(exact[part] - fd[part]) / np.linalg.norm(fd[part])
        assert err <= tol, (path, part, err)
    # the adjoint: one scalar output (the sum of the coordinates), the same derivative
    g = S.gradient(np.ones(n), [path])[0]
    assert abs(g - exact[:n].sum()) <= 1e-9 * np.abs(exact[:n]).sum()



def _toml(doc: dict, analysis: list[str]) -> str:
    lines = [f"[scene]"] + [f"{k} = {json.dumps(v)}" for k, v in doc["scene"].items()]
    for table in ("materials", "sections"):
        for name, d in doc[table].items():
            lines += [f"[{table}.{name}]"] + [f"{k} = {json.dumps(v)}" for k, v in d.items()]
    for table in ("members", "supports", "loads", "contacts"):
        for d in doc[table]:
            lines += [f"[[{table}]]"] + [f"{k} = {json.dumps(v)}" for k, v in d.items()]
    return "\n".join(lines + ["[analysis]"] + analysis) + "\n"


def test_exact_contact_geometry_through_the_command_line(tmp_path):
    """`ancf-sym run SCENE --sensitivity contacts[0].radius` on a statics scene with an exact drum: result.json
    carries StaticSensitivity's derivative (the path check lets the statics' own rows take it); a modal analysis,
    whose frequencies' derivative does not follow the rows' geometry, refuses the path by name before solving."""
    from ancf_sym.cli import main

    scene = tmp_path / "drum.toml"
    scene.write_text(_toml(DRUM, ['type = "statics"']))
    out = tmp_path / "out"
    assert main(["run", str(scene), "--out", str(out), "--quiet", "--sensitivity", "contacts[0].radius"]) == 0
    got = json.loads((out / "result.json").read_text())["sensitivities"]["contacts[0].radius"]
    res, _ = outputs(DRUM)
    ref = StaticSensitivity(scene_from_dict(DRUM)[0], res, DRUM).derivative("contacts[0].radius")
    assert got["potential"] == pytest.approx(ref["potential"], rel=1e-6)  # (two solves to the statics' tol)
    modal = tmp_path / "modal.toml"
    modal.write_text(_toml(DRUM, ['type = "modal"', "modes = 3"]))
    assert main(["run", str(modal), "--out", str(tmp_path / "m"), "--quiet", "--sensitivity",
                 "contacts[0].radius"]) != 0
