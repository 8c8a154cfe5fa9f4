"""Optimal control of cable scenes by direct collocation, solved with IPOPT (exact sparse Hessian).

    from ancf_sym.control import ControlProblem, SupportMotion, PointMass, Effort
    ocp = ControlProblem(scene, controls=[SupportMotion("cable", "start", axes=(0,), name="trolley")],
                         horizon=4.0, point_masses=[PointMass("cable", "end", 100.0)], cost=[Effort()],
                         end={"trolley.position": 2.0}, bounds={"trolley.acceleration": (-2, 2)},
                         intervals=20, stages=3, scheme="radau")
    res = ocp.solve()                 # warm start: the collocation simulation of a quintic rest-to-rest motion
    res.status, res.cost, res.iterations, res.wall_s
    check = res.resimulate()          # the dynamics integrator on the optimal controls
    check.mismatch_m, check.residual_swing_m

Dynamics. The scene's free coordinates q (supports and hinges eliminated as in the dynamics module) obey

    M_ff q'' + M_fc s'' + grad_f U(E q + c + B s) - f_lin - B_f F = 0

where s are the displacements of controlled supports (states s, s'; control s'' = acceleration), F the magnitudes
of controlled point forces, M the mass matrix with the point masses added and f_lin the constant forces (gravity of
the cables and of the point masses, dead loads). Only grad U is nonlinear.

Transcription. K intervals of length h = T/K, each an implicit Runge-Kutta step of Radau IIA or Gauss-Legendre
with s stages (equivalent to collocation with the polynomial through tau = 0 and the points c_j). Variables per
interval: the start velocity v_k, the stage positions Q_kj (Radau: the last stage is the next interval's start
position), the support states at the start and the stages, the controls at the stages (or one per interval,
control_form="constant"). With W = A^-1 the stage velocities and accelerations are linear, V = W (Q - q_k) / h,
a = W (V - v_k) / h, and per stage the dynamics residual above is a constraint; continuity of v (and, for Gauss,
of q) by the quadrature weights b. The tableaus and these condensed stage equations are those of the dynamics
integrator (ancf_sym.dynamics.collocation: stage_residual, interval_end), written for all intervals at once. This
condensed form has about half the variables of the state-per-node form, and its KKT matrix factorises ~4x faster
(measured fill 1.8M vs 6.8M at n = 8, K = 40).

Warm start: the same collocation equations (stage_residual, stage_tangent) integrated interval by interval (Newton
on their exact sparse Jacobian) for a quintic rest-to-rest support motion, so IPOPT starts with every dynamics row
satisfied.

Derivatives. grad U at all collocation points is one mapped call per energy term. IPOPT gets its Jacobian from the
kernel Hessians and the Lagrangian Hessian from the kernels' third-derivative companions (load_hvp: d(H v)/dq with
v = the multipliers of the dynamics rows mapped to element coordinates), both assembled through constant sparse
matrices; everything else (collocation, continuity, costs, path constraints: linear or polynomial) is
differentiated by CasADi. No finite differences.

Package layout (one part per module, composed rather than inherited): ingredients (controls, payloads, costs, path
constraints), options (ControlOptions: grid, scheme, horizon, costs, IPOPT settings, checked once), model
(ControlModel: the reduced coordinates, channels, forces, equilibria and modes), bounds (Bounds: bounds and boundary
values; the path rows and the cost as NLP pieces), transcription (Transcription: the layout of the decision vector,
the collocation NLP part by part and its exact derivatives, pack/unpack), warm_start (WarmStart: the collocation
simulation), problem (ControlProblem: composes the parts, forwards their public names, runs IPOPT), result
(ControlResult), resimulation (the dynamics integrator on the optimal controls).
"""
from __future__ import annotations

from ancf_sym.control.model import StateView
from ancf_sym.control.ingredients import Effort, MinimumTime, PathConstraint, PointForce, PointMass, SupportMotion, Swing
from ancf_sym.control.model import ControlAssembly, ControlModel
from ancf_sym.control.options import ControlOptions
from ancf_sym.control.problem import ControlProblem
from ancf_sym.control.resimulation import ResimulationReport, moving_frame_ok, resimulate_motion, tracked_point
from ancf_sym.control.result import ControlResult

__all__ = ["ControlProblem", "ControlResult", "ControlAssembly", "ControlModel", "ControlOptions", "PointMass",
           "SupportMotion", "PointForce", "Effort", "MinimumTime", "Swing", "PathConstraint", "StateView",
           "ResimulationReport", "resimulate_motion", "moving_frame_ok", "tracked_point"]
