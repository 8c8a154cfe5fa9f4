"""Drives (motion prescribed in time) and applied torques on planar rigid bodies, as time-dependent inputs of the
step graphs.

A drive is an exact constraint row whose coefficients depend on time, written bilinearly in the coordinates with
the time functions w(t) as per-step inputs (no angle coordinate, no wrap-around):
- angle of a body, u = (c, s) its unit vector, theta(t) prescribed:   sin(angle - theta) = s cos(theta) - c sin(theta)
- angle of body b relative to body a (a revolute joint's angle):     sin(angle_b - angle_a - theta) = 0, with
  sin(angle_b - angle_a) = s_b c_a - c_b s_a and cos(...) = c_b c_a + s_b s_a:
      cos(theta) (s_b c_a - c_b s_a) - sin(theta) (c_b c_a + s_b s_a) = 0
- angle of a spatial body about its revolute joint's axis t, relative to the jointed body or the ground: with u the
  body's normal n1 of t and w1, w2 the other side's n1, n2 (t, n1, n2 right-handed; ancf_sym.bodies.spatial):
      cos(theta) u.w2 - sin(theta) u.w1 = sin(angle - theta) = 0   (bilinear; angle 0 in the reference state)
- position of a member node or of a body's centre, r(t) prescribed:  r_k - p_k(t) = 0 per component.
Each row is a sum of entries coef * w_k(t) * X_i * X_j (X = [x; 1]: linear, bilinear and constant terms alike), so
its value, Jacobian and Hessian are exact, and d/dt, d2/dt2 follow from w', w'' (the initial acceleration).
An applied torque tau(t) on a body does the virtual work tau (c ds - s dc): the generalized force tau (-s, c) on
(c, s), with its exact (unsymmetric) tangent; tau is one more per-step input. On a spatial body (axis vectors e_k,
ancf_sym.bodies.spatial) a world torque tau does the work tau . dtheta with de_k = dtheta x e_k: the force
1/2 tau x e_k on each e_k, the same form per component of tau (a constant torque in 3D has no potential).

Motions of time (`motion`): a number (constant), a piecewise polynomial [[t_0, [a0, a1, ...]], [t_1, [...]], ...]
(piece k holds from t_k to t_k+1, the last one on; a polynomial in (t - t_k); before t_0 the value of piece 0 at
t_0 is kept for an angle or a position, and an angular velocity is 0), or Python callables (f, df/dt, d2f/dt2).
A drive given by its angular velocity omega(t) prescribes angle(t) = angle_0 + integral from t_0 of omega, exact
for the piecewise polynomials (the polynomial's integral) and constants (angle_0 + omega (t - 0)).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from ancf_sym.util.checks import SceneError

# -- motions of time -----------------------------------------------------------------------------------------------


class Motion:
    """f(t), f'(t), f''(t) of a prescribed function of time."""

    def __call__(self, t: float) -> tuple[float, float, float]:
        raise NotImplementedError


@dataclass(frozen=True)
class Constant(Motion):
    value: float

    def __call__(self, t):
        return self.value, 0.0, 0.0


@dataclass(frozen=True)
class Ramp(Motion):
    """value0 + rate * t (an angle at a constant angular velocity)."""
    value0: float
    rate: float

    def __call__(self, t):
        return self.value0 + self.rate * t, self.rate, 0.0


@dataclass(frozen=True)
class Piecewise(Motion):
    """Piecewise polynomial: piece k is sum_j coefs[k][j] (t - t_k)^j on [t_k, t_k+1) (the last one on); before t_0
    the value at t_0 (`hold`) or 0."""
    starts: tuple
    coefs: tuple
    hold: bool = True

    def _piece(self, t):
        k = int(np.searchsorted(self.starts, t, side="right")) - 1
        return k

    def __call__(self, t):
        k = self._piece(t)
        if k < 0:
            return (self(self.starts[0])[0] if self.hold else 0.0), 0.0, 0.0
        tau = t - self.starts[k]
        f = df = ddf = 0.0
        for a in reversed(self.coefs[k]):  # Horner on f and its derivatives (called at every step: no numpy)
            ddf = ddf * tau + 2.0 * df
            df = df * tau + f
            f = f * tau + float(a)
        return f, df, ddf

    def integral(self, value0: float) -> "Piecewise":
        """value0 + integral from t_0 of this function (itself 0 before t_0): exact, continuous at the breaks."""
        p = np.polynomial.polynomial
        coefs, acc = [], value0
        for k, c in enumerate(self.coefs):
            ic = p.polyint(np.asarray(c, float))
            ic[0] = acc
            coefs.append(tuple(ic))
            if k + 1 < len(self.starts):
                acc = float(p.polyval(self.starts[k + 1] - self.starts[k], ic))
        return Piecewise(self.starts, tuple(coefs), True)


