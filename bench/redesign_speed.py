"""Speed of the layout change: the same statics (catenary, 40 and 400 elements) and dynamics (pendulum) timed in one
install; run it with the interpreter of each install to compare two versions (min / median over repeats):

    OLD/bin/python bench/redesign_speed.py; NEW/bin/python bench/redesign_speed.py
"""
import time
import tomllib
from pathlib import Path
ROOT = Path(__file__).resolve().parents[1]
import numpy as np
try:
    from ancf_sym.io.scene_toml import scene_from_dict
except ImportError:
    from ancf_sym.scene_toml import scene_from_dict
from ancf_sym import solve_static, run_dynamics
doc = tomllib.loads((ROOT / "examples" / "scenes" / "catenary.toml").read_text())
out = {}
for n in (40, 400):
    d = dict(doc, members=[dict(doc["members"][0], elements=n)])
    scene, _ = scene_from_dict(d)
    solve_static(scene)
    ts = []
    for _ in range(7):
        t0 = time.perf_counter(); r = solve_static(scene); ts.append(time.perf_counter() - t0)
    out[f"statics {n}"] = (min(ts), float(np.median(ts)))
doc = tomllib.loads((ROOT / "examples" / "scenes" / "pendulum.toml").read_text())
scene, an = scene_from_dict(doc)
tab = {k: v for k, v in dict(an).items()}
ts = []
for _ in range(5):
    t0 = time.perf_counter(); r = run_dynamics(scene, tab); ts.append(time.perf_counter() - t0)
out["dynamics pendulum"] = (min(ts), float(np.median(ts)))
for k, v in out.items(): print(f"{k}: min {v[0]*1e3:.2f} ms, median {v[1]*1e3:.2f} ms")
