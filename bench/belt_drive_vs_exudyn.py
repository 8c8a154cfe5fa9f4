"""Cost per step of a belt drive: ancf_sym's belt scene (examples/belt_drive.py) against Exudyn's belt drive set-up
with ObjectContactFrictionCircleCable2D, the same physics where the two codes' laws allow, in this one script.

Scene (both codes): pulleys r_driver = 0.1 m at the origin and r_driven = 0.15 m at 0.5 m, rigid bodies of 1 kg
on revolute joints (Exudyn: NodeRigidBody2D with x, y coordinate constraints), a closed belt of n cable elements
(EA = 1e5 N, rho A = 0.1 kg/m, EI = 0.1 N m^2, axial strain-rate damping 20 N s, prestrain 0.5 %; Exudyn:
CreateReevingCurve + PointsAndSlopes2ANCFCable2D with firstNodeIsLastNode, physicsReferenceAxialStrain = -0.005),
the driver's angular velocity ramped smoothly from rest to 20 rad/s in 0.2 s (ancf_sym: Scene.drive, an exact row
with per-step time inputs; Exudyn: a velocity-level CoordinateConstraint with a Python offsetUserFunction_t, its
own set-up), the driven pulley against a resisting torque of 20 N m ramped alike (Scene.torque / LoadCoordinate
with a Python loadUserFunction), friction mu = 0.4.
Contact laws: a linear penalty k = 1e8 N/m^2 in both; ancf_sym at 5 Gauss points per element with the regularised
Coulomb law (eps = 1 cm/s, the example's); Exudyn's ObjectContactFrictionCircleCable2D per element and pulley with
4 contact segments, contact stiffness k x the segment length, the friction velocity penalty mu f_n / eps per
segment (f_n the contact pressure at the prestress, so the same viscous slope in the sticking zone), no bristle
stiffness. Exudyn's contact is discontinuous (its solver iterates the contact state per step); ancf_sym's is
smooth (one Newton loop on the exact tangent). ancf_sym starts from the belt settled on the pulleys (statics,
outside the timing); Exudyn from its reeving curve.
Both: generalized-alpha (rho_inf 0.6), fixed dt = 1e-3 s over 0.6 s.

Timing: CPU time of each code's time loop (process time; min and median over --repeats, the codes interleaved),
model set-up separately. The steady speed ratio omega_driven / omega_driver of each run is printed as the check
that both modelled the same drive. Where ancf_sym's time goes: Newton iterations per step and the cost of one
iteration, and the same scene with the friction off (normal law only: the step matrix is then symmetric, but the
drive's rows and the torque keep the QR solve).

Run: python bench/belt_drive_vs_exudyn.py [--repeats 3] [--elements 48] [--json PATH]
"""
from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import sys
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "examples"))
import belt_drive as BD  # noqa: E402  (the example's scene)

from ancf_sym.model.assembly import Assembly  # noqa: E402
from ancf_sym.dynamics import DynamicOptions, simulate  # noqa: E402
from ancf_sym.system.graph_cache import clear_graph_cache  # noqa: E402

R2, OMEGA, TORQUE, T_END, DT = 0.15, 20.0, 20.0, 0.6, 1e-3
K_N = 1e8  # linear penalty [N/m^2], both codes
# the linear law's Newton: Armijo backtracking where a full update neither lowers the residual nor contracts (its
# kink), with the iterations such steps need (12: 5 rejected steps in 600; without the line search 3729 rejected
# sub-steps): automatic for a scene with a linear-law contact (docs/contact.md, "Newton through the kink of the
# linear law"), so both laws run with the default options
KINK_NEWTON: dict = {}


def ramp(t: float) -> float:
    tau = min(t / BD.T_RAMP, 1.0)
    return OMEGA * (3 * tau * tau - 2 * tau**3)


# -- ancf_sym ----------------------------------------------------------------------------------------------------

