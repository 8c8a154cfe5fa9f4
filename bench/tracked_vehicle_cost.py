"""Cost per step of the tracked-vehicle chain (examples/tracked_vehicle.py: 64 beam3d elements, 8 contacts) with
the continuum (CMM) and elastic-line (ELM) forces, and where it goes.

From the example's static start, per beam form:
- the time loop (generalized-alpha, dt = 2e-4 s, 100 steps): CPU ms per step and Newton iterations per step, with
  the full contact set (ground friction and damping: unsymmetric tangent, sparse QR) and with the ground's
  dissipation left out (normal laws only: symmetric, LDL^T), which separates the dissipation kernel + QR share;
  and with modified Newton (the exact tangent's factor kept while Newton contracts: the example's setting), at
  dt = 2e-4 s and 5e-4 s (cost per simulated time: divide by 2.5 at the larger step);
- the kernels alone, best of `repeat` calls at the start state: the elastic forces with their Hessian (64
  elements), the 8 contact normal laws (8 x 64 element calls), the ground's damping/friction dissipation (64);
- a sparse LU factorisation of the step matrix M / (beta h^2) + K (SciPy SuperLU, for scale: the step graph
  factorises inside CasADi).
CPU (process) time, so that the other processes on a shared machine count less; min and median over repeats.
No peer runs here: the reference figure is paper 001's "CMM takes 9x the ELM run" (Exudyn has no 24-DOF ANCF beam).

With --driven, the same for the driven half vehicle (chassis and wheels as bodies, 7 body-carried drums, the sprocket
turned by omega(t) from t = 0): the time loop (modified Newton, 0.04 s from the vehicle's static start) and the
kernels with their tangents at the start: elastic, the 8 normal laws, the ground's and the sprocket's friction.

With --reach, the driven vehicle with the contact kernels on all element-surface pairs and only on the blocks in
reach (ancf_sym.system.contact_reach, switched in one process, alternating): the time loop (0.04 s from the static
start, drive from 0), the step Jacobian, its SuperLU factorisation with and without its stored zeros, the residual.

With --window T, the driven vehicle's time loop over T s (drive from t = 0) with and without the energy bookkeeping.

Run: python bench/tracked_vehicle_cost.py [--repeats 3] [--driven | --reach | --window T]
"""
from __future__ import annotations

import argparse
import dataclasses
import os
import statistics
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "examples"))

import numpy as np  # noqa: E402
import scipy.sparse as sp  # noqa: E402
import scipy.sparse.linalg as spla  # noqa: E402

import tracked_vehicle as TV  # noqa: E402
from ancf_sym import contact  # noqa: E402
from ancf_sym.model.assembly import Assembly  # noqa: E402
from ancf_sym.dynamics import DynamicOptions, simulate  # noqa: E402
from ancf_sym.dynamics import StepSystem  # noqa: E402
from ancf_sym.dynamics.newton import NewtonOptions  # noqa: E402
from ancf_sym import kernels  # noqa: E402


def best(f, repeat: int) -> tuple[float, float]:
    ts = []
    for _ in range(repeat):
        t0 = time.process_time()
        f()
        ts.append(time.process_time() - t0)
    return min(ts), statistics.median(ts)


def loop_cost(method: str, q0: np.ndarray, dissipation: bool, repeats: int, modified: bool = False,
              dt: float = 2e-4) -> tuple[float, float, float]:
    """(min, median CPU ms per step, Newton iterations per step) over `repeats` runs of 0.02 s (100 steps at the
    example's dt): full Newton (a factorisation per iteration, in the compiled step graph) or modified Newton (the
    exact tangent's SuperLU factor kept across iterations and steps while Newton contracts)."""
    per, it = [], 0.0
    for _ in range(repeats):
        sc = TV.build_scene(method)
        if not dissipation:
            sc.contacts[0] = dataclasses.replace(sc.contacts[0], damping=0.0, mu=0.0)
        asm = Assembly(sc)
        res = simulate(asm, DynamicOptions(dt=dt, t_end=0.02, rho_inf=0.5, q0=q0, energies=False,
                                           newton=NewtonOptions(modified=modified)), system=StepSystem(asm))
        assert res.success, res.message
        per.append(1e3 * res.cpu_s / res.steps)
        it = res.newton_iterations / res.steps
    return min(per), statistics.median(per), it