@dataclass(frozen=True)
class Callables(Motion):
    f: Callable
    df: Callable
    ddf: Callable

    def __call__(self, t):
        return float(self.f(t)), float(self.df(t)), float(self.ddf(t))


def motion(field: str, spec: Any, integral_of: float | None = None) -> Motion:
    """A checked Motion from a spec (see the module docstring). integral_of: the spec is a rate (omega) and the
    Motion is value0 + its integral, value0 = integral_of."""
    def bad(why):
        return SceneError(f"{field} {why}, got {spec!r}")

    if isinstance(spec, bool):
        raise bad("must be a number, a piecewise polynomial [[t, [a0, a1, ...]], ...] or callables")
    if isinstance(spec, (int, float, np.integer, np.floating)):
        v = float(spec)
        if not math.isfinite(v):
            raise bad("must be finite")
        return Ramp(integral_of, v) if integral_of is not None else Constant(v)
    if isinstance(spec, (tuple, list)) and len(spec) == 3 and all(callable(f) for f in spec):
        if integral_of is not None:
            raise bad("as callables must be given as the angle: angle=(theta, omega, alpha) (the integral of a "
                      "callable omega is not known exactly)")
        return Callables(*spec)
    if callable(spec):
        raise bad("as a callable needs its derivatives: (f, df/dt, d2f/dt2)")
    try:
        pieces = [(float(t), tuple(float(a) for a in np.atleast_1d(np.asarray(c, float)))) for t, c in spec]
    except (TypeError, ValueError):
        raise bad("must be a number, a piecewise polynomial [[t, [a0, a1, ...]], ...] or callables (f, df, ddf)") \
            from None
    if not pieces:
        raise bad("needs at least one piece")
    starts = tuple(t for t, _ in pieces)
    if not all(math.isfinite(t) for t in starts) or any(b <= a for a, b in zip(starts, starts[1:])):
        raise bad("must have finite, increasing piece start times")
    if any(not c or not all(math.isfinite(a) for a in c) for _, c in pieces):
        raise bad("must have non-empty finite polynomial coefficients")
    pw = Piecewise(starts, tuple(c for _, c in pieces), hold=integral_of is None)
    return pw.integral(integral_of) if integral_of is not None else pw


# -- declarations ----------------------------------------------------------------------------------------------------

@dataclass
class AngleDrive:
    name: str
    body: str
    relative_to: str | None
    angle: Motion  # absolute angle, or angle of `body` minus angle of `relative_to`


@dataclass
class PositionDrive:
    name: str
    member: str | None  # a member node (at) or a body's centre (body)
    at: Any
    body: str | None
    position: list  # one Motion per component


@dataclass
class Torque:
    name: str
    body: str
    torque: Any  # a Motion (planar, counter-clockwise); a spatial body's: 3 Motions (world x, y, z components)


def _name(scene, name, default):
    name = default if name is None else name
    taken = {d.name for d in getattr(scene, "drives", [])}
    if not isinstance(name, str) or not name or name in taken:
        raise SceneError(f"drive name must be a new non-empty string, got {name!r}")
    return name


def _body(scene, field, body):
    if body not in scene.bodies:
        raise SceneError(f"{field}={body!r} names no body; bodies: {sorted(scene.bodies)}")
    return body


def angle_drive(scene, body: str, angle: Any = None, omega: Any = None, relative_to: str | None = None,
                angle0: float | None = None, name: str | None = None) -> AngleDrive:
    """A checked angle drive (Scene.drive)."""
    f = f"drive(body={body!r})"
    _body(scene, f"{f}: body", body)
    if relative_to is not None:
        _body(scene, f"{f}: relative_to", relative_to)
        if relative_to == body:
            raise SceneError(f"{f}: relative_to must be another body, got {relative_to!r}")
    if (angle is None) == (omega is None):
        raise SceneError(f"{f}: give exactly one of angle (theta(t)) or omega (angular velocity), got angle="
                         f"{angle!r}, omega={omega!r}")
    if scene.dim == 3:  # the angle about the revolute joint's axis, 0 in the reference state
        from ancf_sym.bodies.spatial import drive_joint

        drive_joint(scene, body, relative_to, f"{f}: body")
        ref = 0.0
    else:
        ref = scene.bodies[body].angle - (scene.bodies[relative_to].angle if relative_to else 0.0)
    if angle0 is not None:
        if angle is not None:
            raise SceneError(f"{f}: angle0 goes with omega (the angle where the integral starts), got {angle0!r}")
        try:
            ref = float(angle0)
        except (TypeError, ValueError):
            raise SceneError(f"{f}: angle0 must be a number, got {angle0!r}") from None
    m = motion(f"{f}: angle", angle) if angle is not None else motion(f"{f}: omega", omega, integral_of=ref)
    return AngleDrive(_name(scene, name, f"angle {body}"), body, relative_to, m)


