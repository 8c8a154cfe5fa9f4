"""A blow-up that Newton does not see is reported, not returned as a completed run.

Paper 002's taut string (5 N, 0.2 mm steel wire, 20 elements, HHT alpha = -0.005, dt = 1e-4) with a 10 N step load
held at midspan: between t = 11 and 12 ms one step converges (residual below tolerance) onto a state with 3.4e4 J of
kinetic energy, while the load has done 0.35 J of work. The energy balance records it; the run ends there with
status energy_blowup (success False) and nothing recorded after it. The same string under gravity alone, and the
10 N load with dt = 1e-5 (which the example found stable), complete."""
from __future__ import annotations

import numpy as np

from ancf_sym import Material, Scene, Section, run_dynamics

SEC = Section.circle(0.2e-3)
EA = 200e9 * SEC.area


def string_run(load: float, dt: float, t_end: float):
    s = Scene(dim=2, gravity=(0, -9.81))
    s.member("s", [(0, 0), (1, 0)], 20, Material(E=200e9, density=7800), SEC, axial="green", prestrain=5.0 / EA)
    s.pin("s", "start")
    s.pin("s", "end")
    loads = [{"member": "s", "at": 10, "force": [0, -load], "history": [[0, 1], [1, 1]]}] if load else []
    return run_dynamics(s, {"integrator": "hht", "alpha": -0.005, "dt": dt, "t_end": t_end, "output_dt": 1e-3,
                            "loads": loads, "sensors": [{"name": "mid", "kind": "position", "member": "s", "at": 10}]})


def test_energy_created_by_the_scheme_ends_the_run():
    r = string_run(10.0, 1e-4, 0.03)
    assert r.status == "energy_blowup" and not r.success
    assert 0.005 < r.t_reached < 0.03 and r.t[-1] <= r.t_reached + 1e-12
    assert "created" in r.message and np.all(np.isfinite(r.energies["kinetic"]))
    assert -r.energies["algorithmic"][-1] > 0.1 * r.energies["kinetic"][-1]


def test_stable_runs_complete():
    for load, dt in ((0.0, 1e-4), (10.0, 1e-5)):
        r = string_run(load, dt, 0.015)
        assert r.status == "completed" and r.success, (load, dt, r.message)
        E = np.array(r.energies["kinetic"]) + np.array(r.energies["potential"])
        assert np.all(np.abs(r.energies["algorithmic"]) < 0.05 * max(np.abs(E).max(), 1e-12) + 1e-9)
