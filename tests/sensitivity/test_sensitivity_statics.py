"""Exact static and modal sensitivities by parameter path against central differences of re-solved scenes.

The reference is Richardson-extrapolated central differences, R = (4 D(h/2) - D(h)) / 3 with D(h) = (f(p+h) -
f(p-h)) / 2h: truncation O(h^4) (~1e-8 relative at h = 1e-2 |p| for responses smooth on the scale of p), round-off
(solve tolerance)/h: Newton converges to round-off here (~1e-13 relative), so ~1e-11. Both far below the 1e-6
the derivatives must meet; a missing term (prestress in the frequencies, a coefficient's degree) errs by O(1)."""
from __future__ import annotations

import copy
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from ancf_sym.modal import modal_analysis
from ancf_sym.io.scene_toml import scene_from_dict
from ancf_sym.sensitivity import get_parameter, with_parameter
from ancf_sym.sensitivity.api import sensitivities
from ancf_sym.sensitivity.model_derivative import ParameterError
from ancf_sym.sensitivity.static import StaticSensitivity
from ancf_sym.statics import solve_static

DOC = {
    "scene": {"name": "rod", "dim": 2, "gravity": [0.0, -9.81]},
    "materials": {"steel": {"E": 2e9, "density": 7800.0}},
    "sections": {"rod": {"area": 1e-4, "I": 1e-9}},
    "members": [{"name": "a", "points": [[0, 0], [2.0, 0]], "elements": 8, "material": "steel", "section": "rod",
                 "axial": "biot", "bending": True}],
    "supports": [{"type": "clamp", "member": "a", "at": "start"}, {"type": "pin", "member": "a", "at": "end"}],
    "loads": [{"type": "force", "member": "a", "at": 4, "value": [3.0, -20.0]},
              {"type": "distributed", "member": "a", "value": [0.0, -5.0]},
              {"type": "moment", "member": "a", "at": "end", "value": 2.0}],
    "masses": [{"member": "a", "at": 3, "mass": 0.5}],
}
# (path, step h): 1e-2 of the value; loads and gravity components at zero: a step on the scale of the other loads
PATHS = [("materials.steel.E", None), ("materials.steel.density", None), ("sections.rod.area", None),
         ("sections.rod.I", None), ("scene.gravity[1]", None), ("scene.gravity[0]", 1.0),
         ("loads[0].value[0]", 1.0), ("loads[1].value[1]", None), ("loads[2].value", None),
         ("masses[0].mass", None)]


def richardson(f, doc, path, h):
    v = get_parameter(doc, path)
    h = h if h is not None else 1e-2 * abs(v)

    def D(s):
        return (f(with_parameter(doc, path, v + s)) - f(with_parameter(doc, path, v - s))) / (2 * s)
    return (4 * D(h / 2) - D(h)) / 3


def static_outputs(doc) -> np.ndarray:
    scene, _ = scene_from_dict(doc)
    r = solve_static(scene)
    assert r.success
    cf = r.constraint_forces
    return np.r_[r.x, r.potential, np.concatenate([np.asarray(cf[k]) for k in sorted(cf)]),
                 [r.energies[k] for k in sorted(r.energies)]]


def flat(d: dict) -> np.ndarray:
    return np.r_[d["potential"], np.concatenate([np.asarray(d["constraint_forces"][k]) for k in
                                                 sorted(d["constraint_forces"])]),
                 [d["energies"][k] for k in sorted(d["energies"])]]


@pytest.fixture(scope="module")
def solved():
    scene, _ = scene_from_dict(DOC)
    res = solve_static(scene)
    assert res.success
    return scene, res, StaticSensitivity(scene, res, DOC)


@pytest.mark.parametrize("path, h", PATHS)
def test_static_sensitivity_matches_central_differences(solved, path, h):
    scene, res, S = solved
    d = S.derivative(path)
    exact = np.r_[S.dx(path), flat(d)]
    fd = richardson(static_outputs, DOC, path, h)
    n, nf, ne = len(res.x), sum(len(v) for v in res.constraint_forces.values()), len(res.energies)
    assert set(d["energies"]) == set(res.energies)
    # coordinates, potential, reactions, energies by label
    for part in (slice(0, n), slice(n, n + 1), slice(n + 1, n + 1 + nf), slice(n + 1 + nf, n + 1 + nf + ne)):
        assert np.linalg.norm(exact[part] - fd[part]) <= 1e-6 * np.linalg.norm(fd[part]), path
    # the reported shapes: nodes (public nodes x dim), tip (dim)
    assert d["members"]["a"]["nodes"].shape == res.nodes("a").shape
    assert np.array_equal(d["members"]["a"]["tip"], d["members"]["a"]["nodes"][-1])


