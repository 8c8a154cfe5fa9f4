"""Calibrate the damping of a steel cantilever from a noisy decay record of its tip, with the exact Jacobian of
the discrete run.

The cantilever (examples/scenes/decay_cantilever.toml: 1 m, 10 mm round steel bar, clamped) is released straight
under gravity and swings about its sag; Rayleigh mass damping C = alpha M gives its first mode the damping ratio
zeta_1 = alpha / (2 omega_1). The "measurement" is made here: the tip's height from a finer model (twice the
elements, a quarter of the step) with the true zeta_1 = 2 % and E = 210 GPa, every 5 ms, with Gaussian noise of
0.05 mm (seed 1; the swing's amplitude is about 7 mm). The fit starts from the scene file's nominal E (10 % off) and
alpha (about 50 % off): E takes up the coarse mesh's frequency error, alpha the decay. The damping ratio of the fitted
model is alpha / (2 omega_1) with omega_1 of its own modal analysis, compared with the fine model's. It writes
decay_calibration.png and the data CSV (by default examples/data/decay_record.csv: the command line's data).

Run: python examples/calibrate_decay_damping.py [--quick] [--json out.json] [--out DIR]   (quick: 1.2 s of record on
4 elements; the CSV goes to DIR, or to examples/data without --out and --quick)
"""
import sys
import tomllib
from pathlib import Path

import numpy as np

from ancf_sym.dynamics import DynamicOptions, simulate
from ancf_sym.io.scene_toml import scene_from_dict
from ancf_sym.modal import modal_analysis
from ancf_sym.sensitivity import calibrate
from ancf_sym.sensitivity.calibrate_history import SensorHistory, write_history

HERE = Path(__file__).resolve().parent
SCENE = HERE / "scenes" / "decay_cantilever.toml"
ZETA = 0.02  # true damping ratio of the first mode
E_TRUE = 2.1e11  # Pa
NOISE = 5e-5  # m
EVERY = 5e-3  # s between measurements


def scene_doc(elements: int, dt: float, t_end: float) -> dict:
    """The scene file with the mesh and the run's steps set."""
    doc = tomllib.loads(SCENE.read_text())
    doc["members"][0]["elements"] = elements
    doc["analysis"].update(dt=dt, t_end=t_end)
    return doc


def omega1(doc: dict) -> float:
    """First natural angular frequency [rad/s] of the scene (modal analysis about its static equilibrium)."""
    m = modal_analysis(scene_from_dict(doc)[0], modes=1)
    return 2 * np.pi * float(m.frequencies[0])


def measure(elements: int, dt: float, t_end: float, seed: int = 1) -> tuple[SensorHistory, float]:
    """The fine model's tip record every EVERY seconds with noise; its alpha for zeta_1 = ZETA."""
    fine = scene_doc(2 * elements, dt / 4, t_end)
    fine["materials"]["steel"]["E"] = E_TRUE
    alpha = 2 * ZETA * omega1(fine)
    fine["dampings"][0]["alpha"] = alpha
    opts = DynamicOptions(dt=dt / 4, t_end=t_end, integrator="generalized_alpha", output_dt=EVERY,
                          sensors=fine["analysis"]["sensors"], energies=False)
    run = simulate(scene_from_dict(fine)[0], opts)
    assert run.success, run.status
    rng = np.random.default_rng(seed)
    y = run.sensors["tip"][:, 1] + rng.normal(0.0, NOISE, len(run.t))
    return SensorHistory(np.round(run.t / dt) * dt, {("tip", 1): y}), alpha


def main(out: Path | None, quick: bool = False) -> dict:
    elements, dt, t_end = (4, 2e-3, 1.2) if quick else (8, 1e-3, 2.0)
    data, alpha_true = measure(elements, dt, t_end)
    doc = scene_doc(elements, dt, t_end)
    folder = out or Path.cwd()
    folder.mkdir(parents=True, exist_ok=True)
    csv_path = (HERE / "data" if out is None and not quick else folder) / "decay_record.csv"
    write_history(csv_path, data)
    cal = calibrate(doc, csv_path, ["materials.steel.E", "dampings[0].alpha"])
    print(cal.summary())
    zeta = cal.estimate[1] / (2 * omega1(cal.doc))
    zeta_std = cal.std[1] / (2 * omega1(cal.doc))
    print(f"damping ratio zeta_1 = {zeta:.5f} +- {zeta_std:.1g} (true {ZETA}, error {zeta / ZETA - 1:+.2e}); "
          f"{cal.iterations} iterations, residual noise {cal.noise * 1e3:.4f} mm (data noise {NOISE * 1e3} mm)")
    png = cal.plot(folder / "decay_calibration.png")
    print(f"plot: {png}")
    return {"calibration": cal, "zeta": zeta, "zeta_std": zeta_std, "alpha_true": alpha_true, "png": png,
            "csv": csv_path}


def cli(argv: list[str] | None = None) -> dict:
    import argparse
    import json

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="1.2 s of record on 4 elements")
    ap.add_argument("--out", help="folder of the PNG and the CSV")
    ap.add_argument("--json", help="write the key figures to this file")
    a = ap.parse_args(argv)
    r = main(Path(a.out) if a.out else None, quick=a.quick)
    if a.json:
        cal = r["calibration"]
        Path(a.json).write_text(json.dumps({"zeta": r["zeta"], "zeta_std": r["zeta_std"], "zeta_true": ZETA,
                                            "alpha_true": r["alpha_true"], **cal.to_dict()}, indent=1))
    return r


if __name__ == "__main__":
    cli()
