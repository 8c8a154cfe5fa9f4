"""Calibration to a dynamic sensor history: the damping of a cantilever from a noisy decay record (the example's
quick form: 4 elements, 600 steps, ~8 periods), and the data checks.

The record comes from a model with twice the elements and a quarter of the step; the fitted model's stiffness takes
up its frequency error, so what is left in the damping ratio is the coarse mesh's effect on the decay envelope and
the noise's share, whose standard deviation (the fit's own, ~0.5 % of zeta here) is inside the issue's 1e-2
bound on the damping ratio; the test also asserts that standard deviation, so a fit that only hit 1e-2 by luck
fails."""
from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

from ancf_sym.scene import SceneError
from ancf_sym.sensitivity import calibrate
from ancf_sym.sensitivity.calibrate_history import SensorHistory, read_history, write_history

ROOT = Path(__file__).resolve().parents[2]
spec = importlib.util.spec_from_file_location("calibrate_decay_damping",
                                              ROOT / "examples" / "calibrate_decay_damping.py")
example = importlib.util.module_from_spec(spec)
spec.loader.exec_module(example)


def test_decay_damping_recovered(tmp_path):
    out = example.main(tmp_path, quick=True)
    cal = out["calibration"]
    assert cal.converged and cal.iterations <= 15
    assert abs(out["zeta"] / example.ZETA - 1) <= 1e-2
    assert out["zeta_std"] <= 1e-2 * example.ZETA
    assert out["png"].stat().st_size > 10_000
    # the record read back is the one fitted; the residual noise is the data's order (model error adds a little)
    data = read_history(out["csv"])
    assert list(data.columns) == [("tip", 1)] and len(data.t) == cal.residuals.size
    assert example.NOISE / 2 <= cal.noise <= 5 * example.NOISE


def test_history_checks():
    doc = example.scene_doc(2, 2e-3, 0.02)
    t = np.arange(0, 0.021, 2e-3)
    with pytest.raises(SceneError, match="names no sensor"):
        calibrate(doc, SensorHistory(t, {("tap", 1): np.zeros(len(t))}), ["dampings[0].alpha"])
    with pytest.raises(SceneError, match="not a step time"):
        calibrate(doc, SensorHistory(t + 1e-4, {("tip", 1): np.zeros(len(t))}), ["dampings[0].alpha"])


def test_cli_calibrate_history(tmp_path):
    """`ancf-sym calibrate` with the example's scene file (its quick form: 4 elements, 2 ms steps, 1.2 s) and a
    decay record (CSV t, tip[1]): the dynamic fit, calibration.json and the PNG, the damping ratio within 1e-2."""
    import json
    import subprocess
    import sys
    text = example.SCENE.read_text().replace("elements = 8", "elements = 4").replace("dt = 1e-3", "dt = 2e-3")
    scene = tmp_path / "decay.toml"
    scene.write_text(text.replace("t_end = 2.0", "t_end = 1.2"))
    data, _ = example.measure(4, 2e-3, 1.2)
    csv = write_history(tmp_path / "record.csv", data)
    cmd = [sys.executable, "-m", "ancf_sym.cli", "calibrate", str(scene), str(csv), "--parameter",
           "materials.steel.E", "--parameter", "dampings[0].alpha", "--out", str(tmp_path / "fit"), "--quiet"]
    subprocess.run(cmd, check=True, cwd=tmp_path)
    res = json.loads((tmp_path / "fit" / "calibration.json").read_text())
    assert res["converged"]
    doc = example.scene_doc(4, 2e-3, 1.2)
    doc["materials"]["steel"]["E"] = res["parameters"]["materials.steel.E"]["estimate"]
    zeta = res["parameters"]["dampings[0].alpha"]["estimate"] / (2 * example.omega1(doc))
    assert abs(zeta / example.ZETA - 1) <= 1e-2
    assert (tmp_path / "fit" / "calibration.png").stat().st_size > 10_000
