"""Re-simulation: the optimal controls run through the dynamics integrator in the frame of the moved support,
compared with the collocation trajectory (mismatch, residual swing after T)."""
from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Callable

import numpy as np

from ancf_sym.util.checks import number as _num
from ancf_sym.scene.builder import SceneError
from ancf_sym.control.ingredients import PointForce
from ancf_sym.control.view import ControlProblemView, ControlResultView



@dataclass
class ResimulationReport:
    success: bool
    status: str
    t: np.ndarray  # output times [s]
    payload: np.ndarray | None  # (len, dim) absolute position of the tracked point (first point mass or cable end)
    support: np.ndarray  # (len, nc) support displacements
    mismatch_m: float | None  # max |tracked point (simulation) - (collocation)| over [0, T] [m]
    mismatch_q: float | None  # max |free coordinates (sim) - (collocation)| at the node times [m, -]
    residual_swing_m: float | None  # max offset of the tracked point from its end equilibrium along the moved
    # axes (the payload's horizontal offset from below the trolley) over [T, T + after] [m]
    residual_motion_m: float | None  # the same as a distance (all directions) [m]
    after: float
    dt: float
    integrator: str
    wall_s: float
    q_free_at: Callable | None = None  # t -> free coordinates (absolute), by interpolation of the outputs
    v_free_at: Callable | None = None  # t -> their velocities (differences of the outputs: for warm starts)
    message: str = ""

    def to_dict(self) -> dict:
        return {"success": self.success, "status": self.status, "mismatch_m": self.mismatch_m,
                "mismatch_q": self.mismatch_q, "residual_swing_m": self.residual_swing_m,
                "residual_motion_m": self.residual_motion_m, "after": self.after,
                "dt": self.dt, "integrator": self.integrator, "wall_s": self.wall_s}


def moving_frame_ok(p: ControlProblemView) -> bool:
    """The re-simulation runs the scene in the frame of the moved support: valid when it is the scene's only
    support that fixes positions (elastic energies are translation invariant, the constant loads unchanged)."""
    if not p.nc:
        return True
    supports = {(s.member, p.asm.mesh.members[s.member].node(s.at)) for s in p.scene.supports
                if s.kind in ("pin", "clamp")}
    moved = set(p.chan_support)
    return supports == moved and len(moved) == 1


def tracked_point(p: ControlProblemView):
    if p.asm.point_masses:
        pm = p.asm.point_masses[0]
        return pm.member, pm.at
    return next(iter(p.scene.members)), "end"


