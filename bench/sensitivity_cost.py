"""Cost of one exact load sensitivity (linearize + one bordered solve) against the statics solve it differentiates:
the catenary example with a 20 N point force at its middle node. Run: python bench/sensitivity_cost.py"""
import time
import tomllib
from pathlib import Path

from ancf_sym.modal.linearize import linearize
from ancf_sym.io.scene_toml import scene_from_dict
from ancf_sym.sensitivity.loads import node_force_sensitivity
from ancf_sym.statics import solve_static

doc = tomllib.loads((Path(__file__).resolve().parents[1] / "examples" / "scenes" / "catenary.toml").read_text())
for n in (40, 160):
    d = dict(doc, members=[dict(doc["members"][0], elements=n)],
             loads=[{"type": "force", "member": "rope", "at": n // 2, "value": [0.0, -20.0]}])
    scene, _ = scene_from_dict(d)
    solve_static(scene)  # warm: kernels loaded, problem cached
    t0 = time.perf_counter(); res = solve_static(scene); t1 = time.perf_counter()
    lin = linearize(scene, res, damping_matrix=False); t2 = time.perf_counter()
    node_force_sensitivity(lin, "rope", n // 2, 0); t3 = time.perf_counter()
    print(f"n={n}: statics {t1 - t0:.4f} s, linearize {t2 - t1:.4f} s, one solve {t3 - t2:.5f} s, "
          f"ratio {(t3 - t1) / (t1 - t0):.2f}")
