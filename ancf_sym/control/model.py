"""The reduced model a control problem moves: the scene's assembly with point masses, the free coordinates
(supports and hinges eliminated), the controlled support channels and forces, the forces and tangent at one instant,
static equilibria and vibration modes, and centreline probes."""
from __future__ import annotations

import math
from typing import Any, Callable, Sequence

import casadi as ca
import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from ancf_sym import registry
from ancf_sym.model.assembly import Assembly
from ancf_sym.util.checks import number as _num
from ancf_sym.model.mesh import Probe
from ancf_sym.model.assembly import LINEAR_EFFECTS
from ancf_sym.model.reduced import ReducedModel, full_mx
from ancf_sym.model.loads import point_force
from ancf_sym.scene.builder import PointMass as ScenePointMass
from ancf_sym.scene.builder import Scene, SceneError
from ancf_sym.util.checks import vector
from ancf_sym.util.sparsity import assemble_mx
from ancf_sym.control.ingredients import PointForce, PointMass, SupportMotion


class ControlAssembly(Assembly):
    """A scene's Assembly with point masses (at nodes): they join the scene's own (Scene.point_mass: mass matrix
    and weight under scene.gravity, ancf_sym.model.loads) in a copy of the scene, the user's scene left as it is. Also
    what the dynamics integrator runs for the re-simulation."""

    def __init__(self, scene: Scene, point_masses: Sequence[PointMass] = ()):
        import copy

        self.point_masses = list(point_masses)
        with_masses = copy.copy(scene)
        with_masses.point_masses = list(scene.point_masses)
        for i, pm in enumerate(self.point_masses):
            if not isinstance(pm, PointMass):
                raise SceneError(f"point_masses[{i}] must be a PointMass, got {pm!r}")
            scene.check_at(pm.member, pm.at, node_only=True, field_name=f"point_masses[{i}].at")
            m = _num(f"point_masses[{i}].mass", pm.mass, positive=True)
            with_masses.point_masses.append(ScenePointMass(pm.member, pm.at, m))
        super().__init__(with_masses)


def newton(residual: Callable, x: np.ndarray, tol: float, max_iter: int, halvings: int,
           tol_step: float = 0.0) -> tuple[np.ndarray, float, bool]:
    """Newton's method on residual(x) -> (R, jacobian), jacobian() giving the sparse dR/dx there (built only where
    a step starts), with a backtracking line search on max|R| (a step is halved until max|R| decreases by the
    fraction 1e-4 lam; after `halvings` it is taken anyway). Converged when max|R| <= tol, or after a full step of
    max|dx| <= tol_step. Returns (x, max|R|, converged); stops early on a singular Jacobian or a residual that is
    not finite."""
    R, J = residual(x)
    rn = float(np.max(np.abs(R))) if R.size else 0.0
    for _ in range(max_iter):
        if not math.isfinite(rn):
            break
        if rn <= tol:
            return x, rn, True
        try:
            dx = sp.linalg.spsolve(sp.csc_matrix(J()), -R.ravel()).reshape(x.shape)
        except Exception:  # noqa: BLE001  (a singular Jacobian)
            break
        if not np.all(np.isfinite(dx)):
            break
        lam = 1.0
        for k in range(halvings):  # backtrack on the residual (rotations of a stiff cable overshoot)
            xn = x + lam * dx
            Rn, Jn = residual(xn)
            rnn = float(np.max(np.abs(Rn)))
            if math.isfinite(rnn) and rnn < (1 - 1e-4 * lam) * rn:
                break
            if k < halvings - 1:
                lam *= 0.5
        x, R, J, rn = xn, Rn, Jn, rnn
        if lam == 1.0 and float(np.max(np.abs(dx))) <= tol_step:
            return x, rn, True
    return x, rn, rn <= tol


