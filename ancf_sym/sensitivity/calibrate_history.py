"""Least-squares calibration of scene parameters to measured dynamic sensor histories (a decay record, a swing),
with the exact Jacobian of the discrete run.

Data: a record of sensor values at times on the run's step grid (t_start + k dt): CSV with a header `t, NAME[j],
...` (NAME: a sensor of the scene's [analysis] sensors, j its component; NAME alone: component 0). The model's
record comes from the dynamic run of the scene (analysis table, type = "dynamics": an alpha scheme with fixed
steps) with the parameters set; its Jacobian from the forward sensitivities of that run (ancf_sym.sensitivity.
dynamics: exact for the discrete scheme, one recursion for all parameters). The Levenberg-Marquardt loop of
ancf_sym.sensitivity.least_squares: a trial step runs the scene alone, an accepted one again with its sensitivities.
"""
from __future__ import annotations

import csv
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ancf_sym.dynamics import DynamicOptions
from ancf_sym.dynamics.options import options_from_dict
from ancf_sym.scene.builder import SceneError
from ancf_sym.io.scene_toml import scene_from_dict
from ancf_sym.sensitivity.alpha_run import check_dynamic_paths
from ancf_sym.sensitivity.calibration import Calibration, check_count, save_figure, start_values, with_parameters
from ancf_sym.sensitivity.dynamics import dynamic_sensitivity
from ancf_sym.sensitivity.least_squares import levenberg_marquardt
from ancf_sym.sensitivity.model_derivative import read_document

_COLUMN = re.compile(r"^\s*([^\[\]]+?)\s*(?:\[(\d+)\])?\s*$")


@dataclass
class SensorHistory:
    """Measured sensor values: t (m,) [s] and columns {(sensor name, component): values (m,)}."""
    t: np.ndarray
    columns: dict


def read_history(path: str | Path) -> SensorHistory:
    """CSV with a header t, NAME[j], ... (see the module docstring)."""
    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))
    if not rows or not rows[0] or rows[0][0].strip() != "t":
        raise SceneError(f"{path}: a sensor history's header starts with t (then NAME[j] columns)")
    keys = []
    for name in rows[0][1:]:
        m = _COLUMN.match(name)
        if m is None:
            raise SceneError(f"{path}: column {name!r} is not NAME or NAME[j]")
        keys.append((m.group(1), int(m.group(2) or 0)))
    if not keys:
        raise SceneError(f"{path}: no sensor columns after t")
    try:
        A = np.array([[float(v) for v in r] for r in rows[1:] if r], float)
    except ValueError as exc:
        raise SceneError(f"{path}: a value is not a number ({exc})") from None
    if A.ndim != 2 or len(A) == 0 or A.shape[1] != len(keys) + 1:
        raise SceneError(f"{path}: no data rows, or rows of another width than the header")
    return SensorHistory(A[:, 0], {k: A[:, i + 1] for i, k in enumerate(keys)})


@dataclass
class HistoryCalibration(Calibration):
    """A Calibration whose data are a SensorHistory: residuals (m,) model - data, the columns one after another
    [the sensors' units]; the fitted run's step times and record."""
    t_model: np.ndarray | None = field(default=None, repr=False)  # the fitted run's step times
    model: dict = field(default_factory=dict, repr=False)  # (sensor, component) -> the fitted run's record

    def plot(self, path: str | Path) -> Path:
        """PNG of the measured record against the fitted run's, one panel per column."""
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        keys = list(self.data.columns)
        fig, axes = plt.subplots(len(keys), 1, figsize=(8, 2.6 * len(keys) + 0.8), squeeze=False)
        for ax, key in zip(axes[:, 0], keys):
            ax.plot(self.data.t, self.data.columns[key], ".", ms=3, color="0.5", label="data")
            ax.plot(self.t_model, self.model[key], "-", lw=1.2, label="fitted model")
            ax.set_ylabel(f"{key[0]}[{key[1]}]")
            ax.legend(fontsize=8, loc="upper right")
        axes[-1, 0].set_xlabel("t [s]")
        axes[0, 0].set_title(self.title(), fontsize=9)
        return save_figure(fig, path)


