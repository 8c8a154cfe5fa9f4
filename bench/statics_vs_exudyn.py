"""Statics against Exudyn's static solver, in one script: paper 000's cantilever (L = 3 m, A = 7.854e-5 m^2,
I = 4.909e-10 m^4, rho = 7200, gravity, clamped), E = 20 GPa and 1 GPa, n elements.

Timed (wall, min / median over repeats):
- ancf solve: StaticProblem.solve() on a problem built once for the scene (what a repeated solve costs);
- ancf new scene: Scene built, the problem cache cleared, solve_static (assembly, Newton graph, solve): cold;
  and the same with the cache kept (a new Scene object with the same content: the problem is reused): warm;
- exudyn solve: SolveStatic with one load step (EigenSparse, full Newton); exudyn build: the model built,
  Assemble, SolveStatic.
The ancf tip is checked against the discrete solution by four more Newton steps (tip_err); Exudyn's cable is its
own formulation, so its tip is printed, not compared.

Run: python bench/statics_vs_exudyn.py [--quick] [--sizes 60 600 ...] [--no-exudyn-above 6000]
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time

import numpy as np

from ancf_sym import Material, Scene, Section, solve_static
from ancf_sym import statics
from ancf_sym.statics import StaticProblem

G, L, A, I, RHO = 9.81, 3.0, 7.854e-5, 4.909e-10, 7200.0


def scene(n: int, axial: str, E: float) -> Scene:
    s = Scene(dim=2, gravity=(0, -G))
    s.member("beam", [(0, 0), (L, 0)], n, Material(E=E, density=RHO), Section(area=A, I=I), axial=axial)
    s.clamp("beam", "start")
    return s


def timed(fn, repeats: int):
    ts, out = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        ts.append(time.perf_counter() - t0)
    return min(ts), statistics.median(ts), out


def tip_error(p: StaticProblem, r) -> float:
    p.newton.solve(r.x, 1e-300, 4, p.work)
    x = p.S.full(p.newton.x)
    mm = p.asm.mesh.members["beam"]
    tip = p.asm.member_coordinates(x, "beam")[mm.public_nodes[-1], :2]
    return float(np.linalg.norm(tip - r.tip("beam")))


def static_settings(exu):
    """Exudyn's static solver as these benches run it: full Newton, sparse solver, no files, no printing."""
    ss = exu.SimulationSettings()
    ss.staticSolver.newton.useModifiedNewton = False
    ss.staticSolver.verboseMode = 0
    ss.linearSolver.solverType = exu.LinearSolverType.EigenSparse
    ss.solution.file.write = False
    ss.displayStatistics = False
    ss.displayComputationTime = False
    return ss


def exudyn_static(n: int, E: float):
    """(wall of SolveStatic, wall of build + Assemble + SolveStatic, tip, converged)."""
    import exudyn as exu
    from exudyn.itemInterface import (CoordinateConstraint, LoadMassProportional, MarkerBodyMass,
                                      MarkerNodeCoordinate, NodePoint2DSlope1, NodePointGround, ObjectANCFCable2D)
    t0 = time.perf_counter()
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    nodes = [mbs.AddNode(NodePoint2DSlope1(referenceCoordinates=[L * i / n, 0, 1, 0])) for i in range(n + 1)]
    for i in range(n):
        o = mbs.AddObject(ObjectANCFCable2D(nodeNumbers=[nodes[i], nodes[i + 1]], length=L / n,
                                            massPerLength=RHO * A, bendingStiffness=E * I, axialStiffness=E * A))
        mbs.AddLoad(LoadMassProportional(markerNumber=mbs.AddMarker(MarkerBodyMass(bodyNumber=o)),
                                         loadVector=[0, -G, 0]))
    ng = mbs.AddNode(NodePointGround(referenceCoordinates=[0, 0, 0]))
    mg = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=ng, coordinate=0))
    for k in (0, 1, 3):
        mbs.AddObject(CoordinateConstraint(markerNumbers=[mg, mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=nodes[0],
                                                                                                    coordinate=k))]))
    mbs.Assemble()
    ss = static_settings(exu)
    ss.staticSolver.numberOfLoadSteps = 1
    t1 = time.perf_counter()
    ok = True
    try:
        exu.SolveStatic(mbs, ss)
    except Exception:  # noqa: BLE001 (Exudyn raises on divergence)
        ok = False
    t2 = time.perf_counter()
    tip = np.asarray(mbs.GetNodeOutput(nodes[-1], exu.OutputVariableType.Position))[:2]
    return t2 - t1, t2 - t0, tip, ok


