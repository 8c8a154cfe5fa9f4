"""Shared states, parameters and rotations for the kernel tests (numpy only, nothing symbolic), and the runner of
the examples for the tests/*/test_examples_*.py files.

States are nodal coordinate vectors in the layout of ancf_sym.registry:
cable (dim 2 or 3): q = [r(0), r_x(0), r(L), r_x(L)]; beam3d: per node r, r_x, r_y, r_z.
"""
from __future__ import annotations

import importlib.util
import json
import subprocess
import sys
from pathlib import Path

import numpy as np

from ancf_sym import kernels, registry

L0 = 0.8  # element length used by the generic tests [m]
EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


# Rotations ------------------------------------------------------------------------------------------------------

def rotation(axis, angle: float) -> np.ndarray:
    """3x3 rotation by `angle` [rad] about `axis` (Rodrigues)."""
    n = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -n[2], n[1]], [n[2], 0, -n[0]], [-n[1], n[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


def rotation2(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s], [s, c]])


def rotate_q(element: str, q: np.ndarray, R: np.ndarray, shift=None) -> np.ndarray:
    """Rigid motion x -> R x + shift applied to an element state: positions move, gradient vectors only rotate."""
    dim = registry.ELEMENTS[element].dim
    blocks = np.asarray(q, float).reshape(-1, dim)
    out = blocks @ R.T
    if shift is not None:
        per_node = 2 if element.startswith("cable") else 4
        out[::per_node] += np.asarray(shift, float)  # the position block of each node
    return out.ravel()


# Reference states ----------------------------------------------------------------------------------------------

def straight_state(element: str, L: float = L0, stretch: float = 0.0) -> np.ndarray:
    """Straight element along the x axis from the origin; r_x = (1 + stretch) e_x; beam: r_y = e_y, r_z = e_z."""
    if element == "beam3d":
        e = np.eye(3)
        node = lambda x: np.concatenate([x * e[0], (1 + stretch) * e[0], e[1], e[2]])
        return np.concatenate([node(0.0), node((1 + stretch) * L)])
    dim = registry.ELEMENTS[element].dim
    ex = np.eye(dim)[0]
    return np.concatenate([0 * ex, (1 + stretch) * ex, (1 + stretch) * L * ex, (1 + stretch) * ex])


def bent_state(element: str, theta: float, chord: float, L: float = L0) -> np.ndarray:
    """Symmetric planar bend by `theta` [rad] in the x-y plane: node tangents at +-theta/2 to the chord (x axis),
    unit slopes, nodes at 0 and chord*e_x. Beam: each nodal frame is the identity turned by +-theta/2 about z."""
    if element == "beam3d":
        RA, RB = rotation([0, 0, 1], theta / 2), rotation([0, 0, 1], -theta / 2)
        return np.concatenate([np.zeros(3), *RA.T, [chord, 0, 0], *RB.T])
    dim = registry.ELEMENTS[element].dim
    t0 = np.zeros(dim)
    t1 = np.zeros(dim)
    t0[:2] = np.cos(theta / 2), np.sin(theta / 2)
    t1[:2] = np.cos(theta / 2), -np.sin(theta / 2)
    r1 = np.zeros(dim)
    r1[0] = chord
    return np.concatenate([np.zeros(dim), t0, r1, t1])


def perturbed_state(element: str, rng: np.random.Generator, L: float = L0, amplitude: float = 0.2,
                    stretch: float = 0.1, angle: float = 0.5) -> np.ndarray:
    """Curved AND stretched state: straight reference stretched by `stretch`, every nodal coordinate perturbed by
    a uniform random amount of relative size `amplitude` (positions by amplitude*L, unit vectors by amplitude),
    then rigidly rotated by `angle` about a skew axis (planar rotation for cable2d), so no coordinate is special."""
    q = straight_state(element, L, stretch)
    dim = registry.ELEMENTS[element].dim
    scale = np.ones_like(q)
    per_node = 2 if element.startswith("cable") else 4
    blocks = scale.reshape(-1, dim)
    blocks[::per_node] = L  # positions
    q = q + amplitude * scale * rng.uniform(-1, 1, q.size)
    R = rotation2(angle) if dim == 2 else rotation([1, -2, 3], angle)
    return rotate_q(element, q, R)


