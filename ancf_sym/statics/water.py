"""Statics of a scene in water: Newton on the residual R(y) = E^T (grad Pi(x) - Q_water(x)) with its exact
(unsymmetric where the current drags) Jacobian, x = E y + c on the free coordinates.

Q_water is the current's Morison drag on the line at rest (not conservative: no potential to minimise) and the
water line's correction of the buoyancy (a potential); lam scales both. The start is the conservative equilibrium the scene's own
statics finds (buoyancy as the net weight, the seabed contacts, with the fairleads' position drives held as pins
at their reference positions); from there the current (scaled by lam) and the fairleads' positions (moved by lam
from the reference to the drives' values at t = 0) reach lam = 1 in adaptive continuation steps, each solved by
full Newton steps on a sparse LU. Convergence is judged as the scene's statics judges it (statics.criteria): the
last update in units of the structure's length and |r . dz| in units of the load work, both <= tol.
A continuation step is accepted where its Newton converged on a stable point whose conservative potential did
not rise above the step's start by more than the drag's work can explain (WaterStatics.energy_rise); else it is
retried shorter.
Stability: the symmetric part of the Jacobian positive definite (inertia of its factorisation): for a conservative
scene that is the Hessian's test; with drag a sufficient condition for a statically stable equilibrium.
"""
from __future__ import annotations

import copy
import functools
import math
import time

import casadi as ca
import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from ancf_sym.model.assembly import Assembly
from ancf_sym.statics.inertia import reduced_inertia
from ancf_sym.model.reduced import partition
from ancf_sym.util.checks import SceneError
from ancf_sym.util.sparsity import dm
from ancf_sym.model.water_forces import drag_force, gravity_magnitude, water_line_energy
from ancf_sym.model.water_points import wet_points

STEP_TOL = 1e-6  # relative tolerance at intermediate continuation steps (a start inside the next basin is enough)
STEP_ITER = 25  # Newton iterations per continuation step
MIN_STEP = 1.0 / 1024  # smaller continuation steps than this: the solve fails (status "continuation_failed")
WILD = 1e3  # an update of a thousand structure lengths: diverged


def _drive_coordinates(asm, scene) -> tuple[list, np.ndarray, np.ndarray, list]:
    """(fixed coordinate indices, their values at t = 0, at the reference, labels) of the member-node position
    drives (the fairleads)."""
    idx, val, labels = [], [], []
    for d in scene.drives:
        if type(d).__name__ != "PositionDrive" or d.member is None:
            raise SceneError(f"drives: {d.name!r}: the statics in water hold member-node position drives (fairleads) "
                             "at their t = 0 values; other drives belong to the dynamics")
        mm = asm.mesh.members[d.member]
        dofs = mm.node_dofs(mm.node(d.at))[:scene.dim]
        for k, mo in enumerate(d.position):
            idx.append(int(dofs[k]))
            val.append(float(mo(0.0)[0]))
        labels.append((d.name, dofs))
    idx = np.array(idx, dtype=np.int64)
    return idx, np.array(val), asm.x0[idx] if len(idx) else np.zeros(0), labels