def position_drive(scene, position: Any, member: str | None = None, at: Any = None, body: str | None = None,
                   name: str | None = None) -> PositionDrive:
    """A checked position drive of a member node or a body's centre (Scene.drive_position)."""
    if (member is None) == (body is None):
        raise SceneError(f"drive_position: give a member (with at) or a body, got member={member!r}, body={body!r}")
    if body is not None:
        _body(scene, "drive_position: body", body)
        f = f"drive_position(body={body!r})"
    else:
        scene.check_at(member, at, node_only=True, field_name="drive_position.at")
        f = f"drive_position(member={member!r}, at={at!r})"
    if isinstance(position, (str, bytes)) or not isinstance(position, (list, tuple)) or len(position) != scene.dim:
        raise SceneError(f"{f}: position must be {scene.dim} motions (one per component), got {position!r}")
    ms = [motion(f"{f}: position[{k}]", p) for k, p in enumerate(position)]
    default = f"position {body}" if body is not None else f"position {member}@{at}"
    return PositionDrive(_name(scene, name, default), member, at, body, ms)


def torque(scene, body: str, torque: Any, name: str | None = None) -> Torque:
    """A checked applied torque on a body (Scene.torque) [N m]: planar counter-clockwise positive; spatial 3 motions,
    the world components."""
    _body(scene, "torque: body", body)
    f = f"torque(body={body!r}): torque"
    if scene.dim == 3:
        if isinstance(torque, (str, bytes)) or not isinstance(torque, (list, tuple)) or len(torque) != 3:
            raise SceneError(f"{f} must be 3 motions (world x, y, z components) on a spatial body, got {torque!r}")
        m = [motion(f"{f}[{k}]", t) for k, t in enumerate(torque)]
    else:
        m = motion(f, torque)
    return Torque(_name(scene, name, f"torque {body}"), body, m)


# -- rows and inputs of the step graphs ------------------------------------------------------------------------------

