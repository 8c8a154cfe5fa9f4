"""Least-squares calibration of scene parameters to measured dynamic sensor histories (a decay record, a swing),
with the exact Jacobian of the discrete run.

Data: a record of sensor values at times on the run's step grid (t_start + k dt): CSV with a header `t, NAME[j],
...` (NAME: a sensor of the scene's [analysis] sensors, j its component; NAME alone: component 0). The model's
record comes from the dynamic run of the scene (analysis table, type = "dynamics": an alpha scheme with fixed
steps) with the parameters set; its Jacobian from the forward sensitivities of that run (ancf_sym.sensitivity.
dynamics: exact for the discrete scheme, one recursion for all parameters). Levenberg-Marquardt on the parameters
scaled by their start values, the same steps and stopping rule as the static calibration
(ancf_sym.sensitivity.calibrate): a step is accepted when it lowers the sum of squares, and the fit stops when the
Gauss-Newton correction is below 1e-6 of the estimate's standard deviation.

Statistics at the estimate: noise sigma^2 = r'r / (m - n), covariance sigma^2 (J'J)^-1 of the linearised model.
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
from ancf_sym.sensitivity.dynamics import dynamic_sensitivity
from ancf_sym.sensitivity.model_derivative import read_document
from ancf_sym.sensitivity.paths import get_parameter, with_parameter

STEP_TOL = 1e-6  # stop when every parameter step is below this fraction of its standard deviation
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


def is_history_file(path: str | Path) -> bool:
    """The CSV's first header column is t (a sensor history, not static node positions)."""
    with open(path, newline="") as fh:
        head = next(csv.reader(fh), [])
    return bool(head) and head[0].strip() == "t"