def case(n: int, axial: str, E: float, repeats: int, exudyn: bool) -> dict:
    p = StaticProblem(scene(n, axial, E))
    s_min, s_med, r = timed(lambda: p.solve(), repeats)
    err = tip_error(p, r)

    def cold():
        statics._CACHE.clear()
        return solve_static(scene(n, axial, E))
    c_min, c_med, _ = timed(cold, repeats)  # as many repeats as Exudyn's build + solve (the min of each)
    solve_static(scene(n, axial, E))
    w_min, w_med, _ = timed(lambda: solve_static(scene(n, axial, E)), repeats)
    row = {"n": n, "axial": axial, "E": E, "status": r.status, "path": r.path, "iters": r.iterations,
           "stable": r.stable, "tip": r.tip("beam"), "tip_err": err, "solve": (s_min, s_med),
           "cold": (c_min, c_med), "warm": (w_min, w_med)}
    if exudyn:
        ex = [exudyn_static(n, E) for _ in range(repeats)]
        row["ex_solve"] = (min(e[0] for e in ex), statistics.median(e[0] for e in ex))
        row["ex_total"] = (min(e[1] for e in ex), statistics.median(e[1] for e in ex))
        row["ex_tip"], row["ex_ok"] = ex[-1][2], ex[-1][3]
    return row


def show(row: dict) -> None:
    ms = lambda t: f"{1e3 * t[0]:.2f}/{1e3 * t[1]:.2f}"
    line = (f"n={row['n']:>6} {row['axial']:<5} E={row['E']:.0e} {row['status']} ({row['path']}, {row['iters']} it, "
            f"stable={row['stable']}) tip=({row['tip'][0]:.6f}, {row['tip'][1]:.6f}) tip_err={row['tip_err']:.1e} m | "
            f"ancf solve {ms(row['solve'])} ms, new scene cold {ms(row['cold'])} warm {ms(row['warm'])} ms")
    if "ex_solve" in row:
        line += (f" | exudyn solve {ms(row['ex_solve'])} ms, build+solve {ms(row['ex_total'])} ms "
                 f"(ok={row['ex_ok']}, tip=({row['ex_tip'][0]:.6f}, {row['ex_tip'][1]:.6f})) | ratios (min): "
                 f"solve {row['solve'][0] / row['ex_solve'][0]:.2f}, cold {row['cold'][0] / row['ex_total'][0]:.2f}, "
                 f"warm {row['warm'][0] / row['ex_total'][0]:.2f}")
    print(line, flush=True)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="fewer repeats, no 100 000")
    ap.add_argument("--sizes", type=int, nargs="*", default=None)
    ap.add_argument("--no-exudyn-above", type=int, default=6000, help="Exudyn diverges at 8000 and 10 000")
    a = ap.parse_args(argv)
    try:
        import exudyn  # noqa: F401
    except ImportError:
        sys.exit("exudyn is not installed: pip install exudyn (a bench extra, never needed by ancf_sym)")
    reps = {60: 20, 600: 7, 2000: 5, 6000: 3, 10_000: 2, 100_000: 1}
    plan = [(60, "biot", 20e9), (60, "green", 20e9), (600, "biot", 20e9), (600, "green", 20e9),
            (2000, "biot", 20e9), (6000, "biot", 20e9), (6000, "green", 20e9), (60, "biot", 1e9),
            (60, "green", 1e9), (600, "biot", 1e9), (600, "green", 1e9), (10_000, "biot", 20e9),
            (10_000, "green", 20e9), (100_000, "biot", 20e9), (100_000, "green", 20e9)]
    if a.sizes:
        plan = [p for p in plan if p[0] in a.sizes]
    if a.quick:
        plan = [p for p in plan if p[0] < 100_000]
    rows = []
    for n, axial, E in plan:
        r = reps[n] if not a.quick else max(1, reps[n] // 3)
        rows.append(case(n, axial, E, r, n <= a.no_exudyn_above))
        show(rows[-1])
    for axial in ("biot", "green"):
        big = {row["n"]: row["solve"][0] for row in rows if row["axial"] == axial and row["E"] == 20e9}
        if 10_000 in big and 100_000 in big:
            print(f"linearity ({axial}): solve(100 000) / solve(10 000) = {big[100_000] / big[10_000]:.1f} "
                  "(linear: 10)")


if __name__ == "__main__":
    main()