@dataclass
class DriveSystem:
    """The scene's drives as rows phi_r(x, w) = sum coef w_ext[k] X[i] X[j] (w_ext = [w; 1], X = [x; 1]) and its
    torques as forces; w(t) holds every time function (cos/sin of driven angles, prescribed positions, torques)."""
    n: int  # scene coordinates
    m: int  # drive rows
    nw: int
    row: np.ndarray
    wk: np.ndarray
    i: np.ndarray
    j: np.ndarray
    coef: np.ndarray
    labels: list
    funcs: list  # per w block: (first index, kind "angle" | "value", Motion)
    torques: list  # (c index, s index, w index, scale): force scale w (-x_s, x_c) on (x_c, x_s)
    drives: list  # the declarations (AngleDrive / PositionDrive), in row order
    drive_rows: list  # rows of each declaration

    def w(self, t: float, order: int = 0) -> np.ndarray | tuple:
        """w(t) (order 0), or (w, w', w'') (order 2)."""
        out = np.zeros((3, self.nw))
        for k, kind, mo in self.funcs:
            f, df, ddf = mo(t)
            if kind == "angle":
                c, s = math.cos(f), math.sin(f)
                out[:, k:k + 2] = [[c, s], [-s * df, c * df], [-c * df * df - s * ddf, -s * df * df + c * ddf]]
            else:
                out[:, k] = f, df, ddf
        return out[0] if order == 0 else (out[0], out[1], out[2])

    def _ext(self, x, w):
        return np.r_[x, 1.0], np.r_[w, 1.0]

    def value(self, x: np.ndarray, w: np.ndarray) -> np.ndarray:
        X, W = self._ext(x, w)
        return np.bincount(self.row, self.coef * W[self.wk] * X[self.i] * X[self.j], minlength=self.m)

    def jacobian(self, x: np.ndarray, w: np.ndarray):
        import scipy.sparse as sp
        X, W = self._ext(x, w)
        a = self.coef * W[self.wk]
        r = np.r_[self.row, self.row]
        c = np.r_[self.i, self.j]
        v = np.r_[a * X[self.j], a * X[self.i]]
        keep = c < self.n
        return sp.coo_matrix((v[keep], (r[keep], c[keep])), shape=(self.m, self.n)).tocsr()

    def transpose_product(self, x: np.ndarray, w: np.ndarray, y: np.ndarray) -> np.ndarray:
        """J^T y on the full coordinates without forming J (the drives' reaction force, booked at every step: the
        sparse J's assembly cost ~0.7 ms a step on the tracked vehicle)."""
        X, W = self._ext(x, w)
        a = self.coef * W[self.wk] * np.asarray(y, float)[self.row]
        c = np.r_[self.i, self.j]
        v = np.r_[a * X[self.j], a * X[self.i]]
        keep = c < self.n
        return np.bincount(c[keep], v[keep], minlength=self.n)

    def time_terms(self, x: np.ndarray, v: np.ndarray, t: float) -> tuple[np.ndarray, np.ndarray]:
        """(phi_t, gamma): the velocity form J v + phi_t = 0 and the acceleration form J a + gamma = 0, gamma =
        d/dt (J) v + phi_tt (all exact: the rows are bilinear in x and linear in w)."""
        w, w1, w2 = self.w(t, 2)
        X, V = np.r_[x, 1.0], np.r_[v, 0.0]
        W, W1, W2 = np.r_[w, 1.0], np.r_[w1, 0.0], np.r_[w2, 0.0]
        i, j, k = self.i, self.j, self.wk
        xx = X[i] * X[j]
        vx = V[i] * X[j] + X[i] * V[j]
        phi_t = np.bincount(self.row, self.coef * W1[k] * xx, minlength=self.m)
        gamma = np.bincount(self.row, self.coef * (W2[k] * xx + 2 * W1[k] * vx + 2 * W[k] * V[i] * V[j]),
                            minlength=self.m)
        return phi_t, gamma

    def mx(self, X, w):
        """Rows as CasADi MX of the full coordinates X and the inputs w."""
        import casadi as ca
        Xe = ca.vertcat(X, ca.DM.ones(1))
        We = ca.vertcat(w, ca.DM.ones(1))
        terms = ca.DM(self.coef) * We[self.wk.tolist()] * Xe[self.i.tolist()] * Xe[self.j.tolist()]
        S = ca.DM(ca.Sparsity.triplet(self.m, len(self.row), self.row.tolist(), list(range(len(self.row)))), 1.0)
        return ca.mtimes(S, terms)

    def torque_force(self, x: np.ndarray, w: np.ndarray) -> np.ndarray:
        """Generalized force of the torques on the full coordinates."""
        f = np.zeros(self.n)
        for ic, is_, k, scale in self.torques:
            f[ic] -= scale * w[k] * x[is_]
            f[is_] += scale * w[k] * x[ic]
        return f

    def reactions(self, x: np.ndarray, lam: np.ndarray) -> dict[str, list]:
        """What each drive applies to the system, from its rows' multipliers lam (true, in row order): an angle
        drive the torque on `body` [N m] (counter-clockwise; spatial: about the joint axis; on relative_to the opposite), a position drive the
        force on the node or body [N]. Row sin(angle - theta): torque = -lam cos(angle - theta) = -lam."""
        out = {}
        for d, rows in zip(self.drives, self.drive_rows):
            out[d.name] = [float(-lam[r]) for r in rows]
        return out