def ancf_run(n: int, k_n: float | None):
    """ancf_sym's belt drive with the linear penalty k_n (Exudyn's law) or, k_n None, the example's Hertz law."""
    clear_graph_cache()
    t0 = time.perf_counter()
    asm = Assembly(BD.scene(R2, OMEGA, TORQUE, n, k_n=k_n))
    t1 = time.perf_counter()
    q0 = BD.start(asm, R2, n, k_n)
    settle = time.perf_counter() - t1
    opts = DynamicOptions(dt=DT, t_end=T_END, integrator="generalized_alpha", rho_inf=0.6, output_dt=0.01,
                          energies=False, q0=q0, newton=KINK_NEWTON if k_n else {}, sensors=[{"name": b, "kind": "body", "member": b}
                                                          for b in ("driver", "driven")])
    res = simulate(asm, opts)
    setup = time.perf_counter() - t0 - res.wall_s - settle
    late = res.t >= res.t[-1] * 2 / 3
    ratio = float(np.mean(res.sensors["driven"][late, 3]) / np.mean(res.sensors["driver"][late, 3])) \
        if res.success else float("nan")
    c = res.counters
    return dict(cpu=res.cpu_s, wall=res.wall_s, steps=res.steps, setup=setup, settle=settle, ratio=ratio,
                status=res.status, newton=c["newton_iterations"] / max(res.steps, 1),
                us_per_iteration=res.cpu_s / max(c["newton_iterations"], 1) * 1e6,
                residuals=c["residuals"] / max(res.steps, 1), rejected=len(res.rejected))


# -- Exudyn ------------------------------------------------------------------------------------------------------

def exudyn_run(n: int, segments: int = 4):
    import exudyn as exu
    from exudyn.beams import CreateReevingCurve, PointsAndSlopes2ANCFCable2D
    from exudyn.itemInterface import (Cable2D, CoordinateConstraint, LoadCoordinate, MarkerBodyCable2DShape,
                                      MarkerBodyRigid, MarkerNodeCoordinate, NodeGenericData, NodePointGround,
                                      NodeRigidBody2D, ObjectContactFrictionCircleCable2D, ObjectRigidBody2D,
                                      SensorNode)

    t0 = time.perf_counter()
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    circles = [[[0.0, 0.0], BD.R1, "L"], [[BD.D, 0.0], R2, "L"]]
    rc = CreateReevingCurve(circles, numberOfANCFnodes=n, closedCurve=True, drawingLinesPerCircle=64)
    E_I = BD.EA * 1e-6
    template = Cable2D(physicsMassPerLength=BD.RHO_A, physicsBendingStiffness=E_I, physicsAxialStiffness=BD.EA,
                       physicsAxialDamping=BD.EA * 2e-4, physicsReferenceAxialStrain=-BD.PRESTRAIN,
                       useReducedOrderIntegration=0)
    ancf = PointsAndSlopes2ANCFCable2D(mbs, rc["ancfPointsSlopes"], rc["elementLengths"], template,
                                       firstNodeIsLastNode=True)
    cables = ancf[1]
    nG = mbs.AddNode(NodePointGround())
    mG = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=nG, coordinate=0))
    l_seg = rc["totalLength"] / n / segments
    fn = BD.EA * BD.PRESTRAIN / BD.R1  # contact pressure at the prestress [N/m]
    delta0 = fn / K_N  # its penetration: ancf_sym's contact damping c delta per length, c = 1e2
    sensors = []
    for i, ((p, r, _), inertia) in enumerate(zip(circles, (0.5 * BD.R1**2, 0.5 * R2**2))):
        nb = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[p[0], p[1], 0.0]))
        ob = mbs.AddObject(ObjectRigidBody2D(physicsMass=1.0, physicsInertia=inertia, nodeNumber=nb))
        for k in (0, 1):
            mbs.AddObject(CoordinateConstraint(markerNumbers=[mG, mbs.AddMarker(MarkerNodeCoordinate(
                nodeNumber=nb, coordinate=k))]))
        mrot = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=nb, coordinate=2))
        if i == 0:
            mbs.AddObject(CoordinateConstraint(markerNumbers=[mG, mrot], velocityLevel=True,
                                               offsetUserFunction_t=lambda mbs, t, item, off: ramp(t)))
        else:
            mbs.AddLoad(LoadCoordinate(markerNumber=mrot, load=-TORQUE,
                                       loadUserFunction=lambda mbs, t, load: load * ramp(t) / OMEGA))
        sensors.append(mbs.AddSensor(SensorNode(nodeNumber=nb, storeInternal=True,
                                                outputVariableType=exu.OutputVariableType.AngularVelocity)))
        mc = mbs.AddMarker(MarkerBodyRigid(bodyNumber=ob))
        for c in cables:
            mcab = mbs.AddMarker(MarkerBodyCable2DShape(bodyNumber=c, numberOfSegments=segments))
            data = mbs.AddNode(NodeGenericData(initialCoordinates=[0.1] * segments + [-2] * segments
                                               + [0] * segments, numberOfDataCoordinates=3 * segments))
            mbs.AddObject(ObjectContactFrictionCircleCable2D(
                markerNumbers=[mc, mcab], nodeNumber=data, numberOfContactSegments=segments,
                contactStiffness=K_N * l_seg, contactDamping=1e2 * delta0 * l_seg,
                frictionVelocityPenalty=BD.MU * fn * l_seg / BD.EPS, frictionStiffness=0.2 * K_N * l_seg,
                frictionCoefficient=BD.MU, circleRadius=r))
    mbs.Assemble()
    ss = exu.SimulationSettings()
    ss.timeIntegration.numberOfSteps = int(round(T_END / DT))
    ss.timeIntegration.endTime = T_END
    ss.timeIntegration.generalizedAlpha.spectralRadius = 0.6
    ss.timeIntegration.verboseMode = 0
    ss.solutionSettings.writeSolutionToFile = False
    ss.solutionSettings.sensorsWritePeriod = 0.01
    ss.linearSolverType = exu.LinearSolverType.EigenSparse
    ss.displayStatistics = False
    setup = time.perf_counter() - t0
    c0, w0 = time.process_time(), time.perf_counter()
    ok = exu.SolveDynamic(mbs, ss, solverType=exu.DynamicSolverType.GeneralizedAlpha)
    cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    newton = float("nan")
    solver = mbs.sys.get("dynamicSolver") if hasattr(mbs, "sys") else None
    if solver is not None:  # Exudyn keeps its solver (storeSolver, default True): its iteration counters
        newton = solver.it.newtonStepsCount / max(solver.it.currentStepIndex, 1)
    w = [np.asarray(mbs.GetSensorStoredData(s))[:, 3] for s in sensors]
    t = np.asarray(mbs.GetSensorStoredData(sensors[0]))[:, 0]
    late = t >= t[-1] * 2 / 3
    ratio = float(np.mean(w[1][late]) / np.mean(w[0][late]))
    return dict(cpu=cpu, wall=wall, steps=ss.timeIntegration.numberOfSteps, setup=setup, ratio=ratio,
                status="completed" if ok else "failed", newton=newton)