def test_adjoint_gradient_equals_direct(solved):
    """One adjoint solve for a scalar output (the tip's height) and every parameter gives the direct answers."""
    scene, res, S = solved
    paths = [p for p, _ in PATHS]
    mm = S.asm.mesh.members["a"]
    c = np.zeros(len(res.x))
    c[mm.offset + mm.public_nodes[-3] * mm.node_size + 1] = 1.0  # y of a node near the end
    adj = S.gradient(c, paths)
    direct = np.array([c @ S.dx(p) for p in paths])
    assert np.allclose(adj, direct, rtol=1e-9, atol=1e-12 * np.abs(direct).max())


def test_frequency_sensitivity_includes_the_prestress():
    """d f / dp against central differences of modal analyses, for parameters that act only through the prestress
    (a horizontal load: the mass and stiffness coefficients are unchanged) and for direct ones. Without the
    third-derivative term the load's derivative would be zero."""
    doc = copy.deepcopy(DOC)
    doc["loads"] = doc["loads"][:2]  # (point moments have no compiled third derivative)
    doc["members"][0]["elements"] = 6

    def freqs(d):
        scene, _ = scene_from_dict(d)
        return modal_analysis(scene, modes=3).frequencies
    out = sensitivities(doc, ["loads[0].value[0]", "materials.steel.density", "sections.rod.I"], modes=3)
    for path, h in (("loads[0].value[0]", 1.0), ("materials.steel.density", None), ("sections.rod.I", None)):
        fd = richardson(freqs, doc, path, h)
        got = np.asarray(out[path]["frequencies"])
        assert np.linalg.norm(got - fd) <= 1e-6 * np.linalg.norm(fd), (path, got, fd)
    assert np.all(np.abs(out["loads[0].value[0]"]["frequencies"]) > 0)


@pytest.mark.parametrize("path, message", [
    ("members[0].prestrain", "names nothing"),
    ("materials.steel.nu", "names nothing"),
    ("members[0].points[1][0]", "not a differentiable parameter here"),
    ("supports[0].member", "a choice"),
])
def test_refused_paths(solved, path, message):
    scene, res, S = solved
    with pytest.raises((KeyError, ValueError), match=message):
        S.derivative(path)


def test_prestrain_refused_with_reason():
    """(A prestrain is differentiable, tests/sensitivity/test_sensitivity_prestrain.py; not with a load at a material coordinate,
    whose element and place in it move with the reference length.)"""
    doc = copy.deepcopy(DOC)
    doc["members"][0]["prestrain"] = 0.01
    doc["loads"][0]["at"] = 1.0
    scene, _ = scene_from_dict(doc)
    res = solve_static(scene)
    with pytest.raises(ParameterError, match="members\\[0\\].prestrain.*material coordinate"):
        StaticSensitivity(scene, res, doc).derivative("members[0].prestrain")


def test_cli_writes_sensitivities(tmp_path):
    """`ancf-sym run --sensitivity PATH` adds sensitivities[PATH] with the result's keys and shapes, equal to the
    Python function's; a path naming a count is refused before any solving (exit code 2)."""
    import tomllib
    scene_file = Path(__file__).resolve().parents[2] / "examples" / "scenes" / "catenary.toml"
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "ancf_sym.cli", "run", str(scene_file), "--out", str(out), "--quiet",
           "--no-animation", "--sensitivity", "materials.rubber.E", "--sensitivity", "scene.gravity[1]"]
    subprocess.run(cmd, check=True, cwd=tmp_path)
    data = json.loads((out / "result.json").read_text())
    sens = data["sensitivities"]
    assert set(sens) == {"materials.rubber.E", "scene.gravity[1]"}
    py = sensitivities(tomllib.loads(scene_file.read_text()), ["scene.gravity[1]"])["scene.gravity[1]"]
    got = sens["scene.gravity[1]"]
    assert np.asarray(got["members"]["rope"]["nodes"]).shape == np.asarray(data["members"]["rope"]["nodes"]).shape
    assert np.allclose(got["members"]["rope"]["nodes"], py["members"]["rope"]["nodes"], rtol=1e-8, atol=1e-12)
    assert set(got["constraint_forces"]) == set(data["constraint_forces"])
    bad = subprocess.run(cmd[:-4] + ["--sensitivity", "members[0].elements"], cwd=tmp_path, capture_output=True,
                         text=True)
    assert bad.returncode == 2 and "a count" in bad.stderr