class WaterStatics:
    def __init__(self, scene):
        self.scene = scene
        self.water = w = scene.water
        self.asm = asm = Assembly(scene)
        g = gravity_magnitude(scene)
        part = partition(asm)
        # exact rows the partition keeps (rigid joints, skew clamps, rigid bodies' joints): Lagrange multipliers mu
        self.rows = part.rows
        self.m = m = len(part.rows)
        cons = asm.exact.subset(part.rows) if m else None
        didx, self.dval, dref, self.drive_labels = _drive_coordinates(asm, scene)
        if len(didx) and np.any(part.pos[didx] < 0):
            raise SceneError("statics in water: a driven fairlead node is also pinned or identified by a joint")
        self.didx = didx
        keep = np.setdiff1d(np.arange(part.ny), part.pos[didx]) if len(didx) else np.arange(part.ny)
        E = part.E.tocsc()[:, keep]
        self.E, self.keep = E, keep
        self.c0 = part.c.copy()
        self.c0[didx] = dref
        self.dc = np.zeros(asm.n)
        self.dc[didx] = self.dval - dref
        self.fixed = np.flatnonzero(np.asarray(abs(E).sum(axis=1)).ravel() == 0)  # coordinates held by supports/drives
        n, ny = asm.n, E.shape[1]
        self.ny = ny
        wp = wet_points(asm, w)
        z, c, lam = ca.MX.sym("z", ny + m), ca.MX.sym("c", n), ca.MX.sym("lam")
        y, mu = z[:ny], z[ny:]
        x = ca.mtimes(dm(E), y) + c
        xs, mus = ca.MX.sym("x", n), ca.MX.sym("mu", m)
        pot, grad, hup, _ = asm.casadi_parts(xs)
        H = hup + hup.T - ca.diag(ca.diag(hup))
        Qw = ca.MX.zeros(n)
        Ub = water_line_energy(wp, w, g, xs)
        self.water_line = ca.Function("water_line", [xs], [Ub]) if Ub is not None else None
        if Ub is not None:
            Qw -= lam * ca.gradient(Ub, xs)  # (scaled by lam too: lam = 0 is the start's own problem)
        Qd = drag_force(wp, w, xs, None, lam) if w.current is not None and wp.drag else ca.MX.zeros(n)
        Qw += Qd
        # a step's acceptance test: the conservative potential at lam (the water line's scaled as in R) and the drag
        self.merit = ca.Function("water_merit", [xs, lam], [pot + (lam * Ub if Ub is not None else 0), Qd])
        Rf = grad - Qw
        Jf = H - ca.jacobian(Qw, xs)
        if m:
            phi = Assembly.casadi_constraint(cons, xs)
            G = ca.jacobian(phi, xs)
            Rf = Rf + ca.mtimes(G.T, mus)
            if len(cons.qrow):  # (bilinear rows: the multipliers' curvature)
                Jf = Jf + ca.hessian(ca.dot(mus, phi), xs)[0]
        else:
            phi, G = ca.MX(0, 1), ca.MX(0, n)
        full = ca.Function("water_residual_full", [xs, lam, mus], [Rf, Jf, phi, G])
        Rx, Jx, ph, Gx = full(x, lam, mu)
        Et, Ed = dm(E.T.tocsr()), dm(E)
        GE = ca.mtimes(Gx, Ed)
        R = ca.vertcat(ca.mtimes(Et, Rx), ph)
        J = ca.blockcat([[ca.mtimes(Et, ca.mtimes(Jx, Ed)), GE.T], [GE, ca.MX(m, m)]])
        self.f = ca.Function("water_statics", [z, c, lam], [R, J])
        self.full = full
        self.mu = np.zeros(m)  # the multipliers at the last solution
        self.scale = np.r_[self._scales(), np.full(m, np.inf)]  # (the multipliers are not judged by the increment)

    def _scales(self) -> np.ndarray:
        from ancf_sym.statics.criteria import coordinate_scales

        return coordinate_scales(self.asm) @ abs(self.E) / np.maximum(np.asarray(abs(self.E).sum(axis=0)).ravel(), 1)

    move_drives = False  # True: lam also moves the fairleads from the reference to the drives' values

    def _c(self, lam: float) -> np.ndarray:
        return self.c0 + (lam if self.move_drives else 1.0) * self.dc

    def x_of(self, z: np.ndarray, lam: float = 1.0) -> np.ndarray:
        return self.E @ z[:self.ny] + self._c(lam)

    def _eval(self, y, lam):
        R, J = self.f(y, self._c(lam), lam)
        return np.asarray(R).ravel(), sp.csc_matrix(J.sparse() if hasattr(J, "sparse") else J)

    def newton(self, y: np.ndarray, lam: float, tol: float, max_iter: int, work: float):
        """Full Newton steps at continuation parameter lam: (y, converged, status, iterations, inc, dec, resid).
        (Measured: halving steps that raise |R| slowed these cable solves; a failed solve shortens the continuation
        step instead.)"""
        inc = dec = rmax = math.inf
        R, J = self._eval(y, lam)
        for it in range(1, max_iter + 1):
            rmax = float(np.max(np.abs(R))) if len(R) else 0.0
            if not np.all(np.isfinite(R)) or not np.all(np.isfinite(J.data)):
                return y, False, "not_finite", it, inc, dec, rmax
            try:
                dz = -splu(J).solve(R)
            except RuntimeError:
                return y, False, "singular", it, inc, dec, rmax
            if not np.all(np.isfinite(dz)):
                return y, False, "not_finite", it, inc, dec, rmax
            inc = float(np.max(np.abs(dz / self.scale))) if len(dz) else 0.0
            dec = abs(float(R @ dz)) / work
            if inc > WILD:
                return y, False, "diverged", it, inc, dec, rmax
            y = y + dz
            if inc <= tol and dec <= tol:
                return y, True, "converged", it, inc, dec, rmax
            R, J = self._eval(y, lam)
        return y, False, "max_iter", max_iter, inc, dec, rmax

    def solve(self, x_start: np.ndarray, tol: float, max_iter: int = 30):
        """Continuation in lam (the current's scale, and the fairleads' way from the reference if move_drives) from
        x_start."""
        y = self._y(x_start)
        if self.m:  # the start's multipliers by least squares, (G E)' mu = -E' R: a bilinear row's curvature mu
            R0, J0 = self._eval(y, 0.0)  # Hess(phi) is the stiffness of what it constrains (a body's turn)
            ny = self.ny
            GEt = J0[:ny, ny:].toarray()
            y[ny:] = np.linalg.lstsq(GEt, -R0[:ny], rcond=None)[0]
        R1, _ = self._eval(y, 1.0)
        R0, _ = self._eval(y, 0.0)
        f_lin = self.E.T @ self.asm.constant_force()
        ny = self.ny  # (the load work on the coordinates' rows)
        work = float(np.sum((np.abs(f_lin) + np.abs(R1[:ny] - R0[:ny])) * self.scale[:ny])) or 1.0
        lam, step, iters, hist = 0.0, 1.0, 0, []
        while lam < 1.0:
            target = min(1.0, lam + step)
            last = target == 1.0
            y_try, ok, status, it, inc, dec, rmax = self.newton(y, target, tol if last else STEP_TOL,
                                                                max_iter if last else STEP_ITER, work)
            iters += it
            if ok and self.stable_at(y_try, target) is False:  # (full Newton steps from far can end on a saddle:
                ok, status = False, "unstable"  # a shorter continuation step starts nearer the stable branch)
            if ok and self.energy_rise(y, y_try, target) > (tol if last else STEP_TOL) * work:
                ok, status = False, "energy_rise"  # (or on a tangled, stretched state: see energy_rise)
            hist.append((target, status, it))
            if ok:
                y, lam = y_try, target
                step = min(1.0, 2 * step) if it <= 10 else step
            else:
                step /= 2
                if step < MIN_STEP:
                    return self.x_of(y, lam), False, "continuation_failed", iters, hist, (inc, dec, rmax)
        self.mu = y[self.ny:].copy()
        return self.x_of(y), True, "converged", iters, hist, (inc, dec, rmax)

    def energy_rise(self, y0: np.ndarray, y1: np.ndarray, lam: float) -> float:
        """How far the conservative potential at lam rises from the step's feasible start (y0's coordinates, the
        fairleads where lam puts them) to its answer y1, beyond twice the drag's work estimate along the straight
        way between them (|Q_d . dx| at both ends): without drag, the dry statics' rule (a minimiser started there
        cannot rightly end higher); the drag can lift it by about the work it does. Full Newton steps from far
        have ended on stable but tangled, stretched states (a kinked rope at +318 kJ where the answer is -1.7 kJ)
        that only this tells apart."""
        x0, x1 = self.x_of(y0, lam), self.x_of(y1, lam)
        e0, q0 = self.merit(x0, lam)
        e1, q1 = self.merit(x1, lam)
        dx = x1 - x0
        drag = abs(float(np.asarray(q0).ravel() @ dx)) + abs(float(np.asarray(q1).ravel() @ dx))
        return float(e1) - float(e0) - 2.0 * drag

    def _roots(self) -> np.ndarray:
        E = self.E.tocsc()
        return E.indices[E.indptr[:-1]]

    def support_forces(self, x: np.ndarray) -> np.ndarray:
        """Full vector: the structure's forces on the supports and drives at x, the sign every statics result reports
        (docs/scenes.md): minus the residual R_full at the held coordinates, which is the support's force on it."""
        R = np.asarray(self.full(x, 1.0, self.mu)[0]).ravel()
        out = np.zeros_like(R)
        out[self.fixed] = -R[self.fixed]
        return out

    def stability(self, x: np.ndarray) -> bool | None:
        """The symmetric part of the Jacobian positive definite on the tangent space of the multiplier rows."""
        return self.stable_at(self._y(x), 1.0)

    def stable_at(self, y: np.ndarray, lam: float) -> bool | None:
        """stability() at the reduced unknowns y and continuation parameter lam."""
        _, J = self._eval(y, lam)
        ny = self.ny
        Jyy = J[:ny, :ny]
        return reduced_inertia(0.5 * (Jyy + Jyy.T), J[ny:, :ny] if self.m else None).stable

    def _y(self, x):
        return np.r_[np.asarray(x)[self._roots()], self.mu]