@dataclass
class HistoryCalibration:
    parameters: list
    estimate: np.ndarray
    std: np.ndarray  # standard deviations of the estimate (linearised, noise from the residuals)
    noise: float  # residual standard deviation sigma [the sensors' units]
    residuals: np.ndarray  # (m,) model - data at the estimate, the columns one after another
    iterations: int
    converged: bool
    status: str
    start: np.ndarray
    history: list = field(default_factory=list)  # (iteration, sum of squares, estimate)
    data: SensorHistory | None = field(default=None, repr=False)
    t_model: np.ndarray | None = field(default=None, repr=False)  # the fitted run's step times
    model: dict = field(default_factory=dict, repr=False)  # (sensor, component) -> the fitted run's record
    doc: dict | None = field(default=None, repr=False)
    covariance: np.ndarray | None = field(default=None, repr=False)

    def to_dict(self) -> dict:
        return {"status": self.status, "converged": self.converged, "iterations": self.iterations,
                "parameters": {p: {"estimate": float(v), "std": float(s), "start": float(s0)}
                               for p, v, s, s0 in zip(self.parameters, self.estimate, self.std, self.start)},
                "covariance": None if self.covariance is None else self.covariance.tolist(),
                "noise": self.noise, "residuals": self.residuals.tolist(),
                "history": [{"iteration": k, "sum_of_squares": c, "estimate": list(map(float, e))}
                            for k, c, e in self.history]}

    def summary(self) -> str:
        est = ", ".join(f"{p} = {v:.6g} +- {s:.2g}" for p, v, s in zip(self.parameters, self.estimate, self.std))
        return (f"calibration {'converged' if self.converged else 'NOT converged: ' + self.status} in "
                f"{self.iterations} iterations: {est}; residual noise {self.noise:.3g}")

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
        axes[0, 0].set_title("; ".join(f"{p} = {v:.5g} +- {s:.2g}" for p, v, s in
                                       zip(self.parameters, self.estimate, self.std)), fontsize=9)
        fig.tight_layout()
        path = Path(path)
        fig.savefig(path, dpi=110)
        plt.close(fig)
        return path


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
    opts = dynamic_options(doc, options)
    if not isinstance(data, SensorHistory):
        data = read_history(data)
    names = [s.get("name") if isinstance(s, dict) else s.name for s in opts.sensors]
    for name, _ in data.columns:
        if name not in names:
            raise SceneError(f"calibrate: data column {name!r} names no sensor of the run (sensors: {names})")
    k = _grid_index(np.asarray(data.t, float), opts)
    meas = np.concatenate(list(data.columns.values()))
    p0 = np.array([get_parameter(doc, p) for p in parameters]) if start is None else np.asarray(start, float)
    if np.any(p0 == 0):
        raise SceneError(f"calibrate: start values must be non-zero (they scale the parameters): {p0.tolist()}")
    m, n = meas.size, len(parameters)
    if m <= n:
        raise SceneError(f"calibrate: {m} measured values cannot determine {n} parameters (and the noise)")

    def evaluate(p, jacobian: bool):
        d = doc
        for path, v in zip(parameters, p):
            d = with_parameter(d, path, v)
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
                                 for path in parameters]) * p0  # d r / d (p / p0)
        return d, r, J, ds.t, model

    p = p0.copy()
    cur = evaluate(p, True)
    if cur is None:
        raise SceneError("calibrate: the run at the start values failed")
    mu, history, status, converged = 1e-3, [], "max_iter reached", False
    it = 0
    for it in range(1, max_iter + 1):
        d, r, J, _, _ = cur
        JtJ, g = J.T @ J, J.T @ r
        cost = float(r @ r)
        history.append((it - 1, cost, p.copy()))
        std_theta = np.sqrt(np.maximum(np.diag(np.linalg.inv(JtJ)) * cost / (m - n), 0.0))
        if np.all(np.abs(np.linalg.solve(JtJ, -g)) <= STEP_TOL * np.maximum(std_theta, 1e-15)):
            converged, status = True, "converged"
            break
        while True:
            step = np.linalg.solve(JtJ + mu * np.diag(np.diag(JtJ)), -g)
            trial = evaluate(p + step * p0, False)
            if trial is not None and float(trial[1] @ trial[1]) <= cost:
                break
            mu *= 4.0
            if mu > 1e12:
                status = "no step lowers the sum of squares"
                break
        if mu > 1e12:
            break
        p, mu = p + step * p0, max(mu / 3.0, 1e-9)
        cur = evaluate(p, True)
        if np.all(np.abs(step) <= STEP_TOL * np.maximum(std_theta, 1e-15)):
            converged, status = True, "converged"
            break
    d, r, J, t_model, model = cur
    cost = float(r @ r)
    history.append((it, cost, p.copy()))
    sigma2 = cost / (m - n)
    cov = np.linalg.inv(J.T @ J) * sigma2 * np.outer(p0, p0)
    return HistoryCalibration(parameters, p, np.sqrt(np.diag(cov)), float(np.sqrt(sigma2)), r, it, converged,
                              status, p0, history, data, t_model, model, d, cov)


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


def run_history_cli(scene_file: str | Path, data_file: str | Path, parameters: list[str], out: Path,
                    max_iter: int = 30, quiet: bool = False) -> int:
    """`ancf-sym calibrate SCENE.toml HISTORY.csv`: the fit of the scene's dynamic run, out/calibration.json and
    out/calibration.png; exit code 0 when converged. Every path is checked before any run."""
    from ancf_sym.io.json_out import write_json
    from ancf_sym.io.scene_toml import scene_from_dict
    from ancf_sym.sensitivity.alpha_run import check_dynamic_paths

    doc = read_document(scene_file)
    scene, _ = scene_from_dict(doc)
    check_dynamic_paths(scene, doc, list(parameters))
    cal = calibrate_history(doc, data_file, parameters, max_iter=max_iter)
    out.mkdir(parents=True, exist_ok=True)
    write_json(out / "calibration.json", cal.to_dict())
    cal.plot(out / "calibration.png")
    if not quiet:
        print(f"{cal.summary()} -> {out}")
    return 0 if cal.converged else 1