# Parameters ----------------------------------------------------------------------------------------------------

# Moderate, distinct magnitudes: a wrong parameter index changes results, and no term drowns the others.
PARAM_VALUES = {
    "EA": 3.0e3, "EI": 7.0, "rhoA": 2.5, "gx": 0.3, "gy": -9.81, "gz": 1.7,
    "b": 0.05, "h": 0.08, "E": 2.1e5, "nu": 0.3, "EIy": 5.0, "EIz": 9.0, "GIp": 4.0, "J": 2.0e-6,
    "xi": 0.35, "M": 2.0,
    "k": 2.0e3, "kh": 5.0e3, "t": 0.01, "c": 3.0, "mu": 0.4, "eps": 0.05,
}


def _midpoint_frame(element: str, q: np.ndarray, L: float):
    """Centre-line point and unit tangent at xi = 1/2, a unit normal m and (3D) a unit binormal a."""
    dim = registry.ELEMENTS[element].dim
    step = 2 * dim if element.startswith("cable") else 4 * dim
    r0, t0, r1, t1 = q[:dim], q[dim:2 * dim], q[step:step + dim], q[step + dim:step + 2 * dim]
    r = 0.5 * (r0 + r1) + L / 8 * (t0 - t1)
    t = 1.5 * (r1 - r0) / L - 0.25 * (t0 + t1)
    t = t / np.linalg.norm(t)
    if dim == 2:
        return r, t, np.array([-t[1], t[0]]), None
    m = np.cross(t, [0.3, 1.0, -0.2])
    m /= np.linalg.norm(m)
    return r, t, m, np.cross(t, m)


_BODY_AXES = rotation(np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8]), 0.9)  # rows e1, e2, e3
_DRUM_OFFSET = np.array([0.1, -0.2, 0.05])  # a spatial body's drum axis point, body components


def kernel_input(element: str, effect: str, q: np.ndarray, seed: int = 0, L: float = L0) -> np.ndarray:
    """The kernel's input for element state q: contact kernels append the drum centre (0.5 m from the element's
    midpoint, normal to it; and its angle, or a carrying body's unit vector) and, for dissipation kernels,
    random velocities of all of it."""
    eff = registry.EFFECTS[(element, effect)]
    z = np.asarray(q, float)
    if eff.obstacle == 12:  # a spatial body (r, e1, e2, e3) whose drum axis passes through r + 0.5 m
        r, _, m, _ = _midpoint_frame(element, z, L)
        E = _BODY_AXES
        z = np.concatenate([z, r + 0.5 * m - E.T @ _DRUM_OFFSET, E.ravel()])
    elif eff.obstacle:
        r, _, m, _ = _midpoint_frame(element, z, L)
        extra = {len(r): [], len(r) + 1: [0.3], len(r) + 2: [np.cos(0.3), np.sin(0.3)]}[eff.obstacle]
        z = np.concatenate([z, r + 0.5 * m, extra])  # (+ angle of a drum, or a body's unit vector)
    if eff.rates:
        z = np.concatenate([z, 0.3 * np.random.default_rng(seed).uniform(-1, 1, z.size)])
    return z