def conservative_start_scene(scene):
    """The scene without current and drives: the fairleads pinned at their reference positions."""
    s = copy.copy(scene)
    s.water = copy.copy(scene.water)
    s.water.current = None
    s.drives = []
    s.supports = list(scene.supports)
    s.contacts = list(scene.contacts)
    for d in scene.drives:
        if type(d).__name__ == "PositionDrive" and d.member is not None:
            s.pin(d.member, at=d.at)
    s.water_start = True  # (solve_static solves this one itself: no water line, no drag)
    return s


def solve_in_water(scene, opts, warm_start=None, *, solve_static, result_type):
    """StaticResult of a scene in water (see the module docstring). solve_static and result_type: the statics'
    own solver (for the conservative start) and its result class, passed in by StaticProblem.solve (this module
    stands below it)."""
    StaticResult = result_type

    t0 = time.perf_counter()
    ws = WaterStatics(scene)
    attempts = []
    if warm_start is None:
        ws.move_drives = True  # (the start has the fairleads at the reference)
        first = solve_static(conservative_start_scene(scene), opts)
        attempts += [dict(a, method="start: " + a.get("method", "?")) for a in first.attempts]
        if not first.success:
            return StaticResult(first.status, False, first.iterations, time.perf_counter() - t0, first.x, None,
                                attempts, ws.asm, "")
        x_start, it0 = first.x, first.iterations
    else:
        x_start, it0 = np.asarray(warm_start, float), 0
    x, ok, status, iters, hist, (inc, dec, rmax) = ws.solve(x_start, opts.tol)
    attempts.append({"method": "water newton", "status": status, "iterations": iters,
                     "detail": f"continuation steps (lam, status, iterations): {hist}"})
    stable = ws.stability(x) if ok else None
    res = StaticResult("Solve_Succeeded" if ok else status, ok, it0 + iters, time.perf_counter() - t0,
                       x if np.all(np.isfinite(x)) else ws.asm.x0, stable, attempts, ws.asm,
                       "water newton" if ok else "",
                       _work_out=functools.partial(_details, ws, x))
    res.increment, res.energy_decrement, res.residual = inc, dec, rmax
    res.water = ws
    return res