def driven_cost(repeats: int) -> None:
    """CPU ms per step of the driven vehicle's time loop and of its kernels at the start, per beam form."""
    print(f"{'driven vehicle, CPU ms':34s} {'CMM min':>9s} {'median':>8s} {'ELM min':>9s} {'median':>8s}")
    rows = {}
    for method in ("continuum", "elastic_line"):
        asm, q0, _ = TV.vehicle_start(method, drive_start=0.0)
        per, it = [], 0.0
        for _ in range(repeats):
            res = simulate(asm, DynamicOptions(dt=2e-4, t_end=0.04, rho_inf=0.5, q0=q0, energies=False,
                                               newton=TV.NEWTON))
            assert res.success, res.message
            per.append(1e3 * res.cpu_s / res.steps)
            it = res.newton_iterations / res.steps
        r = {"loop": (min(per), statistics.median(per))}
        rep = 10 * repeats
        elastic = [mk for mk in asm.curved if mk.term.label != contact.LABEL]
        normal = [mk for mk in asm.curved if mk.term.label == contact.LABEL]
        r["elastic"] = best(lambda: [mk(q0) for mk in elastic], rep)
        r["normal"] = best(lambda: [mk(q0) for mk in normal], rep)
        for element, effect, gauss, idx, P in contact.dissipation_calls(asm.mesh):
            k = kernels.load(element, effect, None if gauss == 5 else gauss).map(len(idx))
            Z = np.vstack([q0[idx].T, np.zeros_like(q0[idx].T)])
            r[effect] = best(lambda: k(Z, P.T), rep)
        rows[method] = r
        print(f"{method}: Newton iterations per step {it:.2f}")
    for key in rows["continuum"]:
        c, e = rows["continuum"][key], rows["elastic_line"][key]
        sc = 1.0 if key == "loop" else 1e3
        print(f"{key:34s} {sc * c[0]:9.2f} {sc * c[1]:8.2f} {sc * e[0]:9.2f} {sc * e[1]:8.2f}")


def reach_cost(repeats: int) -> None:
    """The driven vehicle (ELM) with the contact kernels on every pair and on the blocks in reach, alternating."""
    from ancf_sym.system import contact_reach
    from ancf_sym.system.graph_cache import clear_graph_cache

    from ancf_sym.dynamics import newton as dyn_newton

    asm, q0, _ = TV.vehicle_start("elastic_line", drive_start=0.0)
    rows: dict = {}
    kept: list = []  # the last step matrix a run factorised (the Newton's own, at a converging state)
    factorize = dyn_newton.Factor.factorize

    def keep(self, A, key, counters):
        kept[:] = [A.copy()]
        return factorize(self, A, key, counters)
    dyn_newton.Factor.factorize = keep
    for rep in range(repeats):
        for on in (False, True):
            contact_reach.ENABLED = on
            clear_graph_cache()
            res = simulate(asm, DynamicOptions(dt=2e-4, t_end=0.04, rho_inf=0.5, q0=q0, output_dt=0.05,
                                               newton=TV.NEWTON))
            assert res.success, res.message
            r = rows.setdefault(on, {k: [] for k in ("loop", "jacobian", "lu_full", "lu_pruned", "residual")})
            r["loop"].append(1e3 * res.cpu_s / res.steps)
            S = StepSystem.for_scene(asm)  # the step graphs at the run's last state
            S.x[:] = S.reduce(res.x)
            S.jacobian()
            r["jacobian"].append(1e3 * best(S.jacobian, 10)[0])
            r["residual"].append(1e3 * best(S.residual, 50)[0])
            A, P = kept[0].copy(), kept[0].copy()
            P.eliminate_zeros()  # (the pairs out of reach: stored zeros)
            for key, M in (("lu_full", A), ("lu_pruned", P)):
                r[key].append(1e3 * best(lambda: spla.splu(M, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.1,
                                                           options={"SymmetricMode": True}), 5)[0])
            r["nnz"] = (A.nnz, P.nnz)
    contact_reach.ENABLED = True
    dyn_newton.Factor.factorize = factorize
    print(f"{'driven vehicle (ELM), CPU ms':38s} {'all pairs min':>14s} {'median':>8s} {'in reach min':>13s} "
          f"{'median':>8s}")
    labels = {"loop": "time loop, per step (0.04 s)", "jacobian": "step Jacobian (graph)",
              "lu_full": "SuperLU of the Jacobian as stored", "lu_pruned": "SuperLU without its stored zeros",
              "residual": "residual (graph)"}
    for key, lab in labels.items():
        a, b = rows[False][key], rows[True][key]
        print(f"{lab:38s} {min(a):14.3f} {statistics.median(a):8.3f} {min(b):13.3f} {statistics.median(b):8.3f}")
    print(f"stored entries of the step Jacobian: {rows[True]['nnz'][0]}, nonzero: {rows[True]['nnz'][1]}")