def params(element: str, effect: str, q: np.ndarray, L: float = L0, **overrides) -> np.ndarray:
    """Parameter vector for (element, effect) in registry order. Moment references are taken from the state q
    itself (the tangent / section vector at xi), so the measured angle is small, away from the +-pi branch cut
    and from the degenerate directions of the angle (tangent parallel to the axis n)."""
    names = kernels.parameters(element, effect)
    vals = dict(PARAM_VALUES, L=L, **overrides)
    xi = vals["xi"]
    if effect.startswith("contact_"):
        # obstacles that cut the element (no Gauss point on the boundary, where the linear law's Hessian jumps): the
        # ground plane tilted to the tangent, 0.02 m deep at the midpoint; the drum
        # (centre from kernel_input) 0.05 m deep at the midpoint
        r, t, m, a = _midpoint_frame(element, q, L)
        if effect.startswith("contact_ground"):
            n = (m + 0.5 * t) / np.linalg.norm(m + 0.5 * t)
            vals.update(zip(("nx", "ny", "nz")[:len(n)], n), d=float(n @ r) - vals["t"] + 0.02)
        else:
            nd = registry.ELEMENTS[element].ndof
            if effect.startswith("contact_drum"):  # a fixed drum: its centre is a parameter, where kernel_input puts it
                c = r + 0.5 * m
                vals.update(zip(("cx", "cy", "cz")[:len(c)], c))
            elif effect.startswith("contact_body_drum"):  # a spatial body's: axis point and axis in body components
                E = q[nd + 3:nd + 12].reshape(3, 3)
                c = q[nd:nd + 3] + E.T @ _DRUM_OFFSET
                vals.update(zip(("sx", "sy", "sz"), _DRUM_OFFSET))
                a = E @ a
            else:
                c = q[nd:nd + len(r)]
            vals.update(R=float(np.linalg.norm(r - c)) - vals["t"] + 0.05)
            if a is not None:
                vals.update(ax=a[0], ay=a[1], az=a[2])
    if effect == "moment":
        t = cable_slope(q, registry.ELEMENTS[element].dim, L, xi)
        if element == "cable3d":
            n = np.cross(t, [0.3, 1.0, -0.2])  # perpendicular to the tangent: the angle is well defined
            n /= np.linalg.norm(n)
            t0 = rotation(n, 0.4) @ t  # reference 0.4 rad away from the current tangent, in the plane normal to n
            vals.update(nx=n[0], ny=n[1], nz=n[2], t0x=t0[0], t0y=t0[1], t0z=t0[2])
        else:
            t0 = rotation2(0.4) @ t
            vals.update(t0x=t0[0], t0y=t0[1])
    if effect in ("moment_z", "moment_y"):
        ry = (1 - xi) * q[6:9] + xi * q[18:21]
        rz = (1 - xi) * q[9:12] + xi * q[21:24]
        vals.update(ref1=ry[0] + 0.1, ref2=ry[1]) if effect == "moment_z" else vals.update(ref3=rz[2], ref1=rz[0] + 0.1)
    vals.update(overrides)
    return np.array([vals[n] for n in names], float)


# Evaluation ----------------------------------------------------------------------------------------------------

def evaluate(kernel, q, p):
    """(energy: float, gradient: (n,), hessian: (n, n)) as numpy."""
    e, g, H = kernel(q, p)
    return float(e), np.asarray(g).ravel(), np.asarray(H)


def cable_slope(q, dim: int, L: float, xi: float) -> np.ndarray:
    d = [-6 * xi + 6 * xi**2, 1 - 4 * xi + 3 * xi**2, 6 * xi - 6 * xi**2, -2 * xi + 3 * xi**2]
    r0, t0, r1, t1 = (np.asarray(q[i * dim:(i + 1) * dim]) for i in range(4))
    return (d[0] * r0 + d[2] * r1) / L + d[1] * t0 + d[3] * t1


def gauss01(n: int):
    x, w = np.polynomial.legendre.leggauss(n)
    return (x + 1) / 2, w / 2


def quadrature_length(q, dim: int, L: float, n: int = 5) -> float:
    """Deformed length int |r_x| dx by n-point Gauss, the rule the decoupled strain uses to measure L_D."""
    xs, ws = gauss01(n)
    return L * sum(w * np.linalg.norm(cable_slope(q, dim, L, x)) for x, w in zip(xs, ws))