def _details(ws: WaterStatics, x: np.ndarray) -> tuple[dict, dict, float]:
    asm = ws.asm
    ev = asm.evaluate(x, hessian=False)
    energies = dict(ev.energies)
    if ws.water_line is not None:  # (the buoyancy lost where a section leaves the water: a load potential, with
        energies["gravity"] = energies.get("gravity", 0.0) + float(ws.water_line(x))  # the weight it corrects)
    F = ws.support_forces(x)
    forces: dict = {}
    if asm.exact.m:  # every row's multiplier, as the dry statics report them: J' lam = -(grad Pi - Q_water) on the
        r = np.asarray(ws.full(x, 1.0, np.zeros(ws.m))[0]).ravel()  # rows' coordinates (the rows the reduced
        J = asm.exact.jacobian(x).tocsc()  # coordinates eliminate, e.g. a joint's identified positions, included)
        cols = np.unique(J.tocsr().indices)
        lam = np.linalg.lstsq(J[:, cols].toarray().T, -r[cols], rcond=None)[0]
        for lbl, v in zip(asm.exact.labels, lam):
            forces.setdefault(lbl, []).append(float(v))
    for name, dofs in ws.drive_labels:
        forces[name] = [float(F[i]) for i in dofs]
    viol = float(np.max(np.abs(asm.constraints.value(x)))) if asm.constraints.m else 0.0
    return energies, forces, viol
