"""The result of a calibration (whatever was measured) and the checks every calibration makes before solving.

A fit by ancf_sym.sensitivity.least_squares gives the estimate, the residuals and the Jacobian at the estimate;
Calibration adds what the user reads: the standard deviations and covariance sigma^2 (J'J)^-1 of the linearised
model, the residual noise sigma^2 = r'r / (m - n), the history, the data and the model at the estimate. The kinds of
data (node positions, frequencies, sensor histories) differ only in their residuals' unit and their plot.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import ClassVar

import numpy as np

from ancf_sym.scene.builder import SceneError
from ancf_sym.sensitivity.least_squares import Fit
from ancf_sym.sensitivity.paths import get_parameter, with_parameter


@dataclass
class Calibration:
    parameters: list
    estimate: np.ndarray
    std: np.ndarray  # standard deviations of the estimate (linearised, noise from the residuals)
    noise: float  # residual standard deviation sigma [unit]
    residuals: np.ndarray  # model - data at the estimate [unit]
    iterations: int
    converged: bool
    status: str
    start: np.ndarray
    history: list = field(default_factory=list)  # (iteration, sum of squares, estimate)
    data: object = field(default=None, repr=False)
    result: object = field(default=None, repr=False)  # the model at the estimate (a StaticResult, a ModalResult)
    doc: dict | None = field(default=None, repr=False)
    covariance: np.ndarray | None = field(default=None, repr=False)  # sigma^2 (J'J)^-1 [parameter units^2]

    unit: ClassVar[str] = ""  # the residuals' unit ("" where they mix units)

    @classmethod
    def from_fit(cls, parameters: list[str], fit: Fit, residuals: np.ndarray, data: object, result: object,
                 doc: dict, **extra) -> "Calibration":
        noise, cov = fit.statistics()
        return cls(list(parameters), fit.p, np.sqrt(np.diag(cov)), noise, residuals, fit.iterations, fit.converged,
                   fit.status, fit.scale, fit.history, data, result, doc, cov, **extra)

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
        unit = f" {self.unit}" if self.unit else ""
        return (f"calibration {'converged' if self.converged else 'NOT converged: ' + self.status} in "
                f"{self.iterations} iterations: {est}; residual noise {self.noise:.3g}{unit}")

    def title(self, short: bool = False) -> str:
        """The plot's title: the estimates with their standard deviations (short: the paths' last keys)."""
        return "; ".join(f"{p.split('.')[-1] if short else p} = {v:.5g} +- {s:.2g}"
                         for p, v, s in zip(self.parameters, self.estimate, self.std))

    def plot(self, path: str | Path) -> Path:
        """PNG of the data against the fitted model (per kind of data)."""
        raise NotImplementedError(f"{type(self).__name__} has no plot")


def start_values(doc: dict, parameters: list[str], start: list[float] | None) -> np.ndarray:
    """The first estimate: `start`, else the document's values; non-zero (they scale the parameters)."""
    p0 = np.array([get_parameter(doc, p) for p in parameters]) if start is None else np.asarray(start, float)
    if np.any(p0 == 0):
        raise SceneError(f"calibrate: start values must be non-zero (they scale the parameters): {p0.tolist()}")
    return p0


def check_count(m: int, n: int, what: str) -> None:
    """More measured values than parameters (the noise needs the rest)."""
    if m <= n:
        raise SceneError(f"calibrate: {m} measured {what} cannot determine {n} parameters (and the noise)")


def with_parameters(doc: dict, parameters: list[str], values: np.ndarray) -> dict:
    """A copy of the document with the numbers at `parameters` set to `values`."""
    for path, v in zip(parameters, values):
        doc = with_parameter(doc, path, v)
    return doc


def save_figure(fig, path: str | Path) -> Path:
    """A calibration's plot as PNG (the figure closed)."""
    import matplotlib.pyplot as plt

    fig.tight_layout()
    path = Path(path)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
