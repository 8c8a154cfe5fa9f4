"""A heavy asymmetric rigid body swinging and spinning in 3D, against Euler's equations.

A box-like body (m = 1.5 kg, principal moments 0.02, 0.05, 0.06 kg m^2) hangs from a ground point 0.51 m from its
centre and is launched spinning (omega0 = (0.5, -1, 2) rad/s): a spatial pendulum whose motion is chaotic-looking
but deterministic. The body is a spatial rigid body in natural coordinates (`Scene.body` in a 3D scene: centre and
three axis vectors with six exact orthonormality rows, a constant mass matrix), held two ways:
- `spherical`: a ground spherical joint (three linear rows);
- `cable3d`: pinned (`Scene.pin_body`) to the end of a short clamped steel cable3d (0.1 m, 20 mm diameter), an
  elastic support whose tip stiffness ~5e6 N/m lets the pivot move by ~1e-5 m.
The reference integrates Euler's equations about the fixed pivot (inertia by the parallel-axis theorem, gravity
torque s x R^T m g, R' = R [omega]x) with scipy's solve_ivp (DOP853, rtol 1e-11). Generalized-alpha (rho_inf =
0.9) at three time steps shows the second order of the scheme on the body's centre. Records: case, support, dt_s,
centre_error_m (max over t in [0, t_end]), energy_error_rel (the energy balance's error / m g d), order (log2 of
the error ratio to the next larger dt), constraint_violation, status, success.

Run: python examples/spatial_pendulum.py [--quick] [--json out.json] [--out DIR]
"""
from __future__ import annotations

import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import _common as C  # noqa: E402  (first: it limits BLAS threads before numpy loads)

import numpy as np  # noqa: E402
from scipy.integrate import solve_ivp  # noqa: E402

from ancf_sym import Material, Scene, Section  # noqa: E402
from ancf_sym.model.assembly import Assembly  # noqa: E402
from ancf_sym.dynamics import run_dynamics  # noqa: E402
from ancf_sym.dynamics.initial import velocities  # noqa: E402

G, M = 9.81, 1.5
IC = np.diag([0.02, 0.05, 0.06])
C0 = np.array([0.3, 0.1, -0.4])  # centre relative to the pivot (body axes = world axes at the start)
W0 = np.array([0.5, -1.0, 2.0])


def reference(t: np.ndarray) -> np.ndarray:
    """The centre's path from Euler's equations about the fixed pivot."""
    Io = IC + M * (C0 @ C0 * np.eye(3) - np.outer(C0, C0))

    def f(_, y):
        R, w = y[:9].reshape(3, 3), y[9:]
        torque = np.cross(C0, R.T @ np.array([0.0, 0.0, -M * G]))
        W = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
        return np.r_[(R @ W).ravel(), np.linalg.solve(Io, torque - np.cross(w, Io @ w))]
    y = solve_ivp(f, (t[0], t[-1]), np.r_[np.eye(3).ravel(), W0], t_eval=t, method="DOP853", rtol=1e-11,
                  atol=1e-12).y
    return np.einsum("tij,j->ti", y[:9].T.reshape(-1, 3, 3), C0)


def scene(support: str) -> Scene:
    s = Scene(dim=3, gravity=(0, 0, -G), name=f"spatial_pendulum_{support}")
    s.body("box", M, IC, C0)
    if support == "spherical":
        s.spherical("box", point=(0, 0, 0))
    else:
        s.member("cable", [(0, 0, 0.1), (0, 0, 0)], 2, Material(E=2e11, density=7800), Section.circle(0.02),
                 gravity=False)
        s.clamp("cable", "start")
        s.pin_body("box", "cable", "end")
    return s


def run_case(support: str, dt: float, t: np.ndarray, ref: np.ndarray) -> dict:
    s = scene(support)
    v0 = velocities(Assembly(s), rotation={"box": (W0, (0, 0, 0))})
    r = run_dynamics(s, {"integrator": "generalized_alpha", "rho_inf": 0.9, "dt": dt, "t_end": float(t[-1]),
                         "output_times": t.tolist(), "v0": v0,
                         "sensors": [{"name": "box", "kind": "body", "member": "box"}]})
    err = float(np.abs(r.sensors["box"][:, :3] - ref).max()) if r.success else float("nan")
    scale = M * G * float(np.linalg.norm(C0))
    return {"case": f"{support}_dt{dt:g}", "support": support, "dt_s": dt, "centre_error_m": err,
            "energy_error_rel": float(np.max(np.abs(r.energies["algorithmic"]))) / scale,
            "constraint_violation": float(np.max(r.constraint_violation)), "status": r.status, "success": r.success,
            "path": r.sensors["box"][:, :3]}


def main(argv=None):
    a = C.parser("spatial_pendulum", __doc__).parse_args(argv)
    t_end = 1.0 if a.quick else 3.0
    dts = (4e-3, 2e-3) if a.quick else (4e-3, 2e-3, 1e-3)
    t = np.linspace(0.0, t_end, int(round(t_end / 0.02)) + 1)  # on every dt's grid: outputs are steps, not
    # interpolated between them (an interpolated state misses the nonlinear constraints by O(dt^4))
    ref = reference(t)
    runs = [run_case("spherical", dt, t, ref) for dt in dts] + [run_case("cable3d", dts[-1], t, ref)]
    for prev, cur in zip(runs[:len(dts) - 1], runs[1:len(dts)]):
        cur["order"] = math.log2(prev["centre_error_m"] / cur["centre_error_m"])
    paths = {r["case"]: r.pop("path") for r in runs}
    records = [{"order": None, **r} for r in runs]
    C.table(records, ["case", "centre_error_m", "order", "energy_error_rel", "constraint_violation", "status"])

    def plots(out):
        plt = C.pyplot()
        fig, (ax, bx) = plt.subplots(1, 2, figsize=(11, 4.5))
        ax.plot(ref[:, 0], ref[:, 1], "k-", lw=2.5, alpha=0.4, label="Euler equations (solve_ivp)")
        for r in records:
            if r["dt_s"] == dts[-1]:
                p = paths[r["case"]]
                ax.plot(p[:, 0], p[:, 1], "--", label=f"rigid body, {r['support']}")
        ax.set_xlabel("x [m]"), ax.set_ylabel("y [m]"), ax.set_aspect("equal"), ax.legend(fontsize=8)
        ax.set_title(f"centre of mass seen from above, {t_end:g} s")
        sph = [r for r in records if r["support"] == "spherical"]
        h = np.array([r["dt_s"] for r in sph])
        e = np.array([r["centre_error_m"] for r in sph])
        bx.loglog(h, e, "o-", label="spherical joint")
        bx.loglog(h, e[-1] * (h / h[-1]) ** 2, "k:", label="slope 2")
        bx.set_xlabel("time step [s]"), bx.set_ylabel("max centre error [m]"), bx.legend()
        bx.set_title("generalized-alpha against the reference")
        fig.tight_layout()
        C.save(fig, out, "spatial_pendulum.png")

    return C.finish(records, a, plots)


if __name__ == "__main__":
    main()
