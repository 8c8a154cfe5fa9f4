"""Cost of the dynamic sensitivities of a run with contact friction and damping: the discrete adjoint's gradient of
one output with respect to 100 parameters, against the run it differentiates.

Scene: the sliding rope of tests/sensitivity/test_sensitivity_friction.py (1 m, on a penalty ground with damping and
regularised Coulomb friction, held back by a soft spring), pulled along by 48 nodal forces of 0.6 N in all; 1000
generalized-alpha steps of 1 ms. Output: the time integral of the rope end's x. Parameters: the contact's mu, damping
and stiffness, E, density and 95 force components. The figures: min / median of the repeats, the gradient (run +
adjoint) over the sensitivities' own run of the same steps without records, and the largest relative difference
from Richardson-extrapolated central differences of tightly converged runs on the contact's three parameters.

Run: python bench/sensitivity_friction_cost.py [--repeats N]
"""
from __future__ import annotations

import argparse
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from sensitivity_cost import largest_difference_from_central, timed  # noqa: E402


def scene(elements: int) -> dict:
    nodes = np.linspace(1, elements, 48).round().astype(int)
    return {"scene": {"name": "slide", "dim": 2, "gravity": [0.0, -9.81]},
            "materials": {"m": {"E": 5e6, "density": 1200.0}, "soft": {"E": 2.5e4, "density": 100.0}},
            "sections": {"s": {"area": 1e-4, "I": 1e-9}, "w": {"area": 1e-4}},
            "members": [{"name": "rope", "points": [[0, 0], [1.0, 0]], "elements": elements, "material": "m",
                         "section": "s", "bending": True},
                        {"name": "spring", "points": [[-0.5, 0], [0, 0]], "elements": 1, "material": "soft",
                         "section": "w", "bending": False, "gravity": False}],
            "supports": [{"type": "pin", "member": "spring", "at": "start"}],
            "joints": [{"type": "hinge", "a": ["spring", "end"], "b": ["rope", "start"]}],
            "loads": [{"type": "force", "member": "rope", "at": int(k), "value": [0.6 / 48, 0.0]} for k in nodes],
            "contacts": [{"type": "ground", "member": "rope", "level": 1.8e-4, "stiffness": 1e4, "thickness": 0.0,
                          "damping": 2e5, "mu": 0.3, "eps": 0.02}]}


def friction_adjoint_cost(repeats: int, elements: int, check: bool) -> None:
    from ancf_sym.dynamics import DynamicOptions
    from ancf_sym.sensitivity.adjoint import SensorOutput, dynamic_gradient
    from ancf_sym.sensitivity.alpha_run import run_for_sensitivity

    doc = scene(elements)
    sensors = [{"name": "tip", "kind": "position", "member": "rope", "at": "end"}]
    opts = DynamicOptions(dt=1e-3, t_end=1.0, sensors=sensors, energies=False)
    contact = ["contacts[0].mu", "contacts[0].damping", "contacts[0].stiffness"]
    paths = contact + ["materials.m.E", "materials.m.density"] + \
        [f"loads[{i}].value[{j}]" for i in range(48) for j in range(2)][:95]
    out = SensorOutput("tip", 0, "integral")
    g = dynamic_gradient(doc, paths, opts, out)  # warm
    k_min, k_med, _ = timed(lambda: run_for_sensitivity(doc, [], opts), repeats)
    a_min, a_med, _ = timed(lambda: dynamic_gradient(doc, paths, opts, out), repeats)
    rel = f"{largest_difference_from_central(doc, contact, sensors, out):.1e}" if check else "not checked"
    print(f"dynamics adjoint, friction and contact damping, {elements} elements, 1000 steps, {len(paths)} parameters: "
          f"the run {k_min * 1e3:.1f} / {k_med * 1e3:.1f} ms; gradient (run + adjoint) {a_min * 1e3:.1f} / "
          f"{a_med * 1e3:.1f} ms = {a_min / k_min:.2f}x / {a_med / k_med:.2f}x the run (min / median); largest "
          f"relative difference from central differences on {contact}: {rel}")
    for note in g.notes:
        print("  note:", note)


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=5)
    a = ap.parse_args()
    for n in (10, 40, 80):
        friction_adjoint_cost(a.repeats, n, check=n == 10)
