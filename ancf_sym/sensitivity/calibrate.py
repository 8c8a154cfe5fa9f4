"""Least-squares calibration of scene parameters to measured static node positions, with the exact Jacobian.

Data: rows (member, node, x, y[, z]): the measured position of a member's public node (index from 0; "start",
"end"). The model's positions come from the static equilibrium of the scene with the parameters set; their
Jacobian from the implicit function theorem (ancf_sym.sensitivity.static: one factorisation, one back-substitution
per parameter). Levenberg-Marquardt on the parameters scaled by their start values: (J'J + mu diag J'J) d = -J'r,
a step accepted when it lowers the sum of squares (mu / 3), else mu x 4 and a new trial; a trial whose statics fails
or whose values the scene refuses counts as rejected. It stops when the step is below 1e-6 of the estimate's
standard deviation (further steps cannot change the answer at the data's resolution) or after max_iter iterations.

Statistics at the estimate: the noise sigma^2 = r'r / (m - n) (m residuals, n parameters) and the covariance
sigma^2 (J'J)^-1 of the linearised model: standard deviations of the estimate.
"""
from __future__ import annotations

import csv
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ancf_sym.scene.builder import SceneError
from ancf_sym.io.scene_toml import scene_from_dict
from ancf_sym.statics.problem import problem_for
from ancf_sym.sensitivity.api import read_document
from ancf_sym.sensitivity.calibrate_history import SensorHistory, calibrate_history, is_history_file, run_history_cli
from ancf_sym.sensitivity.paths import get_parameter, with_parameter
from ancf_sym.sensitivity.static import StaticSensitivity

STEP_TOL = 1e-6  # stop when every parameter step is below this fraction of its standard deviation


@dataclass
class Measurement:
    member: str
    node: object  # int, "start" or "end"
    position: np.ndarray


@dataclass
class Calibration:
    parameters: list
    estimate: np.ndarray
    std: np.ndarray  # standard deviations of the estimate (linearised, noise from the residuals)
    noise: float  # residual standard deviation sigma [m]
    residuals: np.ndarray  # (measurements, dim) model - data at the estimate [m]
    iterations: int
    converged: bool
    status: str
    start: np.ndarray
    history: list = field(default_factory=list)  # (iteration, sum of squares, estimate)
    data: list = field(default_factory=list, repr=False)
    result: object = field(default=None, repr=False)  # the StaticResult at the estimate
    doc: dict | None = field(default=None, repr=False)
    covariance: np.ndarray | None = field(default=None, repr=False)  # sigma^2 (J'J)^-1 [parameter units^2]

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
                f"{self.iterations} iterations: {est}; residual noise {self.noise:.3g} m")

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
        ax.set_title("; ".join(f"{p.split('.')[-1]} = {v:.5g} +- {s:.2g}" for p, v, s in
                               zip(self.parameters, self.estimate, self.std)), fontsize=9)
        ax.legend(fontsize=8)
        fig.tight_layout()
        path = Path(path)
        fig.savefig(path, dpi=110)
        plt.close(fig)
        return path


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