def check_scene(sc: Scene) -> None:
    """Refuse scenes the control transcription cannot move exactly (its Hessian needs third-derivative kernels and
    every support eliminated)."""
    for m in sc.members.values():
        if not m.element.startswith("cable"):
            raise SceneError(f"member {m.name!r}: optimal control is available for cable elements (cable2d, "
                             f"cable3d), got {m.element!r}")
        if m.arc_curvature is not None and m.bending:
            raise SceneError(f"member {m.name!r}: curved members (arcs) are not supported by the control module "
                             "(their reference curvature acts through moment kernels, which have no "
                             "third-derivative companion)")
        if len(m.points) > 2:
            raise SceneError(f"member {m.name!r}: polyline members (internal rigid joints) are not supported by "
                             "the control module; use straight members")
    for ld in sc.loads:
        if ld.kind == "moment":
            raise SceneError("moment loads are not supported by the control module (their kernels have no "
                             "third-derivative companion)")
    if getattr(sc, "dampings", None):
        kinds = sorted({d.kind for d in sc.dampings})
        raise SceneError(f"damping ({', '.join(kinds)}) is not supported by the control module yet")
    for j in sc.joints:
        if j.kind == "rigid":
            raise SceneError(f"rigid joints are not supported by the control module (multipliers), got {j}")


