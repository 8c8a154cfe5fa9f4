"""Calibration of scene parameters to measured natural frequencies, with the exact Jacobian of the frequencies.

Data: rows (mode, frequency): the measured frequency [Hz] of the scene's mode `mode`, counted from 0 in ascending
order as in a modal result (result.json's `frequencies`). The model's frequencies come from the modal analysis about
the static equilibrium with the parameters set; their Jacobian from ancf_sym.sensitivity.modal (the prestress's
change through the static sensitivity included), so a parameter that acts only through the tension, a prestrain or
an end load, is identified as exactly as a mass or a stiffness. Levenberg-Marquardt as
ancf_sym.sensitivity.least_squares; the estimate's standard deviation from the Jacobian and the residual noise
sigma^2 = r'r / (m - n) (m frequencies, n < m parameters).

Modes are matched by their rank: where the fitted parameters make two modes cross (the in-plane modes of a sagging
cable near Irvine's crossover), the ranks swap and the fit matches the wrong mode; start close enough, or measure
modes that stay apart.
"""
from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ancf_sym.io.scene_toml import scene_from_dict
from ancf_sym.modal import modal_analysis
from ancf_sym.scene.builder import SceneError
from ancf_sym.sensitivity.calibration import Calibration, check_count, save_figure, start_values, with_parameters
from ancf_sym.sensitivity.least_squares import levenberg_marquardt
from ancf_sym.sensitivity.model_derivative import check_model_paths, read_document
from ancf_sym.sensitivity.modal import ModalSensitivity
from ancf_sym.statics.problem import problem_for

HEADER = ("mode", "frequency")


@dataclass
class FrequencyMeasurement:
    mode: int  # rank from 0 among the ascending frequencies
    frequency: float  # [Hz]


class FrequencyCalibration(Calibration):
    """A Calibration whose data are frequencies: residuals (model - data) [Hz] per measured mode, noise [Hz], the
    ModalResult at the estimate as `result`."""

    unit = "Hz"

    def to_dict(self) -> dict:
        """Calibration.to_dict with the data and the fitted model's frequencies."""
        record = super().to_dict()
        record["data"] = [{"mode": d.mode, "frequency": d.frequency} for d in self.data]
        record["frequencies"] = self.result.frequencies.tolist()
        return record

    def plot(self, path: str | Path) -> Path:
        """PNG: the fitted equilibrium with the measured modes' shapes (left), measured against fitted frequencies
        per mode with the residuals (right)."""
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        modes = np.array([d.mode for d in self.data])
        meas = np.array([d.frequency for d in self.data])
        mr = self.result
        st = mr.static
        fig, (ax0, ax) = plt.subplots(1, 2, figsize=(11, 4.2), gridspec_kw={"width_ratios": [1.4, 1]})
        span = st.assembly.mesh.length_scale
        for name in st.assembly.mesh.members:
            r = st.nodes(name)
            ax0.plot(r[:, 0], r[:, 1], "k-", lw=1.5, label="equilibrium" if name == next(iter(
                st.assembly.mesh.members)) else None)
            for k in modes:
                u = mr.displacements(int(k), name)
                scale = 0.04 * span / max(float(np.abs(u).max()), 1e-300)
                ax0.plot(r[:, 0] + scale * u[:, 0], r[:, 1] + scale * u[:, 1], "-", lw=1,
                         label=f"mode {k}: {mr.frequencies[k]:.4g} Hz")
        ax0.set_aspect("equal", adjustable="datalim")
        ax0.set_xlabel("x [m]")
        ax0.set_ylabel("y [m]")
        ax0.set_title("fitted model: equilibrium and measured modes (scaled)", fontsize=9)
        ax0.legend(fontsize=8)
        k = np.arange(mr.modes)
        ax.plot(k, mr.frequencies, "s", mfc="none", ms=9, label="fitted model")
        ax.plot(modes, meas, "o", label="measured")
        for m_, y, r_ in zip(modes, meas, self.residuals):
            ax.annotate(f"{r_ * 1e3:+.2g} mHz", (m_, y), textcoords="offset points", xytext=(8, -4), fontsize=8)
        ax.set_xlabel("mode (rank from 0)")
        ax.set_ylabel("frequency [Hz]")
        ax.set_xticks(k)
        ax.set_title(self.title(), fontsize=9)
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3)
        return save_figure(fig, path)


def read_frequencies(path: str | Path) -> list[FrequencyMeasurement]:
    """CSV with the header `mode,frequency` (mode: rank from 0; frequency [Hz], positive)."""
    rows = []
    with open(path, newline="") as fh:
        reader = csv.DictReader(fh)
        if [h.strip() for h in (reader.fieldnames or [])] != list(HEADER):
            raise SceneError(f"{path}: header must be {','.join(HEADER)}, got {reader.fieldnames}")
        for k, r in enumerate(reader, start=2):
            try:
                mode, f = int(r["mode"]), float(r["frequency"])
            except (TypeError, ValueError):
                raise SceneError(f"{path}, line {k}: mode {r['mode']!r} is not an integer or frequency "
                                 f"{r['frequency']!r} not a number") from None
            if mode < 0 or not np.isfinite(f) or f <= 0:
                raise SceneError(f"{path}, line {k}: mode must be >= 0 and frequency a positive number "
                                 f"(got mode {mode}, frequency {f})")
            rows.append(FrequencyMeasurement(mode, f))
    if not rows:
        raise SceneError(f"{path}: no measurements")
    modes = [d.mode for d in rows]
    if len(set(modes)) != len(modes):
        raise SceneError(f"{path}: mode measured twice ({sorted(modes)})")
    return rows


def calibrate_frequencies(doc: dict | str | Path, data: list[FrequencyMeasurement] | str | Path,
                          parameters: list[str], start: list[float] | None = None,
                          max_iter: int = 30) -> FrequencyCalibration:
    """Fit the scene numbers at `parameters` (TOML paths) to measured natural frequencies (module docstring).

    start: the first estimate (default: the document's values; non-zero, they scale the parameters)."""
    doc = read_document(doc)
    parameters = list(parameters)
    scene, _ = scene_from_dict(doc)
    check_model_paths(scene, doc, parameters)  # (every path checked before any solving)
    if not isinstance(data, list):
        data = read_frequencies(data)
    p0 = start_values(doc, parameters, start)
    check_count(len(data), len(parameters), "frequencies")
    ranks = np.array([d.mode for d in data])
    meas = np.array([d.frequency for d in data])
    modes = int(ranks.max()) + 1

    def evaluate(p, before):
        d = with_parameters(doc, parameters, p)
        try:
            sc, _ = scene_from_dict(d)
            res = problem_for(sc).solve(x0=None if before is None else before[2].static.x)
            if not res.success:
                return None
            mr = modal_analysis(sc, modes=modes, static=res)
        except SceneError:
            return None
        if not mr.success or mr.modes < modes:
            return None
        return (d, sc, mr), mr.frequencies[ranks] - meas

    def jacobian(state):
        d, sc, mr = state
        ms = ModalSensitivity(mr, sc, d)
        cols = []
        for path in parameters:
            df, notes = ms.derivative(path)
            if not np.all(np.isfinite(df[ranks])):
                raise ValueError(f"calibrate: the frequencies' derivative is not defined ({'; '.join(notes)})")
            cols.append(df[ranks])
        return np.column_stack(cols)

    fit = levenberg_marquardt(evaluate, jacobian, p0, max_iter=max_iter, model="the statics or the modal analysis")
    d, _, mr = fit.state
    return FrequencyCalibration.from_fit(parameters, fit, fit.r, data, mr, d)