def calibrate(doc: dict | str | Path, data: list[Measurement] | str | Path, parameters: list[str],
              start: list[float] | None = None, max_iter: int = 30) -> Calibration:
    """Fit the scene numbers at `parameters` (TOML paths) to measured node positions (see the module docstring).

    start: the first estimate (default: the document's values). A sensor history as data (SensorHistory, or a CSV
    whose header starts with t) fits the scene's dynamic run instead (ancf_sym.sensitivity.calibrate_history)."""
    if isinstance(data, SensorHistory) or (isinstance(data, (str, Path)) and is_history_file(data)):
        return calibrate_history(doc, data, parameters, start, max_iter)
    doc = read_document(doc)
    parameters = list(parameters)
    p0 = np.array([get_parameter(doc, p) for p in parameters]) if start is None else np.asarray(start, float)
    if np.any(p0 == 0):
        raise SceneError(f"calibrate: start values must be non-zero (they scale the parameters): {p0.tolist()}")
    scene, _ = scene_from_dict(doc)
    if not isinstance(data, list):
        data = read_data(data, scene.dim)
    idx = _index(problem_for(scene).asm, data)
    meas = np.concatenate([d.position for d in data])
    m, n = meas.size, len(parameters)
    if m <= n:
        raise SceneError(f"calibrate: {m} measured coordinates cannot determine {n} parameters (and the noise)")

    def evaluate(p, x0=None):
        d = doc
        for path, v in zip(parameters, p):
            d = with_parameter(d, path, v)
        try:
            sc, _ = scene_from_dict(d)
            res = problem_for(sc).solve(x0=x0)
        except SceneError:
            return None
        if not res.success:
            return None
        return d, sc, res, res.x[idx].ravel() - meas

    p = p0.copy()
    cur = evaluate(p)
    if cur is None:
        raise SceneError("calibrate: the statics at the start values failed")
    mu, history, status, converged = 1e-3, [], "max_iter reached", False
    it = 0
    for it in range(1, max_iter + 1):
        d, sc, res, r = cur
        S = StaticSensitivity(sc, res, d)
        J = np.column_stack([S.dx(path)[idx].ravel() for path in parameters]) * p0  # d r / d (p / p0)
        JtJ, g = J.T @ J, J.T @ r
        cost = float(r @ r)
        history.append((it - 1, cost, p.copy()))
        sigma2 = cost / (m - n)
        std_theta = np.sqrt(np.maximum(np.diag(np.linalg.inv(JtJ)) * sigma2, 0.0))
        # the Gauss-Newton correction still to come already below the data's resolution: converged here (where no
        # trial lowers the sum of squares any more, which round-off decides at the minimum)
        if np.all(np.abs(np.linalg.solve(JtJ, -g)) <= STEP_TOL * np.maximum(std_theta, 1e-15)):
            converged, status = True, "converged"
            break
        while True:
            step = np.linalg.solve(JtJ + mu * np.diag(np.diag(JtJ)), -g)
            trial = evaluate(p + step * p0, res.x)
            if trial is not None and float(trial[3] @ trial[3]) <= cost:
                break
            mu *= 4.0
            if mu > 1e12:
                status = "no step lowers the sum of squares"
                break
        if mu > 1e12:
            break
        p, cur, mu = p + step * p0, trial, max(mu / 3.0, 1e-9)
        if np.all(np.abs(step) <= STEP_TOL * np.maximum(std_theta, 1e-15)):
            converged, status = True, "converged"
            break
    d, sc, res, r = cur
    S = StaticSensitivity(sc, res, d)
    J = np.column_stack([S.dx(path)[idx].ravel() for path in parameters]) * p0  # (scaled: J'J well conditioned)
    cost = float(r @ r)
    history.append((it, cost, p.copy()))
    sigma2 = cost / (m - n)
    cov = np.linalg.inv(J.T @ J) * sigma2 * np.outer(p0, p0)
    std = np.sqrt(np.diag(cov))
    return Calibration(parameters, p, std, float(np.sqrt(sigma2)), r.reshape(len(data), -1), it, converged, status,
                       p0, history, data, res, d, cov)


def run_cli(scene_file: str | Path, data_file: str | Path, parameters: list[str], out: Path, max_iter: int = 30,
            quiet: bool = False) -> int:
    """`ancf-sym calibrate`: the fit, out/calibration.json and out/calibration.png; exit code 0 when converged."""
    from ancf_sym.io.json_out import write_json

    if is_history_file(data_file):  # (a sensor history: the dynamic run's fit)
        return run_history_cli(scene_file, data_file, parameters, out, max_iter, quiet)
    doc = read_document(scene_file)
    scene, _ = scene_from_dict(doc)
    for path in parameters:  # every path checked before any solving
        from ancf_sym.sensitivity.model_derivative import model_derivative
        model_derivative(problem_for(scene).asm, doc, path)
    data = read_data(data_file, scene.dim)
    cal = calibrate(doc, data, parameters, max_iter=max_iter)
    out.mkdir(parents=True, exist_ok=True)
    write_json(out / "calibration.json", cal.to_dict())
    cal.plot(out / "calibration.png")
    if not quiet:
        print(f"{cal.summary()} -> {out}")
    return 0 if cal.converged else 1