class ControlModel:
    """The reduced model a control problem moves (see the module docstring): built from the scene, the controls and
    the payloads alone, so that the bounds, the transcription, the warm start and the re-simulation share one
    description of the coordinates and channels.

    n, nf: full and free coordinate counts; part: the partition (x = E q + c + B s); channels (support axes, nc of
    them) and force_names (nF), nu = nc + nF controls; Mff, Mfc: mass matrix blocks; f_lin: constant forces;
    Bf: the controlled forces' columns; nonlinear: the mapped kernels of the nonlinear energy terms."""

    def __init__(self, scene: Scene, controls: Sequence, point_masses: Sequence[PointMass] = ()):
        self.scene = scene
        check_scene(scene)
        self.asm = ControlAssembly(scene, point_masses)
        self._partition()
        self._channels(controls)
        self._matrices()
        self._build_point_functions()

    def _partition(self) -> None:
        """The free coordinates: every support and joint eliminated (the transcription has no multiplier rows)."""
        a = self.asm
        if a.penalty is not None:
            raise SceneError("penalty supports/joints are not supported by the control module; use method='exact'")
        self.reduced = ReducedModel(a)  # (the reduced coordinates statics and dynamics build on too)
        self.part = part = self.reduced.part
        if len(part.rows):
            raise SceneError("the control module needs every support and joint eliminated (pins, clamps of "
                             "axis-aligned members, hinges); constraints with multipliers remain: "
                             f"{[a.exact.labels[r] for r in part.rows]}")
        self.n, self.nf = a.n, part.ny
        self.pos = part.pos
        self.E = part.E

    def _channels(self, controls: Sequence) -> None:
        """The control channels (one per moved support axis) and the controlled forces, checked and named."""
        if not isinstance(controls, (list, tuple)) or not controls:
            raise SceneError("controls must be a non-empty list of SupportMotion / PointForce")
        self.channels, self.chan_coord, self.chan_axis, self.chan_support = [], [], [], []
        self.force_names, self.force_vecs = [], []
        names: set = set()
        for i, c in enumerate(controls):
            if isinstance(c, SupportMotion):
                self._support_motion(i, c, names)
            elif isinstance(c, PointForce):
                self._point_force(i, c, names)
            else:
                raise SceneError(f"controls[{i}] must be SupportMotion or PointForce, got {c!r}")
        self.controls = list(controls)
        self.nc, self.nF = len(self.channels), len(self.force_names)
        self.nu = self.nc + self.nF
        self.acc_index = list(range(self.nc))
        self.force_index = list(range(self.nc, self.nu))

    def _support_motion(self, i: int, c: SupportMotion, names: set) -> None:
        """Channels of a moved support: it must be an exact pin or clamp, not a joint, on fixed coordinates."""
        a, sc = self.asm, self.scene
        dim = sc.dim
        if c.member not in sc.members:
            raise SceneError(f"controls[{i}]: member {c.member!r} does not exist; members: "
                             f"{sorted(sc.members)}")
        sc.check_at(c.member, c.at, node_only=True, field_name=f"controls[{i}].at")
        mm = a.mesh.members[c.member]
        node = mm.node(c.at)
        sup = [s for s in sc.supports if s.member == c.member and s.kind in ("pin", "clamp")
               and mm.node(s.at) == node]
        if not sup:
            raise SceneError(f"controls[{i}] ({c.name!r}) moves a support at {c.member}@{c.at!r}, but there "
                             f"is no pin or clamp there; supports: "
                             f"{[(s.kind, s.member, s.at) for s in sc.supports] or 'none'}")
        if any(s.method != "exact" for s in sup):
            raise SceneError(f"controls[{i}]: the support at {c.member}@{c.at!r} must be exact, not penalty")
        for j in sc.joints:
            for end in (j.a, j.b):
                if end[0] == c.member and mm.node(end[1]) == node:
                    raise SceneError(f"controls[{i}]: the moved node {c.member}@{c.at!r} is also a joint")
        axes = tuple(c.axes) if isinstance(c.axes, (tuple, list)) else (c.axes,)
        if not axes or any(isinstance(ax, bool) or ax not in range(dim) for ax in axes) or \
                len(set(axes)) != len(axes):
            raise SceneError(f"controls[{i}].axes must be distinct axes in 0..{dim - 1}, got {c.axes!r}")
        dofs = mm.node_dofs(node)
        for ax in axes:
            ch = c.name if len(axes) == 1 else f"{c.name}_{'xyz'[ax]}"
            if ch in names:
                raise SceneError(f"controls[{i}]: name {ch!r} used twice")
            names.add(ch)
            if self.pos[dofs[ax]] >= 0:
                raise SceneError(f"controls[{i}]: coordinate {ax} of {c.member}@{c.at!r} is not fixed")
            self.channels.append(ch)
            self.chan_coord.append(int(dofs[ax]))
            self.chan_axis.append(ax)
            self.chan_support.append((c.member, node))

    def _point_force(self, i: int, c: PointForce, names: set) -> None:
        """A controlled dead force: its generalized force per newton along the unit direction."""
        a, sc = self.asm, self.scene
        if c.member not in sc.members:
            raise SceneError(f"controls[{i}]: member {c.member!r} does not exist; members: "
                             f"{sorted(sc.members)}")
        sc.check_at(c.member, c.at, node_only=False, field_name=f"controls[{i}].at")
        d = vector(f"controls[{i}].direction", c.direction, sc.dim)
        if np.linalg.norm(d) == 0:
            raise SceneError(f"controls[{i}].direction must not be zero")
        if c.name in names:
            raise SceneError(f"controls[{i}]: name {c.name!r} used twice")
        names.add(c.name)
        mm = a.mesh.members[c.member]
        s = mm.coordinate(c.at)
        idx, val = point_force(mm, s, d / np.linalg.norm(d))
        vec = np.zeros(self.n)
        np.add.at(vec, idx, val)
        self.force_names.append(c.name)
        self.force_vecs.append(vec)

    def _matrices(self) -> None:
        """The constant matrices of the reduced dynamics and the nonlinear terms (each needs a third-derivative
        kernel for the exact Hessian)."""
        a, part = self.asm, self.part
        B = np.zeros((self.n, self.nc))
        for k, cd in enumerate(self.chan_coord):
            B[cd, k] = 1.0
        self.B = B
        # rigid translation fields of each channel's axis (position coordinates of every node)
        Tr = np.zeros((self.n, self.nc))
        for mm in a.mesh.members.values():
            for node in range(mm.n_nodes):
                d = mm.node_dofs(node)
                for k, ax in enumerate(self.chan_axis):
                    Tr[d[ax], k] = 1.0
        self.Tr = Tr
        M = a.mass_matrix().tocsc()
        self.M_full = M
        self.Mff = part.reduce_matrix(M)
        self.Mfc = part.reduce_matrix(M, B)
        # constant forces: linear energy terms (gravity, distributed dead loads) and dead point loads incl. weights
        self.f_lin_full = f_lin = a.constant_force()
        self.f_lin = part.E.T @ f_lin
        self.Bf = part.E.T @ np.column_stack(self.force_vecs) if self.nF else np.zeros((self.nf, 0))
        self.nonlinear = [mk for mk in a.mapped if mk.term.effect not in LINEAR_EFFECTS]
        for mk in self.nonlinear:
            t = mk.term
            if not registry.has_third_derivatives(t.element, t.effect, t.gauss):
                raise SceneError(f"{t.element}/{t.effect} (gauss {t.gauss}) has no third-derivative kernel, which the "
                                 f"exact Hessian needs; available: {list(registry.THIRD_DERIVATIVE_EFFECTS)} at the "
                                 "default quadrature")
        self.length_scale = max(float(mm.member.length) for mm in a.mesh.members.values())

    def variable_names(self) -> list[str]:
        """The names bounds and path constraints use: <channel>.position/.velocity/.acceleration, <force>.force."""
        out = []
        for ch in self.channels:
            out += [f"{ch}.position", f"{ch}.velocity", f"{ch}.acceleration"]
        return out + [f"{f}.force" for f in self.force_names]

    def chan_vector(self, values: dict) -> np.ndarray:
        """The channels' values (dict by channel name) as a vector in channel order."""
        return np.array([values[ch] for ch in self.channels], float)

    def translated(self, q: np.ndarray, ds: np.ndarray) -> np.ndarray:
        """Free coordinates of the scene translated with the supports by ds (exact for single-support scenes)."""
        return q + self.part.E.T @ (self.Tr @ ds) if self.nc else q.copy()

    # -- point functions (one instant) -----------------------------------------------------------------------
    def full(self, q: np.ndarray, s: np.ndarray) -> np.ndarray:
        """All coordinates from the free ones q and the channel displacements s."""
        return self.part.E @ q + self.part.c + self.B @ s

    def _build_point_functions(self) -> None:
        """forces(q, s) -> (grad_f U, K_ff, K_fc) at one instant (Newton for the equilibria, modes): the kernels'
        gradients and Hessians scattered onto the unknowns [q; s] (free coordinates, then the control channels)."""
        nf, nc = self.nf, self.nc
        q, s = ca.MX.sym("q", nf), ca.MX.sym("s", nc)
        pos = self.pos.copy()  # the controlled support coordinates become unknowns nf + channel
        pos[self.chan_coord] = nf + np.arange(nc)
        x = full_mx(ca.vertcat(q, s), pos, self.part.c)
        calls = []
        for mk in self.nonlinear:
            t = mk.term
            _, G, H = mk.kernel.map(mk.N)(ca.reshape(x[t.idx.ravel().tolist()], mk.nd, mk.N), ca.DM(mk.P.T))
            calls.append((t.idx, G, H))
        g, K = assemble_mx(calls, pos, nf + nc)
        self.forces_f = ca.Function("control_forces", [q, s], [g[:nf], K[:nf, :nf], K[:nf, nf:]], ["q", "s"],
                                    ["g", "Kff", "Kfc"])

    def forces(self, q: np.ndarray, s: np.ndarray) -> tuple[np.ndarray, sp.csc_matrix, np.ndarray]:
        """(grad_f U, K_ff sparse, K_fc) at one instant, for Newton on equilibria and interval equations."""
        g, Kff, Kfc = self.forces_f(q, s)
        return np.asarray(g).ravel(), sp.csc_matrix(Kff.sparse()), np.asarray(Kfc)

    def equilibrium(self, s: np.ndarray, guess: np.ndarray | None = None, max_iter: int = 60) -> np.ndarray:
        """Static equilibrium of the free coordinates with the controlled supports displaced by s (Newton with
        a backtracking line search on the residual; from the reference state unless a guess is given)."""
        if guess is None:
            q = self.translated(self.asm.x0[self.part.roots].copy(), s)
        else:
            q = np.asarray(guess, float).copy()
        fscale = max(float(np.max(np.abs(self.f_lin))), 1e-300)

        def residual(q):
            g, K, _ = self.forces(q, s)
            return g - self.f_lin, lambda: K
        q, rn, ok = newton(residual, q, 1e-10 * fscale + 1e-12, max_iter, halvings=30)
        if ok or rn <= 1e-7 * fscale:  # (a residual at round-off after max_iter iterations)
            return q
        raise SceneError(f"no static equilibrium found for support displacements {s.tolist()} (residual {rn:.3g} N "
                         f"after {max_iter} Newton iterations): the start/end state cannot be at rest")

    def vibration_modes(self, q: np.ndarray, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Natural frequencies [rad/s] and M-orthonormal modes of the free coordinates about (q, s)."""
        _, K, _ = self.forces(q, s)
        Kd = K.toarray()
        Kd = 0.5 * (Kd + Kd.T)
        w2, Phi = sla.eigh(Kd, self.Mff.toarray())
        return np.sqrt(np.maximum(w2, 0.0)), Phi

    # -- probes -----------------------------------------------------------------------------------------------
    def probe(self, member: str, at: Any) -> tuple[np.ndarray, np.ndarray]:
        """(idx (dim, 4) global coordinates, weights (4,)) with r(s) = x[idx] @ w."""
        sc = self.scene
        sc.check_at(member, at, node_only=False, field_name="point.at")
        mm = self.asm.mesh.members[member]
        p = Probe(mm, mm.coordinate(at), sc.dim)
        return p.idx, p.w


def end_mode_count(omega: np.ndarray, nf: int, end_modes: int | None, end_frequency: float | None, K: int,
                   T: float) -> int:
    """How many of the lowest modes (frequencies omega [rad/s]) the end-at-rest rows hold: end_modes if given,
    else those below end_frequency [Hz], default K / (4 T): the modes a grid of K intervals over T resolves."""
    if end_modes is not None:
        return min(int(end_modes), nf)
    f_cut = end_frequency if end_frequency is not None else K / (4.0 * T)
    return max(1, int(np.sum(omega < 2 * np.pi * f_cut)))


class StateView:
    """The state at one instant as CasADi expressions, for path constraints: x, v (full coordinates and velocities),
    point(member, at) / velocity(member, at) of a centreline point, and the support channels and controls by name."""

    def __init__(self, model: ControlModel, x: ca.MX, v: ca.MX, chan_pos: ca.MX, chan_vel: ca.MX, u: ca.MX):
        self._p, self.x, self.v = model, x, v
        self._cp, self._cv, self._u = chan_pos, chan_vel, u

    def point(self, member: str, at: Any = "end"):
        idx, w = self._p.probe(member, at)
        return ca.vertcat(*[ca.dot(ca.DM(w), self.x[row.tolist()]) for row in idx])

    def velocity(self, member: str, at: Any = "end"):
        idx, w = self._p.probe(member, at)
        return ca.vertcat(*[ca.dot(ca.DM(w), self.v[row.tolist()]) for row in idx])

    def __getitem__(self, key: str):
        name, _, what = key.rpartition(".")
        p = self._p
        if name in p.channels and what in ("position", "velocity", "acceleration"):
            k = p.channels.index(name)
            return {"position": self._cp, "velocity": self._cv, "acceleration": self._u}[what][
                k if what != "acceleration" else p.acc_index[k]]
        if name in p.force_names and what == "force":
            return self._u[p.force_index[p.force_names.index(name)]]
        raise SceneError(f"unknown state or control {key!r}; known: {p.variable_names()}")
