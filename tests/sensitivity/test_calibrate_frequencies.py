"""Calibration to measured natural frequencies: a stay cable's prestrain (its tension) from two noisy frequencies,
examples/calibrate_stay_cable.py in its quick form, and the command line with a CSV of frequencies."""
from __future__ import annotations

import importlib.util
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from ancf_sym.scene import SceneError
from ancf_sym.sensitivity.frequency_fit import calibrate_frequencies, read_frequencies

ROOT = Path(__file__).resolve().parents[2]
spec = importlib.util.spec_from_file_location("calibrate_stay_cable", ROOT / "examples" / "calibrate_stay_cable.py")
example = importlib.util.module_from_spec(spec)
spec.loader.exec_module(example)


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    out = tmp_path_factory.mktemp("stay")
    return example.main(out, quick=True), out


def test_stay_cable_tension_from_two_frequencies(quick):
    (cal, T, T_true), out = quick
    assert cal.converged and cal.iterations <= 10, cal.summary()
    # The estimate's spread from the known noise (3 mHz) through the exact Jacobian: sigma_known = noise
    # sqrt((J'J)^-1) = std * noise / (residual noise); the fit must land within 4 of them of the truth (the
    # 16-element model's frequencies differ from the 32-element data's by < 1e-6 Hz, far below the noise).
    sigma = cal.std[0] * example.NOISE / cal.noise
    assert abs(cal.estimate[0] - example.TRUE) <= 4 * sigma, (cal.estimate, sigma)
    # the tension follows the prestrain (T ~ EA eps): the same relative accuracy, here below 1 %
    assert abs(T / T_true - 1) <= 4 * sigma / example.TRUE + 1e-3
    assert sigma / example.TRUE < 1e-2  # two frequencies at 3 mHz determine the tension to better than 1 %
    # the fitted frequencies match the data within the noise
    assert np.all(np.abs(cal.residuals) <= 4 * example.NOISE)
    assert (out / "stay_cable_calibration.png").is_file()


def test_cli_calibrate_frequencies(quick, tmp_path):
    (cal, _, _), out = quick
    data = out / "stay_cable_frequencies.csv"
    assert [d.mode for d in read_frequencies(data)] == [0, 1]
    scene = tmp_path / "stay.toml"  # the quick mesh, as the fitted model
    scene.write_text(example.SCENE.read_text().replace("elements = 40", "elements = 16"))
    cmd = [sys.executable, "-m", "ancf_sym.cli", "calibrate", str(scene), str(data), "--parameter",
           "members[0].prestrain", "--out", str(tmp_path / "c"), "--quiet"]
    subprocess.run(cmd, check=True, cwd=tmp_path)
    got = json.loads((tmp_path / "c" / "calibration.json").read_text())
    assert np.isclose(got["parameters"]["members[0].prestrain"]["estimate"], cal.estimate[0], rtol=1e-9)
    assert len(got["frequencies"]) == 2 and (tmp_path / "c" / "calibration.png").is_file()
    bad = tmp_path / "bad.csv"
    bad.write_text("mode,frequency\n0,1.8\n0,1.9\n")
    r = subprocess.run(cmd[:5] + [str(bad)] + cmd[6:], cwd=tmp_path, capture_output=True, text=True)
    assert r.returncode == 2 and "mode measured twice" in r.stderr


def test_too_few_frequencies_refused(tmp_path):
    csv = tmp_path / "one.csv"
    csv.write_text("mode,frequency\n0,1.8\n")
    with pytest.raises(SceneError, match="1 measured frequencies cannot determine 1 parameters"):
        calibrate_frequencies(example.SCENE, csv, ["members[0].prestrain"])