def build(asm) -> DriveSystem | None:
    """The DriveSystem of an assembled scene, or None without drives and torques. Refuses (before any work) a
    position drive on a coordinate a support or joint already fixes."""
    scene, mesh = asm.scene, asm.mesh
    decl = list(getattr(scene, "drives", []))
    if not decl:
        return None
    row, wk, ii, jj, coef, labels, funcs, torques, drives, drive_rows = ([] for _ in range(10))
    n = asm.n
    ONE = n
    nw = 0
    m = 0

    def entry(r, k, i, j, c):
        row.append(r), wk.append(k), ii.append(i), jj.append(j), coef.append(c)

    for d in decl:
        if isinstance(d, Torque):
            o = mesh.bodies[d.body]
            if scene.dim == 2:
                funcs.append((nw, "value", d.torque))
                torques.append((o + 2, o + 3, nw, 1.0))
                nw += 1
                continue
            # spatial (ancf_sym.bodies.spatial): 1/2 tau x e_k on each axis vector e_k; component m of tau acts as
            # a planar torque tau_m / 2 on the pair (a, b) of components of e_k normal to axis m
            for comp, mo in enumerate(d.torque):
                funcs.append((nw, "value", mo))
                a, b = (comp + 1) % 3, (comp + 2) % 3
                torques += [(o + 3 + 3 * k + a, o + 3 + 3 * k + b, nw, 0.5) for k in range(3)]
                nw += 1
            continue
        if isinstance(d, AngleDrive) and scene.dim == 3:
            # spatial (ancf_sym.bodies.spatial.drive_vectors): cos(theta) u.w2 - sin(theta) u.w1 = sin(angle - theta)
            from ancf_sym.bodies.spatial import drive_joint, drive_vectors

            u, w1, w2 = drive_vectors(mesh, drive_joint(scene, d.body, d.relative_to, d.name), d.body, d.relative_to)
            for k, sign, w_ in ((nw, 1.0, w2), (nw + 1, -1.0, w1)):
                for i, j, c in _dot_terms(u, w_, ONE):
                    entry(m, k, i, j, sign * c)
            funcs.append((nw, "angle", d.angle))
            nw += 2
            labels.append(d.name)
            drives.append(d)
            drive_rows.append([m])
            m += 1
            continue
        if isinstance(d, AngleDrive):
            ob = mesh.bodies[d.body]
            cb, sb = ob + 2, ob + 3
            C, S = nw, nw + 1
            funcs.append((nw, "angle", d.angle))
            nw += 2
            if d.relative_to is None:  # s cos(theta) - c sin(theta)
                entry(m, C, sb, ONE, 1.0)
                entry(m, S, cb, ONE, -1.0)
            else:
                oa = mesh.bodies[d.relative_to]
                ca_, sa = oa + 2, oa + 3
                entry(m, C, sb, ca_, 1.0)
                entry(m, C, cb, sa, -1.0)
                entry(m, S, cb, ca_, -1.0)
                entry(m, S, sb, sa, -1.0)
            labels.append(d.name)
            drives.append(d)
            drive_rows.append([m])
            m += 1
            continue
        # position drive: coordinate - p(t)
        if d.body is not None:
            o = mesh.bodies[d.body]
            idx = [o + k for k in range(scene.dim)]
        else:
            mm = mesh.members[d.member]
            idx = [int(i) for i in mm.node_dofs(mm.node(d.at))[:scene.dim]]
        rows = []
        for k, (ci, mo) in enumerate(zip(idx, d.position)):
            funcs.append((nw, "value", mo))
            entry(m, -1, ci, ONE, 1.0)
            entry(m, nw, ONE, ONE, -1.0)
            nw += 1
            labels.append(f"{d.name}[{k}]")
            rows.append(m)
            m += 1
        drives.append(d)
        drive_rows.append(rows)
    wk_arr = np.array(wk, dtype=np.int64)
    wk_arr[wk_arr < 0] = nw  # the constant 1
    return DriveSystem(n, m, nw, np.array(row, dtype=np.int64), wk_arr, np.array(ii, dtype=np.int64),
                       np.array(jj, dtype=np.int64), np.array(coef, float), labels, funcs, torques, drives, drive_rows)


def _dot_terms(a, b, one: int) -> list[tuple[int, int, float]]:
    """(i, j, coef) with a . b = sum coef X_i X_j for affine vectors a, b (ancf_sym.bodies.rows.Vec; X = [x; 1],
    index `one` the constant 1)."""
    out = []
    for ca_, cb, a0, b0 in zip(a.coef, b.coef, a.const, b.const):
        out += [(i, j, u * v) for i, u in ca_.items() for j, v in cb.items()]
        out += [(i, one, u * b0) for i, u in ca_.items() if b0 != 0]
        out += [(j, one, v * a0) for j, v in cb.items() if a0 != 0]
        if a0 * b0 != 0:
            out.append((one, one, a0 * b0))
    return [t for t in out if t[2] != 0]


def check_free(ds: DriveSystem, pos: np.ndarray) -> None:
    """Refuse position-drive rows on coordinates the supports/joints eliminated (fixed): the two would fight. (An
    angle drive's bilinear row may hold fixed coordinates as constants: a spatial revolute joint to the ground
    fixes the components of the body's axis vectors across its axis, not the angle.)"""
    position = {r for d, rows in zip(ds.drives, ds.drive_rows) if isinstance(d, PositionDrive) for r in rows}
    for r, i, j in zip(ds.row, ds.i, ds.j):
        if r not in position:
            continue
        for c in (i, j):
            if c < ds.n and pos[c] < 0:
                raise SceneError(f"drive {ds.labels[r]!r} acts on coordinate {int(c)}, which a support or joint "
                                 "already fixes (drive the node or body instead of supporting it)")