def kernels_by_element():
    """catalogue() entries grouped per element (ids for parametrize)."""
    return [(k["element"], k["effect"], k["gauss"]) for k in kernels.catalogue()]


# Examples ------------------------------------------------------------------------------------------------------

def run_example(name: str, tmp_path_factory, *args: str) -> tuple[object, list[dict]]:
    """Import examples/<name>.py, run its main(["--quick", *args, "--json", ..., "--out", ...]) in a fresh temporary
    directory and check what every example promises: the JSON on disk holds the returned records, flat, and at least
    one figure was drawn. Returns (module, records)."""
    spec = importlib.util.spec_from_file_location(f"example_{name}", EXAMPLES / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    tmp = tmp_path_factory.mktemp(name)
    js, out = tmp / f"{name}.json", tmp / "figures"
    records = mod.main(["--quick", *args, "--json", str(js), "--out", str(out)])
    on_disk = json.loads(js.read_text())
    assert len(on_disk) == len(records) > 0
    assert all(isinstance(r, dict) and all(not isinstance(v, (dict, list)) for v in r.values()) for r in on_disk), \
        "records must be flat"
    assert sorted(out.glob("*.png")), f"{name} drew no figure"
    return mod, records


def pick(records: list[dict], **kw) -> dict:
    """The one record whose fields equal kw (asserts there is exactly one)."""
    hits = [r for r in records if all(r.get(k) == v for k, v in kw.items())]
    assert len(hits) == 1, f"{len(hits)} records match {kw}"
    return hits[0]


def cli(*args, cwd: Path) -> subprocess.CompletedProcess:
    """`python -m ancf_sym.cli ARGS` in a subprocess, as a user runs it (outside the project root, so that the
    installed package with its compiled kernels is imported)."""
    return subprocess.run([sys.executable, "-m", "ancf_sym.cli", *map(str, args)], cwd=cwd, capture_output=True,
                          text=True, timeout=300)


# -- comparing two dynamic runs that solve the same equations (a held body's drum against the fixed drum) ---------
HISTORIES_PART_TOL = 1e-2  # m/s: see same_motion_tol


def step_history(res) -> tuple:
    """What decides a fixed-step run's step sequence: its accepted steps and its rejected attempts (t, h). The step
    control is a deterministic function of these outcomes, so equal histories mean the same steps."""
    return res.steps, [(r["t"], r["h"]) for r in res.rejected]


def same_motion_tol(a, b) -> float:
    """Tolerance on the sensor velocities [m/s] of two fixed-step runs (dt = 1e-3 s) of a rope started at rest over
    a drum (tests/contact/test_contact_body*.py rope_over) whose systems are the same equations in differently structured
    unknowns (a held body adds its coordinates and the multipliers of its joint and drive), Newton run to its
    update tolerance (1e-10 m) every step.

    Same steps: they agree to that tolerance, 1e-8 m/s over 30 steps. But a step counts as converged only if
    Newton meets its tolerance within max_iter iterations, and on the wrapped start full Newton first wanders
    (the regularised friction's force saturates over eps; a step's first iterations cycle) before converging
    quadratically, so some steps meet the tolerance at iteration 11 or 12 and others just after: round-off decides
    (another system's structure, another BLAS kernel for the CPU: the initial acceleration's sparse solve calls
    it), and one run halves a step the other accepts. From there they are two time discretisations of the same
    motion and differ by the schemes' error on the start, not by round-off: the start halves the step to ~1e-5 s
    in both whatever dt, and runs of the fixed drum that part there (max_iter 8 to 20, dt 1e-3 or 5e-4) differ by
    up to 4e-3 m/s at a peak speed of 0.21 m/s, hence 1e-2 m/s; a drum that lost its friction (mu = 0 for 0.1)
    differs by 1.7e-2."""
    return 1e-8 if step_history(a) == step_history(b) else HISTORIES_PART_TOL