def dynamic_options(doc: dict, options: DynamicOptions | None) -> DynamicOptions:
    """The run to fit: `options`, else the document's [analysis] table (type = "dynamics")."""
    if options is not None:
        return options
    a = doc.get("analysis")
    if not isinstance(a, dict) or a.get("type") != "dynamics":
        raise SceneError("calibrate: a sensor history needs the scene's [analysis] with type = \"dynamics\" "
                         "(or options)")
    return options_from_dict(a)


def _grid_index(t: np.ndarray, opts: DynamicOptions) -> np.ndarray:
    """Step indices of the data times; a time off the step grid is refused (naming it)."""
    k = np.rint((t - opts.t_start) / opts.dt).astype(int)
    off = np.abs(opts.t_start + k * opts.dt - t) > 1e-9 * opts.dt + 1e-12 * np.abs(t)
    bad = off | (k < 0) | (k > opts.n_grid)
    if bad.any():
        raise SceneError(f"calibrate: data time t = {t[bad][0]!r} s is not a step time of the run (t_start "
                         f"{opts.t_start} + k dt, dt = {opts.dt}, up to t_end {opts.t_end})")
    return k


def calibrate_history(doc: dict | str | Path, data: SensorHistory | str | Path, parameters: list[str],
                      start: list[float] | None = None, max_iter: int = 30,
                      options: DynamicOptions | None = None) -> HistoryCalibration:
    """Fit the scene numbers at `parameters` (TOML paths) to a measured sensor history (see the module docstring).

    start: the first estimate (default: the document's values); options: the run (default: the document's
    [analysis] table)."""
    doc = read_document(doc)
    parameters = list(parameters)
    check_dynamic_paths(scene_from_dict(doc)[0], doc, parameters)  # (every path checked before any run)
    opts = dynamic_options(doc, options)
    if opts.adaptive:  # (the residual would jump where the error control picks other steps between iterations)
        raise SceneError("calibrate: analysis.adaptive = true: a sensor history is fitted on fixed steps (dt), "
                         "whose run is a smooth function of the parameters")
    if not isinstance(data, SensorHistory):
        data = read_history(data)
    names = [s.get("name") if isinstance(s, dict) else s.name for s in opts.sensors]
    for name, _ in data.columns:
        if name not in names:
            raise SceneError(f"calibrate: data column {name!r} names no sensor of the run (sensors: {names})")
    k = _grid_index(np.asarray(data.t, float), opts)
    meas = np.concatenate(list(data.columns.values()))
    p0 = start_values(doc, parameters, start)
    check_count(meas.size, len(parameters), "values")

    def run(p, jacobian: bool):
        """(state, r) of the run at p; state (p, document, step times, record, d r / d p or None)."""
        d = with_parameters(doc, parameters, p)
        try:
            ds = dynamic_sensitivity(d, parameters if jacobian else [], opts)
        except SceneError:
            return None
        records = {}
        for ev in ds.sensors:
            records[ev.sensor.name] = np.array([ev(x, v) for x, v in zip(ds.x, ds.v)])
        model = {key: records[key[0]][:, key[1]] for key in data.columns}
        r = np.concatenate([model[key][k] for key in data.columns]) - meas
        if not np.all(np.isfinite(r)):
            return None
        J = None
        if jacobian:
            J = np.column_stack([np.concatenate([ds.sensor(path, key[0])[k, key[1]] for key in data.columns])
                                 for path in parameters])
        return (p, d, ds.t, model, J), r

    def evaluate(p, before):
        return run(p, before is None)  # (the start's Jacobian from the same run)

    def jacobian(state):
        if state[4] is not None:
            return state[4]
        again = run(state[0], True)  # (an accepted trial: its run again, with the sensitivities)
        if again is None:
            raise SceneError("calibrate: the run with sensitivities failed where the run alone succeeded")
        return again[0][4]

    fit = levenberg_marquardt(evaluate, jacobian, p0, max_iter=max_iter, model="the run")
    _, d, t_model, model, _ = fit.state
    return HistoryCalibration.from_fit(parameters, fit, fit.r, data, None, d, t_model=t_model, model=model)


def write_history(path: str | Path, history: SensorHistory) -> Path:
    """The CSV read_history reads."""
    path = Path(path)
    keys = list(history.columns)
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["t"] + [f"{name}[{j}]" for name, j in keys])
        for i, t in enumerate(history.t):
            w.writerow([repr(float(t))] + [repr(float(history.columns[key][i])) for key in keys])
    return path

