"""Bounds, boundary values, costs and path constraints of a control problem, and their pieces of the NLP: the
Bounds object (checked user bounds and start/end values, the variable bounds of a layout) and the functions that
write the path rows and the cost for the transcription."""
from __future__ import annotations

import math

import casadi as ca
import numpy as np

from ancf_sym.util.checks import number as _num
from ancf_sym.scene.builder import SceneError
from ancf_sym.util.sparsity import dm as _dm
from ancf_sym.control.ingredients import Effort, MinimumTime, Swing
from ancf_sym.control.model import StateView
from ancf_sym.control.model import ControlModel
from ancf_sym.control.options import ControlOptions


class Bounds:
    """The user's bounds ({"<channel>.position": (lo, hi), ...}) and the channels' start and end values, checked
    against the model's names and for the necessary conditions of a rest-to-rest move, before any NLP is built."""

    def __init__(self, model: ControlModel, options: ControlOptions, bounds: dict | None, start: dict | None,
                 end: dict | None):
        self.model, self.options = model, options
        self.bounds = self._check_bounds(bounds or {})
        self.start_values = self._check_targets(start or {}, "start")
        self.end_values = self._check_targets(end or {}, "end")
        self._check_feasible()

    def _check_bounds(self, bounds: dict) -> dict:
        if not isinstance(bounds, dict):
            raise SceneError(f"bounds must be a dict name -> (lower, upper), got {bounds!r}")
        known = self.model.variable_names()
        out = {}
        for k, v in bounds.items():
            if k not in known:
                raise SceneError(f"bounds: unknown name {k!r}; known: {known}")
            if not isinstance(v, (tuple, list)) or len(v) != 2:
                raise SceneError(f"bounds[{k!r}] must be (lower, upper), got {v!r}")
            lo = -np.inf if v[0] is None else float(v[0])
            hi = np.inf if v[1] is None else float(v[1])
            if math.isnan(lo) or math.isnan(hi) or lo > hi:
                raise SceneError(f"bounds[{k!r}] = {tuple(v)!r} is infeasible: lower > upper")
            if k.endswith(".velocity") and not lo <= 0 <= hi:
                raise SceneError(f"bounds[{k!r}] = {tuple(v)!r} excludes rest (velocity 0), where the motion starts")
            out[k] = (lo, hi)
        return out

    def _check_targets(self, d: dict, label: str) -> dict:
        if not isinstance(d, dict):
            raise SceneError(f"{label} must be a dict channel.position -> value, got {d!r}")
        channels = self.model.channels
        out = {ch: 0.0 for ch in channels}
        for k, v in d.items():
            name, _, what = k.rpartition(".")
            if name not in channels or what != "position":
                raise SceneError(f"{label}: unknown name {k!r}; give '<channel>.position' for channels "
                                 f"{channels} (controlled supports); the scene starts and ends at rest")
            out[name] = _num(f"{label}[{k!r}]", v)
        for ch, val in out.items():
            lo, hi = self.bounds.get(f"{ch}.position", (-np.inf, np.inf))
            if not lo <= val <= hi:
                raise SceneError(f"{label}: {ch}.position = {val} lies outside its bounds ({lo}, {hi}): infeasible")
        return out

    def _check_feasible(self) -> None:
        """Necessary conditions of a rest-to-rest move in the longest allowed time: distance <= v_max T and
        <= a_max T^2 / 4."""
        T = self.options.T_bounds[1]
        for ch in self.model.channels:
            d = abs(self.end_values[ch] - self.start_values[ch])
            vlo, vhi = self.bounds.get(f"{ch}.velocity", (-np.inf, np.inf))
            alo, ahi = self.bounds.get(f"{ch}.acceleration", (-np.inf, np.inf))
            vmax = -vlo if self.end_values[ch] < self.start_values[ch] else vhi
            amax = min(-alo, ahi)
            if d > 0 and vmax <= 0:
                raise SceneError(f"{ch}: velocity bounds {(vlo, vhi)} forbid moving from {self.start_values[ch]} "
                                 f"to {self.end_values[ch]}: infeasible")
            if d > vmax * T * (1 + 1e-12):
                raise SceneError(f"{ch}: moving {d} m needs more than the horizon {T} s at the velocity bound "
                                 f"{vmax} m/s: infeasible")
            if amax < 0:
                raise SceneError(f"{ch}: acceleration bounds {(alo, ahi)} exclude zero (rest): infeasible")
            if d > amax * T * T / 4 * (1 + 1e-12):
                raise SceneError(f"{ch}: a rest-to-rest move of {d} m in {T} s needs an acceleration of at least "
                                 f"{4 * d / T ** 2:.4g} m/s^2, above the bound {amax}: infeasible")

    def variable_bounds(self, idx: dict, nw: int, iT: int | None, q_start: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(lower, upper) of the nw decision variables (their indices idx by part, iT the horizon's): the user's
        bounds on the channels and forces, the start at rest in the equilibrium q_start, the supports at rest at
        their end values, the horizon's range."""
        m = self.model
        I, K, nf, nc = idx, self.options.K, m.nf, m.nc
        lb, ub = np.full(nw, -np.inf), np.full(nw, np.inf)
        for k, ch in enumerate(m.channels):
            lo, hi = self.bounds.get(f"{ch}.position", (-np.inf, np.inf))
            for key in ("s", "SP"):
                lb[I[key][..., k]], ub[I[key][..., k]] = lo, hi
            lo, hi = self.bounds.get(f"{ch}.velocity", (-np.inf, np.inf))
            for key in ("sv", "SV"):
                lb[I[key][..., k]], ub[I[key][..., k]] = lo, hi
            lb[I["U"][..., k]], ub[I["U"][..., k]] = self.bounds.get(f"{ch}.acceleration", (-np.inf, np.inf))
        for k, fn in enumerate(m.force_names):
            lb[I["U"][..., nc + k]], ub[I["U"][..., nc + k]] = self.bounds.get(f"{fn}.force", (-np.inf, np.inf))
        # start: at rest in equilibrium; end: supports at rest at their targets
        s0, sT = m.chan_vector(self.start_values), m.chan_vector(self.end_values)
        for key, val in (("q", q_start), ("v", np.zeros(nf)), ("s", s0), ("sv", np.zeros(nc))):
            lb[I[key][0]], ub[I[key][0]] = val, val
        for key, val in (("s", sT), ("sv", np.zeros(nc))):
            lb[I[key][K]], ub[I[key][K]] = val, val
        if self.options.free_time:
            lb[iT], ub[iT] = self.options.T_bounds
        return lb, ub


def path_rows(model: ControlModel, options: ControlOptions, w: ca.MX, I: dict, Ed: ca.DM, Xp: ca.MX, Vp: ca.MX,
              SP: ca.MX, SV: ca.MX, U: ca.MX) -> tuple[list, list, list]:
    """Rows (CasADi), lower and upper bounds of the path constraints at the collocation points (positions Xp,
    velocities Vp, channels SP, SV, controls U there) and of the terminal constraints at T."""
    K, n, nc, nu = options.K, model.n, model.nc, model.nu
    Pp = K * options.s
    rows = []
    lb_path, ub_path = [], []
    items = [("path", i, pc) for i, pc in enumerate(options.path)] + \
        [("terminal", i, pc) for i, pc in enumerate(options.terminal)]
    if items:
        xs, vs = ca.MX.sym("x", n), ca.MX.sym("v", n)
        ps_, vs_, us_ = ca.MX.sym("sp", nc), ca.MX.sym("sv", nc), ca.MX.sym("u", nu)
        view = StateView(model, xs, vs, ps_, vs_, us_)
        xT = ca.mtimes(Ed, w[I["q"][K].tolist()]) + ca.DM(model.part.c)
        vT = ca.mtimes(Ed, w[I["v"][K].tolist()])
        if nc:
            xT += ca.mtimes(ca.DM(model.B), w[I["s"][K].tolist()])
            vT += ca.mtimes(ca.DM(model.B), w[I["sv"][K].tolist()])
        for kind, i, pc in items:
            label = f"{kind}[{i}] ({pc.name!r})"
            try:
                expr = ca.vec(ca.MX(pc.fn(view)))
            except SceneError:
                raise
            except Exception as exc:  # noqa: BLE001
                raise SceneError(f"{label}: fn(view) failed: {exc}") from None
            if not ca.depends_on(expr, ca.vertcat(xs, vs, ps_, vs_, us_)):
                raise SceneError(f"{label}: fn(view) does not depend on the state")
            m = expr.shape[0]
            lo = np.broadcast_to(np.asarray(pc.lower, float), (m,))
            hi = np.broadcast_to(np.asarray(pc.upper, float), (m,))
            if np.any(np.isnan(lo)) or np.any(np.isnan(hi)) or np.any(lo > hi):
                raise SceneError(f"{label}: bounds ({pc.lower}, {pc.upper}) are infeasible (lower > upper)")
            fn = ca.Function(f"{kind}_{i}", [xs, vs, ps_, vs_, us_], [expr])
            if kind == "path":
                rows.append(ca.vec(fn.map(Pp)(Xp, Vp, SP, SV, U)))
                reps = Pp
            else:  # the controls of the last collocation point
                rows.append(fn(xT, vT, w[I["s"][K].tolist()] if nc else ca.MX(0, 1),
                               w[I["sv"][K].tolist()] if nc else ca.MX(0, 1), U[:, Pp - 1]))
                reps = 1
            lb_path.append(np.tile(lo, reps))
            ub_path.append(np.tile(hi, reps))
    return rows, lb_path, ub_path


def cost(model: ControlModel, options: ControlOptions, T: ca.MX, h: ca.MX, U: ca.MX, Vst: ca.MX, SV: ca.MX,
         Ed: ca.DM) -> ca.MX:
    """The objective: quadrature of the running costs over the collocation points (controls U, stage velocities
    Vst, channel velocities SV), plus weight x T."""
    K, nu, nc, tab = options.K, model.nu, model.nc, options.tab
    bw = ca.DM(np.tile(tab.b, K))  # quadrature weights of the points (times h)
    f = 0
    for c in options.cost:
        if isinstance(c, Effort):
            wts = np.ones(nu)
            names = model.channels + model.force_names
            for k2, v2 in (c.weights or {}).items():
                if k2 not in names:
                    raise SceneError(f"Effort.weights: unknown control {k2!r}; known: {names}")
                wts[names.index(k2)] = _num(f"Effort.weights[{k2!r}]", v2, nonneg=True)
            f += c.weight * h * ca.mtimes(ca.mtimes(ca.DM(wts).T, U ** 2), bw)
        elif isinstance(c, MinimumTime):
            f += c.weight * T
        elif isinstance(c, Swing):
            Vrel = ca.mtimes(Ed, Vst)
            if nc:
                Vrel += ca.mtimes(ca.DM(model.B - model.Tr), SV)
            ke = 0.5 * ca.sum1(Vrel * ca.mtimes(_dm(model.M_full), Vrel))
            f += c.weight * h * ca.mtimes(ke, bw)
    f = ca.MX(f) if not isinstance(f, ca.MX) else f
    return f
