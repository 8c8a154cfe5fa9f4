"""Dynamics speed and accuracy: ancf_sym against Exudyn (generalized-alpha, sparse solver), same physics.

Cases (the speed goal's benchmark): the paper-000 beam pinned and released horizontal (n = 30, dt = 1e-3 s, 2 s) and
the paper-002 soft rope pinned and released (n = 32, dt = 1e-3 s, 1 s); `--clamp` adds the clamped beam (the
paper's own case). Both codes: generalized-alpha with rho_inf = 0.9 (Exudyn's default), dt fixed, planar ANCF
cable (ObjectANCFCable2D / NodePoint2DSlope1 vs cable2d).

Physics matched: Exudyn's cable uses the Biot axial strain |r'| - 1 (ancf_sym axial="biot") and the material
curvature (r' x r'')/|r'|^2 where ancf_sym uses |r' x r''|/|r'|^3 (equal for an inextensible line; they differ
by the factor |r'| = 1 + strain, up to 1e-4 here for the steel beam, ~30 % for the rope, whose bending energy is
~1e-4 of its strain energy); Exudyn integrates the bending term with 3 Gauss points, ancf_sym with 5.

Accuracy: both are compared at 10 ms output times with a reference run of ancf_sym at dt/8 (same physics); the
difference between the two codes and each one's error are printed. Timing: CPU time of the time loop (the
process's time, so other users' load on the shared machine counts less than in wall time) and wall time, both
min and median over --repeats runs, the two codes interleaved: Exudyn's SolveDynamic call, ancf_sym's time loop
as simulate reports it (DynamicResult.cpu_s, wall_s). Model set-up (Exudyn's model building and Assemble;
ancf_sym's Assembly, StepSystem and the integrator's compiled step and chunk functions) is timed separately, and
cpu_total (everything, set-up included) is printed too. Exudyn is a bench extra (`pip install exudyn`); ancf_sym
never imports it.

Run: python bench/dynamics_vs_exudyn.py [--repeats 5] [--clamp] [--json PATH] [--exudyn-modified both]
         [--exudyn-tols 1e-8 1e-4] [--no-energies] [--ancf-modified]
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from ancf_sym import Material, Scene, Section  # noqa: E402
from ancf_sym.model.assembly import Assembly  # noqa: E402
from ancf_sym.dynamics import DynamicOptions, StepSystem, clear_graph_cache, simulate  # noqa: E402

G = 9.81
CASES = {
    "pendulum": dict(L=3.0, A=7.854e-5, I=4.909e-10, rho=7200.0, E=20e9, n=30, dt=1e-3, T=2.0, support="pin"),
    "rope": dict(L=1.2, A=0.0018, I=1.215e-8, rho=5540.0, E=0.7e6, n=32, dt=1e-3, T=1.0, support="pin"),
    "clamped_beam": dict(L=3.0, A=7.854e-5, I=4.909e-10, rho=7200.0, E=20e9, n=30, dt=1e-3, T=2.0, support="clamp"),
}
CASES["pendulum_1000"] = dict(CASES["pendulum"], n=1000, T=0.3)  # a hard transient on a fine mesh
OUT_DT = 0.01


# -- ancf_sym ----------------------------------------------------------------------------------------------------

def ancf_scene(c):
    s = Scene(dim=2, gravity=(0.0, -G))
    s.member("m", [(0.0, 0.0), (c["L"], 0.0)], c["n"], Material(E=c["E"], density=c["rho"]),
             Section(area=c["A"], I=c["I"]), axial="biot")
    (s.clamp if c["support"] == "clamp" else s.pin)("m", "start")
    return s


def ancf_run(c, dt=None, modified=False, energies=True, cold=True, sensors=True):
    """The time loop is timed by simulate itself (DynamicResult.cpu_s / wall_s: initial acceleration, steps,
    outputs); set-up = Assembly + StepSystem + the integrator's step and chunk functions (DynamicResult.setup_s).
    cold: forget the compiled graphs first (a first run of its structure in the process: set-up builds them all,
    but not the kernels and the scene-independent Newton logic, loaded by an earlier run as in any process that
    ran dynamics before); else a structure run before in this process reuses them."""
    if cold:
        clear_graph_cache()
    c0, t0 = time.process_time(), time.perf_counter()
    asm = Assembly(ancf_scene(c))
    system = StepSystem.for_scene(asm)
    setup = time.perf_counter() - t0
    opts = DynamicOptions(dt=dt or c["dt"], t_end=c["T"], integrator="generalized_alpha", rho_inf=0.9,
                          output_dt=OUT_DT, newton={"modified": modified}, energies=energies,
                          sensors=[{"name": "tip", "kind": "position", "member": "m", "at": "end"}] if sensors else [])
    c1 = time.process_time()
    res = simulate(asm, opts, system=system)
    cpu_sim = time.process_time() - c1  # (the time this bench reported before: loop + the integrator's set-up)
    cpu_total, wall_total = time.process_time() - c0, time.perf_counter() - t0
    assert res.status == "completed", res.message
    return {"cpu": res.cpu_s, "wall": res.wall_s, "setup": setup + res.setup_s, "cpu_total": cpu_total,
            "setup_cpu": cpu_total - res.cpu_s,  # (all but the time loop: less sensitive to other users' load)
            "cpu_sim": cpu_sim,
            "wall_total": wall_total, "t": res.t, "tip": res.sensors.get("tip"), "steps": res.steps,
            "newton": res.newton_iterations, "jacobians": res.counters["jacobians"],
            "factorizations": res.factorizations, "residuals": res.counters["residuals"],
            "rejected": len(res.rejected)}


# -- Exudyn ------------------------------------------------------------------------------------------------------

def exudyn_run(c, modified=True, rel_tol=1e-8):
    import exudyn as exu
    from exudyn.itemInterface import (CoordinateConstraint, LoadMassProportional, MarkerBodyMass,
                                      MarkerBodyPosition, MarkerNodeCoordinate, MarkerNodePosition,
                                      NodePoint2DSlope1, NodePointGround, ObjectANCFCable2D, ObjectGround,
                                      ObjectJointRevolute2D, SensorNode)
    c0, t0 = time.process_time(), time.perf_counter()
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    n, L = c["n"], c["L"]
    nodes = [mbs.AddNode(NodePoint2DSlope1(referenceCoordinates=[L * i / n, 0, 1, 0])) for i in range(n + 1)]
    for i in range(n):
        o = mbs.AddObject(ObjectANCFCable2D(nodeNumbers=[nodes[i], nodes[i + 1]], length=L / n,
                                            massPerLength=c["rho"] * c["A"], bendingStiffness=c["E"] * c["I"],
                                            axialStiffness=c["E"] * c["A"]))
        mbs.AddLoad(LoadMassProportional(markerNumber=mbs.AddMarker(MarkerBodyMass(bodyNumber=o)),
                                         loadVector=[0, -G, 0]))
    if c["support"] == "clamp":
        ng = mbs.AddNode(NodePointGround(referenceCoordinates=[0, 0, 0]))
        mg = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=ng, coordinate=0))
        for k in (0, 1, 3):  # x, y and the slope's y component
            mk = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=nodes[0], coordinate=k))
            mbs.AddObject(CoordinateConstraint(markerNumbers=[mg, mk]))
    else:
        ground = mbs.AddObject(ObjectGround())
        mbs.AddObject(ObjectJointRevolute2D(markerNumbers=[
            mbs.AddMarker(MarkerBodyPosition(bodyNumber=ground, localPosition=[0, 0, 0])),
            mbs.AddMarker(MarkerNodePosition(nodeNumber=nodes[0]))]))
    sens = mbs.AddSensor(SensorNode(nodeNumber=nodes[-1], storeInternal=True, writeToFile=False,
                                    outputVariableType=exu.OutputVariableType.Position))
    mbs.Assemble()
    ss = exu.SimulationSettings()
    ti = ss.timeIntegration
    ti.numberOfSteps = int(round(c["T"] / c["dt"]))
    ti.endTime = c["T"]
    ti.generalizedAlpha.spectralRadius = 0.9
    ti.newton.useModifiedNewton = modified
    ti.newton.relativeTolerance = rel_tol
    ti.verboseMode = 0
    ss.solution.file.write = False
    ss.solution.sensors.writePeriod = OUT_DT
    ss.linearSolver.solverType = exu.LinearSolverType.EigenSparse
    ss.linearSolver.reuseAnalyzedPattern = True
    ss.show.statistics = False
    setup = time.perf_counter() - t0
    c1, w0 = time.process_time(), time.perf_counter()
    exu.SolveDynamic(mbs, ss, storeSolver=True)
    cpu, wall = time.process_time() - c1, time.perf_counter() - w0
    cpu_total, wall_total = time.process_time() - c0, time.perf_counter() - t0
    d = np.asarray(mbs.GetSensorStoredData(sens))
    it = mbs.sys["dynamicSolver"].it
    return {"cpu": cpu, "wall": wall, "setup": setup, "cpu_total": cpu_total, "wall_total": wall_total,
            "t": d[:, 0], "tip": d[:, 1:3], "steps": int(it.currentStepIndex),
            "newton": int(it.newtonStepsCount), "jacobians": int(it.newtonJacobiCount),
            "factorizations": int(it.newtonJacobiCount), "rejected": int(it.rejectedModifiedNewtonSteps),
            "h_last": float(it.currentStepSize)}


# -- comparison --------------------------------------------------------------------------------------------------

def on_grid(run, times):
    return np.column_stack([np.interp(times, run["t"], run["tip"][:, k]) for k in range(2)])


def bench_case(name, c, repeats, exudyn_modes, exudyn_tols, ancf_no_energies, ancf_modified=False, warm=False):
    times = np.round(np.arange(0.0, c["T"] + 1e-9, OUT_DT), 10)
    ref = ancf_run(c, dt=c["dt"] / 8)
    tip_ref = on_grid(ref, times)
    configs = [("ancf_sym", dict(modified=False))]
    if warm:
        configs.append(("ancf_sym (graphs reused)", dict(modified=False, cold=False)))
    if ancf_no_energies:
        configs.append(("ancf_sym (no energies)", dict(modified=False, energies=False)))
    if ancf_modified:
        configs.append(("ancf_sym (modified Newton, no energies)", dict(modified=True, energies=False)))
    configs += [(f"exudyn ({'modified' if m else 'full'} Newton{'' if tol == 1e-8 else f', relTol {tol:g}'})",
                 dict(modified=m, rel_tol=tol)) for m in exudyn_modes for tol in exudyn_tols]
    runs = {k: [] for k, _ in configs}
    for _ in range(repeats):
        for label, kw in configs:
            runs[label].append(ancf_run(c, **kw) if label.startswith("ancf_sym") else exudyn_run(c, **kw))
    rows = []
    tip_ancf = on_grid(runs["ancf_sym"][0], times)
    for label, _ in configs:
        rs = runs[label]
        tip = on_grid(rs[0], times)
        cpu = [r["cpu"] for r in rs]
        wall = [r["wall"] for r in rs]
        r0 = rs[0]
        med = statistics.median(cpu)
        rows.append({
            "case": name, "code": label, "n": c["n"], "dt": c["dt"], "t_end": c["T"],
            "cpu_min_s": min(cpu), "cpu_median_s": med, "wall_min_s": min(wall), "wall_median_s": statistics.median(wall),
            "cpu_sim_median_s": statistics.median([r.get("cpu_sim", r["cpu"]) for r in rs]),
            "cpu_total_min_s": min(r["cpu_total"] for r in rs),
            "cpu_total_median_s": statistics.median([r["cpu_total"] for r in rs]),
            "setup_s": min(r["setup"] for r in rs), "steps": r0["steps"], "newton_iterations": r0["newton"],
            "jacobians": r0["jacobians"], "factorizations": r0["factorizations"], "rejected": r0["rejected"],
            "steps_per_s": r0["steps"] / med, "newton_per_s": r0["newton"] / med,
            "factorizations_per_s": r0["factorizations"] / med,
            "max_err_vs_ref_m": float(np.max(np.linalg.norm(tip - tip_ref, axis=1))),
            "max_diff_vs_ancf_m": float(np.max(np.linalg.norm(tip - tip_ancf, axis=1))),
            "tip_end_x": float(tip[-1, 0]), "tip_end_y": float(tip[-1, 1]),
        })
    for base in [r for r in rows if r["code"].startswith("ancf_sym")]:
        for r in rows:
            if r["code"].startswith("ancf_sym"):
                continue
            base[f"ratio_cpu_vs_{r['code']}"] = base["cpu_median_s"] / r["cpu_median_s"]
            base[f"ratio_cpu_min_vs_{r['code']}"] = base["cpu_min_s"] / r["cpu_min_s"]
            base[f"ratio_wall_vs_{r['code']}"] = base["wall_median_s"] / r["wall_median_s"]
            base[f"ratio_cpu_total_vs_{r['code']}"] = base["cpu_total_median_s"] / r["cpu_total_median_s"]
            base[f"ratio_cpu_total_min_vs_{r['code']}"] = base["cpu_total_min_s"] / r["cpu_total_min_s"]
    return rows


def scaling(ns, repeats, case="rope", steps=20, exudyn=True, dt=1e-3):
    """Time per step, per Newton iteration and set-up against n (the case released horizontal, `steps` steps of
    dt): ancf_sym's loop CPU (its set-up apart, first run of the structure) and Exudyn's SolveDynamic."""
    rows = []
    for n in ns:
        c = dict(CASES[case], n=n, T=steps * dt, dt=dt)
        a, e = [], []
        for _ in range(repeats):
            a.append(ancf_run(c, energies=False, sensors=False))
            if exudyn:
                e.append(exudyn_run(c, rel_tol=1e-4))
        row = {"n": n, "steps": a[0]["steps"], "ancf_step_ms_min": 1e3 * min(r["cpu"] for r in a) / a[0]["steps"],
               "ancf_setup_s_min": min(r["setup"] for r in a), "ancf_newton": a[0]["newton"],
               "ancf_iteration_ms_min": 1e3 * min(r["cpu"] for r in a) / a[0]["newton"]}
        if exudyn:
            row.update({"exudyn_step_ms_min": 1e3 * min(r["cpu"] for r in e) / e[0]["steps"],
                        "exudyn_setup_s_min": min(r["setup"] for r in e), "exudyn_newton": e[0]["newton"],
                        "exudyn_iteration_ms_min": 1e3 * min(r["cpu"] for r in e) / e[0]["newton"]})
            row["ratio_step"] = row["ancf_step_ms_min"] / row["exudyn_step_ms_min"]
        rows.append(row)
        print("  ".join(f"{k} {v:.4g}" if isinstance(v, float) else f"{k} {v}" for k, v in row.items()), flush=True)
    return rows


def second_run(name, repeats):
    """Set-up of a first run of a structure (kernel libraries already loaded by a run of another structure) and
    of a second run of the same structure with other values: E x 2, dt / 2, gravity x 1.5 (a constant load),
    a different initial state (the member bent by a small vertical velocity)."""
    c = dict(CASES[name])
    rows = []
    for _ in range(repeats):
        ancf_run(dict(c, n=c["n"] + 1, T=0.01))  # loads the kernels: what follows pays only for graphs
        clear_graph_cache()
        first = ancf_run(dict(c, T=0.2), cold=False)
        c2 = dict(c, E=2 * c["E"], T=0.2)  # (200 and 400 steps: chunks of 50 both)
        second = _run_with(c2, dt=c["dt"] / 2, gravity=1.5 * G, v_tip=0.1)
        rows.append({"first_setup_s": first["setup"], "second_setup_s": second["setup"],
                     "ratio": second["setup"] / first["setup"], "first_setup_cpu_s": first["setup_cpu"],
                     "second_setup_cpu_s": second["setup_cpu"], "ratio_cpu": second["setup_cpu"] / first["setup_cpu"]})
    best = {k: min(r[k] for r in rows) for k in rows[0]}
    best["ratio_of_minima"] = best["second_setup_s"] / best["first_setup_s"]
    best["ratio_of_minima_cpu"] = best["second_setup_cpu_s"] / best["first_setup_cpu_s"]
    for what, sfx in (("wall", ""), ("CPU", "_cpu")):
        print(f"{name}: set-up ({what}) first run {best['first_setup' + sfx + '_s'] * 1e3:.2f} ms, second run (E x 2, "
              f"dt / 2, gravity x 1.5, initial velocity) {best['second_setup' + sfx + '_s'] * 1e3:.2f} ms: "
              f"{100 * best['ratio_of_minima' + sfx]:.1f} % (min over {repeats}; per-repeat ratios "
              f"{', '.join('%.3f' % r['ratio' + sfx] for r in rows)})", flush=True)
    return best


def _run_with(c, dt, gravity, v_tip):
    """A run of the case's structure with other values (graphs reused from the process's cache)."""
    c0, t0 = time.process_time(), time.perf_counter()
    s = Scene(dim=2, gravity=(0.0, -gravity))
    s.member("m", [(0.0, 0.0), (c["L"], 0.0)], c["n"], Material(E=c["E"], density=c["rho"]),
             Section(area=c["A"], I=c["I"]), axial="biot")
    (s.clamp if c["support"] == "clamp" else s.pin)("m", "start")
    asm = Assembly(s)
    system = StepSystem.for_scene(asm)
    setup = time.perf_counter() - t0
    v0 = np.zeros(asm.n)
    v0[1::4] = v_tip * np.linspace(0.0, 1.0, asm.n // 4)  # vertical velocity growing along the member (pin: 0)
    opts = DynamicOptions(dt=dt, t_end=c["T"], integrator="generalized_alpha", rho_inf=0.9, v0=v0, energies=False)
    res = simulate(asm, opts, system=system)
    assert res.status == "completed", res.message
    return {"setup": setup + res.setup_s, "setup_cpu": time.process_time() - c0 - res.cpu_s}


def cluster_study(study, sweep, repeats):
    """Wall time of a quick study run in this process (--jobs 1), with a local pool of 2 processes, and on a
    2-worker Dask LocalCluster (cluster start-up apart); the records must be the same."""
    import shutil
    import tempfile

    import distributed

    from ancf_sym.study import run_study
    out = {}
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, dashboard_address=None,
                                  silence_logs=40) as cluster, distributed.Client(cluster) as client:
        client.run(lambda: __import__("ancf_sym.study"))
        for _ in range(repeats):
            for label, kw in (("jobs 1", dict(jobs=1)), ("local pool, jobs 2", dict(jobs=2)),
                              ("LocalCluster, 2 workers", dict(scheduler=client))):
                d = tempfile.mkdtemp()
                t0 = time.perf_counter()
                rep = run_study(study, d, quick=True, progress=False, sweep=sweep, **kw)
                w = time.perf_counter() - t0
                shutil.rmtree(d)
                out.setdefault(label, []).append(w)
                out.setdefault(label + " records", [{k: v for k, v in r.items() if k != "wall_s"}
                                                    for r in rep.records])
    same = out["jobs 1 records"] == out["LocalCluster, 2 workers records"]
    for label in ("jobs 1", "local pool, jobs 2", "LocalCluster, 2 workers"):
        ws = out[label]
        print(f"study {study} --quick: {label}: wall min {min(ws):.2f} s, median {statistics.median(ws):.2f} s")
    print(f"LocalCluster records equal to --jobs 1 (timings apart): {same}")
    return {k: v for k, v in out.items() if not k.endswith("records")} | {"same_records": same}


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    p.add_argument("--repeats", type=int, default=5)
    p.add_argument("--clamp", action="store_true", help="also the clamped beam (paper 000's own case)")
    p.add_argument("--cases", nargs="*", default=None, help=f"subset of {sorted(CASES)}")
    p.add_argument("--exudyn-modified", choices=("yes", "no", "both"), default="both",
                   help="Exudyn with modified Newton (its default), full Newton, or both")
    p.add_argument("--exudyn-tols", type=float, nargs="*", default=[1e-8],
                   help="Exudyn Newton relative tolerances to try (default its own 1e-8)")
    p.add_argument("--no-energies", action="store_true",
                   help="also time ancf_sym without the energy balance at the output times (Exudyn records none)")
    p.add_argument("--ancf-modified", action="store_true",
                   help="also time ancf_sym with modified Newton (newton.modified = true; no energies)")
    p.add_argument("--warm", action="store_true",
                   help="also time ancf_sym reusing the compiled graphs of the earlier repeats (set-up of a second "
                        "run of the structure); the default runs each build everything (first run)")
    p.add_argument("--scaling", type=int, nargs="*", metavar="N",
                   help="time per step and set-up against n (e.g. 100 1000 10000) instead of the cases")
    p.add_argument("--scaling-dt", type=float, default=1e-3, help="time step of --scaling (20 steps)")
    p.add_argument("--second-run", action="store_true",
                   help="set-up of a second run of the same structure with other values vs the first")
    p.add_argument("--cluster-study", metavar="STUDY",
                   help="wall time of a quick study: --jobs 1, a local pool and a 2-worker Dask LocalCluster")
    p.add_argument("--json", metavar="PATH")
    a = p.parse_args(argv)
    try:
        import exudyn  # noqa: F401  (only to check it is installed)
    except ImportError:
        sys.exit("exudyn is not installed: pip install exudyn (a bench extra, never needed by ancf_sym)")
    extra = {}
    if a.scaling:
        extra["scaling"] = scaling(a.scaling, a.repeats, (a.cases or ["rope"])[0], dt=a.scaling_dt)
    if a.second_run:
        extra["second_run"] = {k: second_run(k, a.repeats) for k in (a.cases or ["pendulum", "rope"])}
    if a.cluster_study:
        extra["cluster_study"] = cluster_study(a.cluster_study, None, a.repeats)
    if extra:
        if a.json:
            with open(a.json, "w") as f:
                json.dump(extra, f, indent=1)
        return extra
    modes = {"yes": [True], "no": [False], "both": [True, False]}[a.exudyn_modified]
    names = a.cases or (["pendulum", "rope"] + (["clamped_beam"] if a.clamp else []))
    rows = []
    for name in names:
        rows += bench_case(name, CASES[name], a.repeats, modes, a.exudyn_tols, a.no_energies, a.ancf_modified,
                           a.warm)
    cols = ["case", "code", "cpu_min_s", "cpu_median_s", "wall_median_s", "setup_s", "cpu_sim_median_s",
            "cpu_total_median_s", "steps",
            "newton_iterations", "factorizations", "steps_per_s", "newton_per_s", "factorizations_per_s",
            "max_err_vs_ref_m", "max_diff_vs_ancf_m"]
    w = {c: max(len(c), 12) for c in cols}
    w["code"] = max(len(r["code"]) for r in rows)
    print("  ".join(c.rjust(w[c]) for c in cols))
    for r in rows:
        cells = []
        for c in cols:
            v = r[c]
            cells.append((f"{v:.4g}" if isinstance(v, float) else str(v)).rjust(w[c]))
        print("  ".join(cells))
    print()
    what = {"cpu": "CPU time of the time loop, medians", "cpu_min": "CPU time of the time loop, minima",
            "wall": "wall time of the time loop, medians", "cpu_total": "CPU time incl. set-up, medians",
            "cpu_total_min": "CPU time incl. set-up, minima"}
    for r in rows:
        for k, v in r.items():
            if k.startswith("ratio_"):
                kind = k[len("ratio_"):].split("_vs_")[0]
                print(f"{r['case']}: {r['code']} / {k.split('_vs_')[1]} = {v:.2f} ({what[kind]})")
    if a.json:
        with open(a.json, "w") as f:
            json.dump(rows, f, indent=1)
    return rows


if __name__ == "__main__":
    main()