def breakdown(n: int, k_n: float | None, repeats: int = 20) -> dict:
    """Where one full Newton iteration of ancf_sym's step goes, at the settled start state (process time per call,
    min over `repeats` calls of each compiled function): the whole iteration (residual, KKT matrix, sparse QR
    factorisation and solve: sparse LU), the residual alone, the contact damping/friction graph (the drums' dissipation
    kernels and the scatter of their Hessian blocks) and the belt's strain-rate damping graph."""
    import casadi as ca
    from ancf_sym.system import damping
    from ancf_sym.dynamics.schemes import Scheme
    from ancf_sym.system.step_system import StepSystem
    from ancf_sym.util.sparsity import dm

    clear_graph_cache()
    asm = Assembly(BD.scene(R2, OMEGA, TORQUE, n, k_n=k_n))
    S = StepSystem.for_scene(asm, linsol="auto_lu")  # (as a run builds it: ancf_sym.dynamics.run)
    S.x[:] = S.reduce(BD.start(asm, R2, n, k_n))
    S.p[S.nf:] = S.w(T_END / 2)  # the drives' time inputs (all zero would leave the driven angle's row zero)
    sc = Scheme.generalized_alpha(0.6)  # the step coefficients of a run
    S.cm[0], S.cc[0], S.kc[0] = sc.cm(DT), sc.cc(DT), sc.cm(DT) * S.stiffness_scale()
    xf, vf = ca.MX.sym("x", S.nf), ca.MX.sym("v", S.nf)
    X, V = S.x_full_mx(xf), ca.mtimes(dm(S.E), vf)
    contact_f = ca.Function("c", [xf, vf], list(damping.contact_dissipation_mx(S, X, V, ca.MX(S.cc[0]))))
    rate_f = ca.Function("s", [xf, vf], damping.strain_rate_mx(S.strain_rate, xf, X, V, vf, E=S.E,
                                                                cc=ca.MX(S.cc[0])))  # (the step's summed tangent)

    def per_call(f):
        f()
        best = math.inf
        for _ in range(repeats):
            c0 = time.process_time()
            f()
            best = min(best, time.process_time() - c0)
        return best * 1e6

    out = {"iteration_us": per_call(S.iterate), "residual_us": per_call(S.residual),
           "contact_friction_us": per_call(lambda: contact_f(S.x, S.vc)),
           "strain_rate_us": per_call(lambda: rate_f(S.x, S.vc))}
    out["rest_us"] = out["iteration_us"] - out["contact_friction_us"] - out["strain_rate_us"]
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--elements", type=int, default=48)
    ap.add_argument("--json")
    a = ap.parse_args()
    runs = {"ancf_sym Hertz": [], "exudyn": [], "ancf_sym linear": []}
    for _ in range(a.repeats):  # interleaved
        runs["ancf_sym Hertz"].append(ancf_run(a.elements, None))
        runs["exudyn"].append(exudyn_run(a.elements))
        runs["ancf_sym linear"].append(ancf_run(a.elements, K_N))
    rows = []
    for name, rs in runs.items():
        per = [r["cpu"] / r["steps"] * 1e6 for r in rs]
        rows.append(dict(code=name, elements=a.elements, dt=DT, t_end=T_END, cpu_us_step_min=min(per),
                         cpu_us_step_median=statistics.median(per), setup_s=min(r["setup"] for r in rs),
                         speed_ratio=rs[0]["ratio"], status=rs[0]["status"], newton_per_step=rs[0].get("newton"),
                         us_per_iteration=min(r["us_per_iteration"] for r in rs) if "us_per_iteration" in rs[0]
                         else None, rejected=rs[0].get("rejected")))
    base = rows[1]["cpu_us_step_min"]  # exudyn
    print(f"belt drive, {a.elements} elements, dt = {DT}, {T_END} s, r_driver/r_driven = {BD.R1 / R2:.4f}, "
          f"min/median over {a.repeats} repeats (CPU time of the time loop)")
    print(f"{'code':24s} {'min us/step':>12s} {'median':>10s} {'vs exudyn':>10s} {'setup s':>8s} "
          f"{'speed ratio':>12s} {'Newton/step':>12s} {'us/iter':>8s} {'rejected':>8s} status")
    for r in rows:
        nps, upi, rej = r["newton_per_step"], r["us_per_iteration"], r["rejected"]
        print(f"{r['code']:24s} {r['cpu_us_step_min']:12.1f} {r['cpu_us_step_median']:10.1f} "
              f"{r['cpu_us_step_min'] / base:10.2f} {r['setup_s']:8.2f} {r['speed_ratio']:12.4f} "
              f"{'' if nps is None else f'{nps:.2f}':>12s} {'' if upi is None else f'{upi:.0f}':>8s} "
              f"{'' if rej is None else rej:>8} {r['status']}")
    b = breakdown(a.elements, None)
    print(f"one Newton iteration of ancf_sym (Hertz scene), us: whole {b['iteration_us']:.0f} = contact damping + "
          f"friction kernels {b['contact_friction_us']:.0f} + strain-rate damping {b['strain_rate_us']:.0f} + "
          f"the rest (elastic and normal-law kernels, assembly, sparse LU) {b['rest_us']:.0f}; residual alone "
          f"{b['residual_us']:.0f}")
    if a.json:
        with open(a.json, "w") as f:
            json.dump(rows + [dict(code="ancf_sym Hertz, one iteration", elements=a.elements, **b)], f, indent=1)


if __name__ == "__main__":
    main()
