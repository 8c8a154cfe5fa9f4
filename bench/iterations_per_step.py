"""Newton iterations per step of a bench case (the step graph's info rows): histogram, the sequence, and for the
first steps the predictor's update |dz0|, the second iteration's |dz1|, the truncation-error estimate and the
update tolerance (1 % of it), i.e. why a step needed more than one iteration.

Run: python bench/iterations_per_step.py [--case pendulum_1000] [--steps 12]
"""
from __future__ import annotations

import argparse
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import numpy as np  # noqa: E402
from dynamics_vs_exudyn import CASES, ancf_run  # noqa: E402

from ancf_sym.dynamics import alpha  # noqa: E402


def main(argv=None) -> np.ndarray:
    ap = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    ap.add_argument("--case", default="pendulum_1000", choices=sorted(CASES))
    ap.add_argument("--steps", type=int, default=12, help="steps to detail")
    a = ap.parse_args(argv)
    rows = []
    count = alpha.AlphaIntegrator._count

    def logged(self, info):  # (large states: one info row per step; chunks of small ones: summed rows, skipped)
        if np.ndim(info) == 1:
            rows.append(np.array(info, dtype=float))
        return count(self, info)

    alpha.AlphaIntegrator._count = logged
    try:
        r = ancf_run(CASES[a.case])
    finally:
        alpha.AlphaIntegrator._count = count
    if not rows:
        sys.exit(f"{a.case}: its steps run in compiled chunks (no per-step rows); use a large case")
    info = np.array(rows)
    it = info[:, 1].astype(int)
    print(f"{a.case}: {r['steps']} steps, {r['newton']} Newton iterations; steps by iterations "
          f"{ {k: int(v) for k, v in enumerate(np.bincount(it)) if v} }")
    print("per step:", "".join(str(k) for k in it))
    print("step  iterations  |dz0|      |dz1|      truncation  tolerance")
    for k in range(min(a.steps, len(info))):
        d0, d1, lte = info[k, 3:6]
        print(f"{k + 1:4d}  {it[k]:10d}  {d0:.3e}  {d1:.3e}  {lte:.3e}   {0.01 * lte:.3e}")
    return info


if __name__ == "__main__":
    main()
