"""Calibration by Levenberg-Marquardt with the exact Jacobian: the hanging hose's EA and EI from ten noisy points."""
from __future__ import annotations

import importlib.util
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

import ancf_sym
from ancf_sym.scene import SceneError

ROOT = Path(__file__).resolve().parents[2]
spec = importlib.util.spec_from_file_location("calibrate_hanging_rope", ROOT / "examples" / "calibrate_hanging_rope.py")
example = importlib.util.module_from_spec(spec)
spec.loader.exec_module(example)


@pytest.fixture(scope="module")
def fitted(tmp_path_factory):
    out = tmp_path_factory.mktemp("cal")
    doc = tomllib.loads(example.SCENE.read_text())
    data = out / "points.csv"
    example.measure(doc, data, seed=1)
    return doc, data, ancf_sym.calibrate(doc, data, list(example.TRUE)), out


def test_hanging_rope_ea_ei_recovered(fitted):
    """EA and EI to 1e-3 from 10 points with 1 mm noise in <= 15 iterations. The bound is a statement about the
    noise, so the test also asserts the fit's own standard deviations put 1e-3 beyond 2.5 sigma: the design (a 12 m
    heavy elastica whose shape moves by metres per unit log-stiffness) makes the recovery a property of the data,
    not of this seed. The data come from a 40-element model, the fit uses 20: discretisation is part of the test."""
    doc, data, cal, out = fitted
    assert cal.converged and cal.iterations <= 15
    E, I = cal.estimate
    E0, I0 = example.TRUE["materials.hose.E"], example.TRUE["sections.hose.I"]
    A = doc["sections"]["hose"]["area"]
    assert abs(E * A / (E0 * A) - 1) <= 1e-3  # EA
    assert abs(E * I / (E0 * I0) - 1) <= 1e-3  # EI
    # relative standard deviations of EA = E A and EI = E I for the true noise (1 mm): log-parameter covariance
    C = cal.covariance / np.outer(cal.estimate, cal.estimate) * (example.NOISE / cal.noise) ** 2
    std_EA, std_EI = np.sqrt(C[0, 0]), np.sqrt(C[0, 0] + C[1, 1] + 2 * C[0, 1])
    assert max(std_EA, std_EI) <= 1e-3 / 2.5
    # the residual noise estimates the 1 mm of the data (20 residuals, 2 parameters: chi with 18 dof lies within
    # [0.55, 1.45] sigma with probability > 0.99)
    assert 0.55e-3 <= cal.noise <= 1.45e-3
    assert cal.residuals.shape == (10, 2)
    png = cal.plot(out / "fit.png")
    assert png.stat().st_size > 1000


def test_calibration_jacobian_is_the_sensitivity(fitted):
    """Noise-free data from the model itself (the same mesh): the fit returns the true values to the solver's
    precision, far below the 1e-3 of the noisy case."""
    doc, _, _, out = fitted
    import copy
    from ancf_sym.io.scene_toml import scene_from_dict
    from ancf_sym.sensitivity.calibrate import Measurement
    truth = copy.deepcopy(doc)
    truth["materials"]["hose"]["E"] = example.TRUE["materials.hose.E"]
    truth["sections"]["hose"]["I"] = example.TRUE["sections.hose.I"]
    res = ancf_sym.solve_static(scene_from_dict(truth)[0])
    data = [Measurement("hose", k, res.nodes("hose")[k]) for k in example.NODES]
    cal = ancf_sym.calibrate(doc, data, list(example.TRUE))
    assert np.allclose(cal.estimate, list(example.TRUE.values()), rtol=1e-7)


def test_cli_calibrate(fitted, tmp_path):
    doc, data, cal, _ = fitted
    cmd = [sys.executable, "-m", "ancf_sym.cli", "calibrate", str(example.SCENE), str(data), "--parameter",
           "materials.hose.E", "--parameter", "sections.hose.I", "--out", str(tmp_path / "c"), "--quiet"]
    subprocess.run(cmd, check=True, cwd=tmp_path)
    import json
    got = json.loads((tmp_path / "c" / "calibration.json").read_text())
    assert np.isclose(got["parameters"]["materials.hose.E"]["estimate"], cal.estimate[0], rtol=1e-9)
    assert (tmp_path / "c" / "calibration.png").is_file()
    bad = subprocess.run(cmd[:7] + ["members[0].elements", "--out", str(tmp_path / "d")], cwd=tmp_path,
                         capture_output=True, text=True)
    assert bad.returncode == 2 and "a count" in bad.stderr


def test_bad_data_named(tmp_path):
    csv = tmp_path / "d.csv"
    csv.write_text("member,node,x\nhose,2,1.0\n")
    with pytest.raises(SceneError, match="columns \\['y'\\] missing"):
        ancf_sym.calibrate(example.SCENE, csv, ["materials.hose.E"])
