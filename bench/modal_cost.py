"""Modal analysis cost: the lowest 10 modes of a prestressed cable (2D, 100 m between two pins, tension 50 kN as a
prestrain, sagging under gravity, EI = 24 N m^2, Biot strain), n elements; against Exudyn's ComputeODE2Eigenvalues on
the same model (ANCFCable2D: the same strain |r'| - 1, physicsReferenceAxialStrain = -prestrain, mass per chord
length rho A / (1 + prestrain)), its static solve first, its state copied to the initial one.

Timed (wall, one cold run each: a new scene and problem):
- ancf: modal_analysis(scene, modes=10) whole (validation, assembly, statics, linearize, shift-invert Lanczos), and
  its parts: statics (StaticProblem built + solved), linearize, eigen (lowest_modes);
- exudyn: build + Assemble, SolveStatic, ComputeODE2Eigenvalues(useSparseSolver=True, numberOfEigenvalues=10,
  constrainedCoordinates = the pinned ones). Exudyn exports M and K as dense matrices (its docstring: "intermediate
  matrices may become huge for more than 5000 coordinates"): 10 000 elements (40 004 coordinates) would need two
  12.8 GB matrices, so it is skipped above --exudyn-max elements.
The frequencies of both are compared (max relative difference of the 10).

Run: python bench/modal_cost.py [--sizes 1000 10000] [--exudyn-max 2000]
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from ancf_sym import Material, Scene, Section, linearize, modal_analysis
from ancf_sym import statics
from ancf_sym.modal.eigen import lowest_modes
from ancf_sym.statics import StaticProblem
from statics_vs_exudyn import static_settings  # (bench/ is the script's folder, on sys.path)

L, A, RHO, E, T, EI, G = 100.0, 1e-3, 1000.0, 2.4e10, 5e4, 24.0, 9.81
P = T / (E * A)  # prestrain


def scene(n: int) -> Scene:
    s = Scene(dim=2, gravity=(0.0, -G))
    s.member("cable", [(0, 0), (L, 0)], n, Material(E=E, density=RHO), Section(area=A, I=EI / E), axial="biot",
             prestrain=P)
    s.pin("cable", "start")
    s.pin("cable", "end")
    return s


def ancf(n: int) -> dict:
    statics._CACHE.clear()
    t0 = time.perf_counter()
    r = modal_analysis(scene(n), modes=10)
    total = time.perf_counter() - t0
    s = scene(n)
    t0 = time.perf_counter()
    prob = StaticProblem(s)
    st = prob.solve()
    t1 = time.perf_counter()
    lin = linearize(s, st, damping_matrix=False, problem=prob)
    t2 = time.perf_counter()
    lowest_modes(lin.K, lin.M, lin.G, 10)
    t3 = time.perf_counter()
    return {"total": total, "statics": t1 - t0, "linearize": t2 - t1, "eigen": t3 - t2, "f": r.frequencies,
            "method": r.method, "success": r.success}


def exudyn(n: int) -> dict:
    import exudyn as exu
    from exudyn.itemInterface import (LoadMassProportional, MarkerBodyMass, NodePoint2DSlope1,
                                      ObjectANCFCable2D)
    t0 = time.perf_counter()
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    nodes = [mbs.AddNode(NodePoint2DSlope1(referenceCoordinates=[L * i / n, 0, 1, 0])) for i in range(n + 1)]
    for i in range(n):
        o = mbs.AddObject(ObjectANCFCable2D(nodeNumbers=[nodes[i], nodes[i + 1]], length=L / n,
                                            massPerLength=RHO * A / (1 + P), bendingStiffness=EI,
                                            axialStiffness=E * A, physicsReferenceAxialStrain=-P))
        mbs.AddLoad(LoadMassProportional(markerNumber=mbs.AddMarker(MarkerBodyMass(bodyNumber=o)),
                                         loadVector=[0, -G, 0]))
    fixed = [0, 1, 4 * n, 4 * n + 1]  # the pinned positions (node coordinates x, y, x', y')
    for c in fixed:  # static solve: the pins as coordinate constraints to the ground
        from exudyn.itemInterface import CoordinateConstraint, MarkerNodeCoordinate, NodePointGround
        ng = mbs.AddNode(NodePointGround(referenceCoordinates=[0, 0, 0]))
        mg = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=ng, coordinate=0))
        mbs.AddObject(CoordinateConstraint(markerNumbers=[mg, mbs.AddMarker(
            MarkerNodeCoordinate(nodeNumber=nodes[c // 4 if c < 4 else n], coordinate=c % 4))]))
    mbs.Assemble()
    ss = static_settings(exu)
    t1 = time.perf_counter()
    try:
        exu.SolveStatic(mbs, ss)
    except exu.SolverError:  # (measured at 4000 elements, with 1 and with 10 load steps)
        return {"failed": "SolveStatic did not converge"}
    t2 = time.perf_counter()
    state = mbs.systemData.GetSystemState()
    mbs.systemData.SetSystemState(state, exu.ConfigurationType.Initial)
    t3 = time.perf_counter()
    w2, _ = mbs.ComputeODE2Eigenvalues(ss, useSparseSolver=True, numberOfEigenvalues=10,
                                       constrainedCoordinates=fixed, ignoreAlgebraicEquations=True)
    t4 = time.perf_counter()
    return {"build": t1 - t0, "statics": t2 - t1, "eigen": t4 - t3, "total": t4 - t0,
            "f": np.sqrt(np.abs(np.sort(w2))) / (2 * np.pi)}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--sizes", type=int, nargs="+", default=[1000, 10000])
    ap.add_argument("--exudyn-max", type=int, default=2000)
    a = ap.parse_args()
    print("| elements | ancf modal_analysis [s] | statics / linearize / eigen [s] | exudyn build / static / eigen "
          "[s] | exudyn total [s] | ratio ancf/exudyn (total; eigen) | max rel. freq. difference |")
    print("|---|---|---|---|---|---|---|")
    for n in a.sizes:
        r = ancf(n)
        row = f"| {n} | {r['total']:.3f} | {r['statics']:.3f} / {r['linearize']:.3f} / {r['eigen']:.3f} |"
        x = exudyn(n) if n <= a.exudyn_max else None
        if x is not None and "failed" in x:
            row += f" {x['failed']} | - | - | - |"
        elif x is not None:
            d = float(np.max(np.abs(r["f"] / x["f"] - 1)))
            row += (f" {x['build']:.3f} / {x['statics']:.3f} / {x['eigen']:.3f} | {x['total']:.3f} | "
                    f"{r['total'] / x['total']:.3f}; {r['eigen'] / x['eigen']:.4f} | {d:.2e} |")
        else:
            row += " skipped (dense export) | - | - | - |"
        print(row, flush=True)
        print("   ancf f [Hz]:", np.array2string(r["f"], precision=6), r["method"])
        if x is not None and "f" in x:
            print("   exudyn f [Hz]:", np.array2string(x["f"], precision=6))


if __name__ == "__main__":
    main()
