"""Cost per step of the tracked-vehicle chain (examples/tracked_vehicle.py: 64 beam3d elements, 8 contacts) with
the continuum (CMM) and elastic-line (ELM) forces, and where it goes.

From the example's static start, per beam form:
- the time loop (generalized-alpha, dt = 2e-4 s, 100 steps): CPU ms per step and Newton iterations per step, with
  the full contact set (ground friction and damping: unsymmetric tangent, sparse QR) and with the ground's
  dissipation left out (normal laws only: symmetric, LDL^T), which separates the dissipation kernel + QR share;
- the kernels alone, best of `repeat` calls at the start state: the elastic forces with their Hessian (64
  elements), the 8 contact normal laws (8 x 64 element calls), the ground's damping/friction dissipation (64);
- a sparse LU factorisation of the step matrix M / (beta h^2) + K (SciPy SuperLU, for scale: the step graph
  factorises inside CasADi).
CPU (process) time, so that the other processes on a shared machine count less; min and median over repeats.
No peer runs here: the reference figure is paper 001's "CMM takes 9x the ELM run" (Exudyn has no 24-DOF ANCF beam).

Run: python bench/tracked_vehicle_cost.py [--repeats 3]
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
from ancf_sym.assembly import Assembly  # noqa: E402
from ancf_sym.dynamics import DynamicOptions, simulate  # noqa: E402
from ancf_sym.dynamics import StepSystem  # noqa: E402
from ancf_sym import kernels  # noqa: E402


def best(f, repeat: int) -> tuple[float, float]:
    ts = []
    for _ in range(repeat):
        t0 = time.process_time()
        f()
        ts.append(time.process_time() - t0)
    return min(ts), statistics.median(ts)


def loop_cost(method: str, q0: np.ndarray, dissipation: bool, repeats: int) -> tuple[float, float, float]:
    """(min, median CPU ms per step, Newton iterations per step) over `repeats` runs of 100 steps."""
    per, it = [], 0.0
    for _ in range(repeats):
        sc = TV.build_scene(method)
        if not dissipation:
            sc.contacts[0] = dataclasses.replace(sc.contacts[0], damping=0.0, mu=0.0)
        asm = Assembly(sc)
        res = simulate(asm, DynamicOptions(dt=2e-4, t_end=0.02, rho_inf=0.5, q0=q0, energies=False),
                       system=StepSystem(asm))
        assert res.success, res.message
        per.append(1e3 * res.cpu_s / res.steps)
        it = res.newton_iterations / res.steps
    return min(per), statistics.median(per), it


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=3)
    a = ap.parse_args()
    rows = {}
    for method in ("continuum", "elastic_line"):
        q0, _ = TV.static_start(method)
        asm = Assembly(TV.build_scene(method))
        r = {}
        r["loop"] = loop_cost(method, q0, True, a.repeats)
        r["loop_sym"] = loop_cost(method, q0, False, a.repeats)
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
              "elastic": "elastic forces + Hessian (64 el.)", "normal": "8 contact normal laws (8 x 64)",
              "friction": "ground damping/friction (64)", "lu": "sparse LU of the step matrix"}
    for key, lab in labels.items():
        c, e = rows["continuum"][key], rows["elastic_line"][key]
        sc = 1.0 if key.startswith("loop") else 1e3
        print(f"{lab:34s} {sc * c[0]:9.2f} {sc * c[1]:8.2f} {sc * e[0]:9.2f} {sc * e[1]:8.2f} {c[0] / e[0]:8.2f}")
    for m in rows:
        print(f"{m}: Newton iterations per step {rows[m]['loop'][2]:.2f} (all contacts), "
              f"{rows[m]['loop_sym'][2]:.2f} (no ground dissipation)")


if __name__ == "__main__":
    main()
