"""Least-squares calibration of scene parameters to measured data, with the exact Jacobian: the one entry point.

calibrate() and `ancf-sym calibrate` decide here, and only here, which data they are given (data_kind): static node
positions (this module), natural frequencies (ancf_sym.sensitivity.frequency_fit) or a dynamic sensor history
(ancf_sym.sensitivity.calibrate_history). All three fit by the one Levenberg-Marquardt loop of
ancf_sym.sensitivity.least_squares (parameters scaled by their start values; converged where the Gauss-Newton
correction still to come is below 1e-6 of the estimate's standard deviation) and report a
ancf_sym.sensitivity.calibration.Calibration.

Positions: rows (member, node, x, y[, z]): the measured position of a member's public node (index from 0; "start",
"end"). The model's positions come from the static equilibrium of the scene with the parameters set; their
Jacobian from the implicit function theorem (ancf_sym.sensitivity.static: one factorisation, one back-substitution
per parameter). A trial whose statics fails or whose values the scene refuses counts as rejected.
"""
from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ancf_sym.scene.builder import SceneError
from ancf_sym.io.scene_toml import scene_from_dict
from ancf_sym.statics.problem import problem_for
from ancf_sym.sensitivity.api import read_document
from ancf_sym.sensitivity.calibrate_history import SensorHistory, calibrate_history
from ancf_sym.sensitivity.calibration import Calibration, check_count, save_figure, start_values, with_parameters
from ancf_sym.sensitivity.frequency_fit import FrequencyMeasurement, HEADER as FREQUENCY_HEADER, calibrate_frequencies
from ancf_sym.sensitivity.least_squares import levenberg_marquardt
from ancf_sym.sensitivity.model_derivative import check_model_paths
from ancf_sym.sensitivity.static import StaticSensitivity

__all__ = ["Calibration", "PositionCalibration", "Measurement", "calibrate", "calibrate_positions", "data_kind",
           "read_data", "run_cli"]


@dataclass
class Measurement:
    member: str
    node: object  # int, "start" or "end"
    position: np.ndarray


class PositionCalibration(Calibration):
    """A Calibration whose data are node positions: residuals (measurements, dim) [m], the StaticResult at the
    estimate as `result`."""

    unit = "m"

    def plot(self, path: str | Path) -> Path:
        """PNG of the measured points against the fitted equilibrium (the members' centre lines)."""
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        res = self.result
        fig, ax = plt.subplots(figsize=(7, 4.5))
        for name in sorted({d.member for d in self.data}):
            s = res.along(name, 8)
            ax.plot(s["r"][:, 0], s["r"][:, 1], "-", label=f"fitted model: {name}")
        P = np.array([d.position for d in self.data])
        ax.plot(P[:, 0], P[:, 1], "o", mfc="none", label="data")
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_title(self.title(short=True), fontsize=9)
        ax.legend(fontsize=8)
        return save_figure(fig, path)


def data_kind(data: object) -> str:
    """"positions", "frequencies" or "history": what `data` holds (a CSV file by its header: `t, NAME[j], ...` a
    sensor history, `mode,frequency` frequencies, else node positions; or the objects the readers make)."""
    if isinstance(data, SensorHistory):
        return "history"
    if isinstance(data, (str, Path)):
        if not Path(data).is_file():
            raise SceneError(f"calibrate: data file {str(data)!r} not found")
        with open(data, newline="") as fh:
            head = [h.strip() for h in next(csv.reader(fh), [])]
        if head[:1] == ["t"]:
            return "history"
        return "frequencies" if head == list(FREQUENCY_HEADER) else "positions"
    if isinstance(data, list) and data and all(isinstance(d, FrequencyMeasurement) for d in data):
        return "frequencies"
    return "positions"


def read_data(path: str | Path, dim: int) -> list[Measurement]:
    """CSV with a header: member, node, x, y[, z] (node: a public node index, start or end)."""
    rows = []
    with open(path, newline="") as fh:
        reader = csv.DictReader(fh)
        need = ["member", "node", "x", "y", "z"][:2 + dim]
        missing = [k for k in need if k not in (reader.fieldnames or [])]
        if missing:
            raise SceneError(f"{path}: columns {missing} missing (header needs {', '.join(need)})")
        for k, r in enumerate(reader, start=2):
            node = r["node"].strip()
            try:
                pos = np.array([float(r[c]) for c in need[2:]])
                node = node if node in ("start", "end") else int(node)
            except ValueError:
                raise SceneError(f"{path}, line {k}: node {r['node']!r} or a coordinate is not a number") from None
            rows.append(Measurement(r["member"].strip(), node, pos))
    if not rows:
        raise SceneError(f"{path}: no measurements")
    return rows