def resimulate_motion(p: ControlProblemView, T: float, motion: Callable, res: ControlResultView | None,
                      dt: float | None = None, after: float | None = None, integrator: str = "radau", **dyn_kw) -> ResimulationReport | None:
    """Run ancf_sym.dynamics.simulate on the ControlAssembly in the frame of the moved support: the support's
    translation s(t) enters as the d'Alembert force -M_full Tr s''(t) (the cables' mass as 2-point Gauss point
    forces per element, exact for the cubic shape functions; the point masses as point forces), controlled forces
    as time loads. Returns None if the scene does not allow the moving frame.

    With a result `res`, the step divides the collocation interval (dt <= the given or T/400) and the load history
    holds both one-sided limits of the controls at every interval joint and at T (the optimal acceleration jumps
    there): Radau IIA's stages lie in (t, t + dt], so no step sees a joint from the wrong side. Trapezoidal-type
    schemes (Newmark, generalized-alpha) smear such a jump over one step: a swing error of order jump x dt /
    omega, which they show as a residual swing that shrinks with dt."""
    from ancf_sym.dynamics import DynamicOptions, TimeLoad, simulate
    if not moving_frame_ok(p):
        return None
    omega = p.modes[0]
    w1 = omega[omega > 1e-9 * max(omega.max(), 1.0)]
    period = 2 * np.pi / w1[0] if len(w1) else T
    after = 3 * period if after is None else _num("after", after, nonneg=True)
    dt_target = T / 400 if dt is None else _num("dt", dt, positive=True)
    t_end = T + after
    eps = 1e-9 * T
    if res is not None:
        h = T / p.K
        m = max(1, int(math.ceil(h / dt_target - 1e-9)))
        dt = h / m
        tau = np.linspace(0.0, 1.0, m + 1)
        th, uh = [], []
        for k in range(p.K):
            tk = (k + tau) * h
            if k:
                tk[0] += eps  # right limit at the joint; the previous interval gave the left one
            th.append(tk)
            uh.append(res.control_in_interval(k, tau))
        th.append(np.array([T + eps, max(t_end, T + 2 * eps)]))
        uh.append(np.zeros((2, p.nu)))
        th, uh = np.concatenate(th), np.concatenate(uh)
        acc = uh[:, :p.nc]
    else:
        dt = dt_target
        th = np.linspace(0.0, t_end, max(int(math.ceil(t_end / dt)) + 1, 2))
        acc = np.asarray(motion(th)[2]).reshape(len(th), p.nc)
        acc[th > T] = 0.0
        uh = np.c_[acc, np.zeros((len(th), p.nF))]
    loads = []
    dim = p.scene.dim
    if p.nc:
        for mm in p.asm.mesh.members.values():
            m = mm.member
            rhoA = m.material.density * m.section.area
            starts = np.r_[0.0, np.cumsum(mm.elem_length)[:-1]]
            for e, L in enumerate(mm.elem_length):
                for gp in (0.5 - 0.5 / math.sqrt(3), 0.5 + 0.5 / math.sqrt(3)):
                    at = float(min(starts[e] + gp * L, m.length))
                    for k, ax in enumerate(p.chan_axis):
                        F = np.zeros(dim)
                        F[ax] = -rhoA * L / 2
                        loads.append(TimeLoad(m.name, at, F, np.c_[th, acc[:, k]]))
        for pm in p.asm.point_masses:
            for k, ax in enumerate(p.chan_axis):
                F = np.zeros(dim)
                F[ax] = -pm.mass
                loads.append(TimeLoad(pm.member, pm.at, F, np.c_[th, acc[:, k]]))
    if p.nF:
        uf = uh[:, p.nc:]
        for k, c in enumerate([c for c in p.controls if isinstance(c, PointForce)]):
            d = np.asarray(c.direction, float)
            loads.append(TimeLoad(c.member, c.at, d / np.linalg.norm(d), np.c_[th, uf[:, k]]))
    # initial state in the moving frame
    s0 = p.chan_vector(p.start_values)
    if res is not None:
        q0f, v0f = res.q_free[0], res.v_free[0]
    else:
        q0f, v0f = p.q_start, np.zeros(p.nf)
    sv0 = res.Z[0, 2 * p.nf + p.nc:] if res is not None else np.zeros(p.nc)
    x0 = p.full(q0f, s0) - p.Tr @ s0
    v0 = p.part.E @ v0f + (p.B - p.Tr) @ sv0
    # outputs: node times of the collocation grid and a fine grid
    t_out = np.unique(np.r_[np.linspace(0, t_end, int(math.ceil(t_end / dt)) + 1),
                            p.node_times(T)[p.node_times(T) <= t_end]])
    sensors = []
    for name, mm in p.asm.mesh.members.items():
        for node in range(len(mm.public_nodes)):
            sensors.append({"name": f"{name}#{node}", "kind": "coordinates", "member": name, "at": node})
    mem, at = tracked_point(p)
    sensors.append({"name": "tracked", "kind": "position", "member": mem, "at": at})
    opts = DynamicOptions(dt=dt, t_end=t_end, integrator=integrator, output_times=t_out, sensors=sensors,
                          loads=loads, q0=x0, v0=v0, **dyn_kw)
    t0 = time.perf_counter()
    try:
        dyn = simulate(p.asm, opts)
    except SceneError as exc:
        return ResimulationReport(False, f"dynamics refused: {exc}", np.zeros(0), None, np.zeros((0, p.nc)), None,
                                  None, None, None, after, dt, integrator, time.perf_counter() - t0, None, None, str(exc))
    wall = time.perf_counter() - t0
    t = dyn.t
    S, _, _ = motion(t)
    S = np.asarray(S).reshape(len(t), p.nc)
    S[t > T] = np.asarray(motion(np.array([T]))[0]).reshape(1, p.nc)
    shift = (p.Tr @ S.T).T  # (len, n) translation of every coordinate
    X = np.zeros((len(t), p.n))
    for name, mm in p.asm.mesh.members.items():
        for node in range(len(mm.public_nodes)):
            X[:, mm.node_dofs(mm.node(node))] = dyn.sensors[f"{name}#{node}"]
    X += shift
    track = dyn.sensors["tracked"] + S @ np.array([np.eye(dim)[ax] for ax in p.chan_axis]).reshape(p.nc, dim) \
        if p.nc else dyn.sensors["tracked"]
    qf = X[:, p.part.roots]

    vf = np.gradient(qf, t, axis=0) if len(t) > 2 else np.zeros_like(qf)

    def q_free_at(tt):
        tt = np.atleast_1d(np.asarray(tt, float))
        return np.column_stack([np.interp(tt, t, qf[:, i]) for i in range(p.nf)])

    def v_free_at(tt):
        tt = np.atleast_1d(np.asarray(tt, float))
        return np.column_stack([np.interp(tt, t, vf[:, i]) for i in range(p.nf)])

    mismatch = mismatch_q = None
    idx, wts = p.probe(mem, at)
    if res is not None:
        during = t <= T + 1e-12
        ref = res.point(mem, at, t[during])
        mismatch = float(np.max(np.linalg.norm(track[during] - ref, axis=1)))
        tn = p.node_times(T)
        qn = q_free_at(tn)
        mismatch_q = float(np.max(np.abs(qn - res.q_free)))
    x_end = p.full(p.q_end, p.chan_vector(p.end_values))
    r_end = np.array([x_end[row] @ wts for row in idx])
    post = t >= T - 1e-12
    swing = motion_ = None
    if np.any(post):
        dev = track[post] - r_end
        axes = sorted(set(p.chan_axis)) or [0]
        swing = float(np.max(np.abs(dev[:, axes])))
        motion_ = float(np.max(np.linalg.norm(dev, axis=1)))
    return ResimulationReport(dyn.success, dyn.status, t, track, S, mismatch, mismatch_q, swing, motion_, after, dt,
                              integrator, wall, q_free_at, v_free_at, dyn.message)