def test_cli_modal_sensitivities(tmp_path):
    """A modal run's sensitivities carry `frequencies` (one per mode), equal to the Python function's."""
    scene_file = Path(__file__).resolve().parents[2] / "examples" / "scenes" / "sagging_cable_modes.toml"
    out = tmp_path / "m"
    subprocess.run([sys.executable, "-m", "ancf_sym.cli", "run", str(scene_file), "--out", str(out), "--quiet",
                    "--no-animation", "--sensitivity", "materials.cable.density"], check=True, cwd=tmp_path)
    data = json.loads((out / "result.json").read_text())
    got = np.asarray(data["sensitivities"]["materials.cable.density"]["frequencies"])
    assert got.shape == (len(data["frequencies"]),)
    py = sensitivities(scene_file, ["materials.cable.density"], modes=len(got))["materials.cable.density"]
    assert np.allclose(got, py["frequencies"], rtol=1e-8)


def test_rigid_joint_statics_and_frequencies():
    """The T-frame example: a rigid joint's rows are bilinear (their Jacobian turns with the state). Statics: its
    multipliers' curvature is in K_L. Frequencies: the rows' curvature times the multipliers' change, and
    2 mu'(dG phi) of the rows turning with dx (without it the load's derivative errs by 3e-3 here)."""
    import tomllib
    doc = tomllib.loads((Path(__file__).resolve().parents[2] / "examples" / "scenes" / "t_frame.toml").read_text())
    doc["loads"] = doc["loads"][:1]  # (a point moment has no compiled third derivative)
    doc["members"][0]["elements"] = doc["members"][1]["elements"] = 6

    def statics(d):
        return static_outputs(d)

    def freqs(d):
        return modal_analysis(scene_from_dict(d)[0], modes=3).frequencies
    paths = ["loads[0].value[1]", "materials.steel.E"]
    out = sensitivities(doc, paths, modes=3)
    scene, _ = scene_from_dict(doc)
    res = solve_static(scene)
    S = StaticSensitivity(scene, res, doc)
    for path in paths:
        fd = richardson(freqs, doc, path, None)
        got = np.asarray(out[path]["frequencies"])
        assert np.linalg.norm(got - fd) <= 1e-6 * np.linalg.norm(fd), path
        fd = richardson(statics, doc, path, None)
        d = S.derivative(path)
        exact = np.r_[S.dx(path), flat(d)]
        n, nf = len(res.x), sum(len(v) for v in res.constraint_forces.values())
        for part in (slice(0, n), slice(n + 1, n + 1 + nf)):  # coordinates, reactions (the joint's included)
            assert np.linalg.norm(exact[part] - fd[part]) <= 1e-6 * np.linalg.norm(fd[part]), path


def test_mode_shape_derivatives():
    """d(M-normalised mode shapes)/dp by Nelson's bordered system against differences of modal analyses (each
    perturbed mode signed like the base one), for a mass, a stiffness and a prestress-only parameter."""
    from ancf_sym.sensitivity.modal import ModalSensitivity
    doc = copy.deepcopy(DOC)
    doc["loads"] = doc["loads"][:2]
    doc["members"][0]["elements"] = 6
    base = modal_analysis(scene_from_dict(doc)[0], modes=3)
    M = base.linearization.assembly.mass_matrix()
    ms = ModalSensitivity(base, scene_from_dict(doc)[0], doc)

    def shapes(d):
        s = modal_analysis(scene_from_dict(d)[0], modes=3).shapes
        return s * np.sign(np.sum(s * (M @ base.shapes), axis=0))
    for path, h in (("materials.steel.density", None), ("sections.rod.I", None), ("loads[0].value[0]", 1.0)):
        fd = richardson(shapes, doc, path, h)
        got = ms.shape_derivative(path)
        for k in range(3):
            assert np.linalg.norm(got[:, k] - fd[:, k]) <= 1e-6 * np.linalg.norm(fd[:, k]), (path, k)