def _index(asm, data: list[Measurement]) -> np.ndarray:
    """Full-coordinate indices of the measured positions, (measurements, dim)."""
    dim = asm.scene.dim
    out = []
    for d in data:
        mm = asm.mesh.members.get(d.member)
        if mm is None:
            raise SceneError(f"data: member {d.member!r} is not in the scene ({', '.join(asm.mesh.members)})")
        pub = mm.public_nodes
        k = {"start": 0, "end": len(pub) - 1}.get(d.node, d.node)
        if not -len(pub) <= k < len(pub):
            raise SceneError(f"data: member {d.member!r} has public nodes 0..{len(pub) - 1}, not {d.node!r}")
        out.append(mm.node_dofs(pub[k])[:dim])
    return np.asarray(out)


def calibrate(doc: dict | str | Path, data: object, parameters: list[str], start: list[float] | None = None,
              max_iter: int = 30) -> Calibration:
    """Fit the scene numbers at `parameters` (TOML paths) to measured data, whichever they are (data_kind): node
    positions (calibrate_positions), frequencies (ancf_sym.sensitivity.frequency_fit.calibrate_frequencies) or a
    sensor history of the scene's dynamic run (ancf_sym.sensitivity.calibrate_history.calibrate_history).

    start: the first estimate (default: the document's values)."""
    fit = {"positions": calibrate_positions, "frequencies": calibrate_frequencies,
           "history": calibrate_history}[data_kind(data)]
    return fit(doc, data, parameters, start, max_iter)


def calibrate_positions(doc: dict | str | Path, data: list[Measurement] | str | Path, parameters: list[str],
                        start: list[float] | None = None, max_iter: int = 30) -> PositionCalibration:
    """Fit the scene numbers at `parameters` (TOML paths) to measured node positions (see the module docstring)."""
    doc = read_document(doc)
    parameters = list(parameters)
    scene, _ = scene_from_dict(doc)
    check_model_paths(scene, doc, parameters)  # (every path checked before any solving)
    p0 = start_values(doc, parameters, start)
    if not isinstance(data, list):
        data = read_data(data, scene.dim)
    idx = _index(problem_for(scene).asm, data)
    meas = np.concatenate([d.position for d in data])
    check_count(meas.size, len(parameters), "coordinates")

    def evaluate(p, before):
        d = with_parameters(doc, parameters, p)
        try:
            sc, _ = scene_from_dict(d)
            res = problem_for(sc).solve(x0=None if before is None else before[2].x)
        except SceneError:
            return None
        if not res.success:
            return None
        return (d, sc, res), res.x[idx].ravel() - meas

    def jacobian(state):
        d, sc, res = state
        S = StaticSensitivity(sc, res, d)
        return np.column_stack([S.dx(path)[idx].ravel() for path in parameters])

    fit = levenberg_marquardt(evaluate, jacobian, p0, max_iter=max_iter, model="the statics")
    d, _, res = fit.state
    return PositionCalibration.from_fit(parameters, fit, fit.r.reshape(len(data), -1), data, res, d)


def run_cli(scene_file: str | Path, data_file: str | Path, parameters: list[str], out: Path, max_iter: int = 30,
            quiet: bool = False) -> int:
    """`ancf-sym calibrate`: the fit (whichever data the CSV holds), out/calibration.json and out/calibration.png;
    exit code 0 when converged. Every path is checked before any solving."""
    from ancf_sym.io.json_out import write_json

    cal = calibrate(read_document(scene_file), Path(data_file), parameters, max_iter=max_iter)
    out.mkdir(parents=True, exist_ok=True)
    write_json(out / "calibration.json", cal.to_dict())
    cal.plot(out / "calibration.png")
    if not quiet:
        print(f"{cal.summary()} -> {out}")
    return 0 if cal.converged else 1