def window_cost(t_end: float, repeats: int) -> None:
    """CPU ms per step of the driven vehicle (ELM) over t_end s from its static start, drive from t = 0, the
    example's options (modified Newton, outputs every 0.05 s), with the energy and work bookkeeping and without
    (alternating; run it on each commit to compare versions)."""
    asm, q0, _ = TV.vehicle_start("elastic_line", drive_start=0.0)
    per: dict = {True: [], False: []}
    for _ in range(repeats):
        for energies in (True, False):
            res = simulate(asm, DynamicOptions(dt=2e-4, t_end=t_end, rho_inf=0.5, q0=q0, output_dt=0.05,
                                               energies=energies, newton=TV.NEWTON))
            assert res.success, res.message
            per[energies].append(1e3 * res.cpu_s / res.steps)
    for energies, v in per.items():
        print(f"driven vehicle (ELM), {t_end:g} s, energies {energies}: CPU ms per step min {min(v):.3f} "
              f"median {statistics.median(v):.3f}")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--driven", action="store_true", help="the driven vehicle instead of the chain on fixed wheels")
    ap.add_argument("--reach", action="store_true", help="the driven vehicle, contact kernels on all pairs / in reach")
    ap.add_argument("--window", type=float, default=0.0, help="the driven vehicle's time loop over this many s")
    a = ap.parse_args()
    if a.reach:
        reach_cost(a.repeats)
        return
    if a.window:
        window_cost(a.window, a.repeats)
        return
    if a.driven:
        driven_cost(a.repeats)
        return
    rows = {}
    for method in ("continuum", "elastic_line"):
        q0, _ = TV.static_start(method)
        asm = Assembly(TV.build_scene(method))
        r = {}
        r["loop"] = loop_cost(method, q0, True, a.repeats)
        r["loop_sym"] = loop_cost(method, q0, False, a.repeats)
        r["loop_mod"] = loop_cost(method, q0, True, a.repeats, modified=True)
        r["loop_mod_5"] = loop_cost(method, q0, True, a.repeats, modified=True, dt=5e-4)
        elastic = [mk for mk in asm.curved if mk.term.label != contact.LABEL]
        normal = [mk for mk in asm.curved if mk.term.label == contact.LABEL]
        rep = 10 * a.repeats
        r["elastic"] = best(lambda: [mk(q0) for mk in elastic], rep)
        r["normal"] = best(lambda: [mk(q0) for mk in normal], rep)
        calls = contact.dissipation_calls(asm.mesh)
        element, effect, gauss, idx, P = calls[0]
        k = kernels.load(element, effect, None if gauss == 5 else gauss).map(len(idx))
        Z = np.vstack([q0[idx].T, np.zeros_like(q0[idx].T)])
        r["friction"] = best(lambda: k(Z, P.T), rep)
        ev = asm.evaluate(q0, hessian=True)
        K = sp.csc_matrix(ev.hessian)
        A = (K + sp.diags(np.full(asm.n, 1.0)) * (15.6e3 * 0.381 * 0.02 * 0.15 / (0.25 * 2e-4**2))).tocsc()
        r["lu"] = best(lambda: spla.splu(A), rep)
        rows[method] = r
    print(f"{'CPU ms':34s} {'CMM min':>9s} {'median':>8s} {'ELM min':>9s} {'median':>8s} {'CMM/ELM':>8s}")
    labels = {"loop": "time loop, per step (all contacts)", "loop_sym": "time loop, per step (no ground dissip.)",
              "loop_mod": "time loop, modified Newton (the example)",
              "loop_mod_5": "modified Newton, dt = 5e-4 s",
              "elastic": "elastic forces + Hessian (64 el.)", "normal": "8 contact normal laws (8 x 64)",
              "friction": "ground damping/friction (64)", "lu": "sparse LU of the step matrix"}
    for key, lab in labels.items():
        c, e = rows["continuum"][key], rows["elastic_line"][key]
        sc = 1.0 if key.startswith("loop") else 1e3
        print(f"{lab:34s} {sc * c[0]:9.2f} {sc * c[1]:8.2f} {sc * e[0]:9.2f} {sc * e[1]:8.2f} {c[0] / e[0]:8.2f}")
    for m in rows:
        print(f"{m}: Newton iterations per step {rows[m]['loop'][2]:.2f} (all contacts), "
              f"{rows[m]['loop_sym'][2]:.2f} (no ground dissipation), {rows[m]['loop_mod'][2]:.2f} (modified), "
              f"{rows[m]['loop_mod_5'][2]:.2f} (modified, dt = 5e-4 s)")


if __name__ == "__main__":
    main()
