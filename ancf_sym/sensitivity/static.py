"""Exact sensitivities of a static equilibrium to scene parameters named by their TOML path.

At the equilibrium the reduced residual E'(grad Pi(x, p) + G'mu) = 0 with the kept constraint rows G x = 0 (rigid
joints, points in exact contact) holds for every p, so (implicit function theorem, K_L the exact Hessian of the
Lagrangian on the reduced coordinates, ancf_sym.modal.linearize):

    [K_L  G'] [dy ]     [-E' dR/dp]
    [G    0 ] [dmu]  =  [    0    ],     dx/dp = E dy

with dR/dp exact (ancf_sym.sensitivity.model_derivative). One factorisation serves every parameter (direct: one
back-substitution each); for one scalar output and many parameters the adjoint solves once with the output's
gradient and takes a dot product per parameter. Supports' and joints' reactions follow from the differentiated
stationarity J'dlambda = -(K_L dx + dR/dp + J_c' dmu_c); the potential's total derivative is its partial one (the
gradient is balanced by the constraint forces, which do no work on admissible dx).
"""
from __future__ import annotations

from typing import Callable

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ancf_sym.contact import laws as contact
from ancf_sym.modal.contact_rows import contact_points
from ancf_sym.modal.linearize import Linearization, linearize
from ancf_sym.model.reduced import partition
from ancf_sym.scene.builder import Scene
from ancf_sym.statics.problem import StaticResult
from ancf_sym.sensitivity.contact_state import check_differentiable
from ancf_sym.sensitivity.exact_contact_geometry import geometry_path, row_derivatives
from ancf_sym.sensitivity.model_derivative import ModelDerivative, model_derivative
from ancf_sym.sensitivity.paths import get_parameter
from ancf_sym.sensitivity.water_derivative import water_line_gradient


class StaticSensitivity:
    """The linearisation of one equilibrium, factorised once; derivatives of its reported quantities per parameter.

    doc: the scene document (a parsed TOML file) the scene was built from; paths address its numbers. With exact
    contact, an equilibrium with a point touching without pressing is refused (ContactStateError naming the points:
    the derivative would hold one way only); `what` names the derivative in that message."""

    def __init__(self, scene: Scene, result: StaticResult, doc: dict, linearization: Linearization | None = None,
                 what: str = "static sensitivities"):
        if not isinstance(result, StaticResult) or not result.success:
            raise ValueError("sensitivities need a successful static result (its status: "
                             f"{getattr(result, 'status', result)!r})")
        if contact.exact_contacts(result.assembly):
            check_differentiable(result.assembly, result, what)
        self.scene, self.result, self.doc = scene, result, doc
        self.water = getattr(scene, "water", None) is not None  # (lines in water: the water statics' Jacobian)
        self.lin = linearization if linearization is not None else _stiffness(scene, result)
        self.asm = self.lin.assembly
        lin = self.lin
        self.m, self.ny = lin.G.shape[0], lin.K.shape[0]
        A = sp.bmat([[lin.K, lin.G.T], [lin.G, None]]).tocsc() if self.m else lin.K.tocsc()
        try:
            self._lu = spla.splu(A)
        except RuntimeError as exc:  # (SuperLU: "Factor is exactly singular")
            raise ValueError("sensitivities: the equilibrium's tangent [K_L G'; G 0] is singular (a mechanism, or a "
                             "cable without bending stiffness in a straight state): the equilibrium does not depend "
                             f"smoothly on the parameters there ({exc})") from None
        self._derivs: dict = {}
        self._rows: dict = {}  # path -> the kept rows' terms of an exact contact's geometry

    # -- the model's derivative and the equilibrium's ------------------------------------------------------------
    def model(self, path: str) -> ModelDerivative:
        if path not in self._derivs:
            where = geometry_path(self.asm, self.doc, path)
            if where is not None:  # (an exact contact's geometry: in its rows only)
                self._derivs[path] = ModelDerivative(path, get_parameter(self.doc, path))
                self._rows[path] = self._row_terms(where)
            else:
                self._derivs[path] = model_derivative(self.asm, self.doc, path)
        return self._derivs[path]

    def _row_terms(self, where: tuple) -> tuple[np.ndarray, np.ndarray]:
        """(dg/dp of the kept rows (m: zeros for the joints'), -sum_active f_i d(grad g_i)/dp (n))."""
        dg, dgrad = row_derivatives(self.asm, self.result.x, where)
        active = self._contact_active()
        f = np.asarray(self.result.constraint_forces["contact"], float)
        dR = np.zeros(self.asm.n)
        held = set(active.tolist())
        for row, v in dgrad:
            if row in held:
                dR -= f[row] * v
        return np.r_[np.zeros(self.m - len(active)), dg[active]], dR

    def residual(self, path: str) -> tuple[float, np.ndarray, np.ndarray]:
        """(d Pi/dp at fixed x, the residual's d/dp (full coordinates), the kept rows' dg/dp (m))."""
        dPi, dR = self.model(path).residual(self.result.x)
        if path in self._rows:
            dg, dRr = self._rows[path]
            return dPi, dR + dRr, dg
        return dPi, dR, np.zeros(self.m)

    def solve(self, dR: np.ndarray, dg: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(dx, dmu) for a residual derivative dR (full coordinates) and the kept rows' dg (m; None: zero)."""
        rhs = np.r_[-(self.lin.E.T @ dR), np.zeros(self.m) if dg is None else -dg]
        sol = self._lu.solve(rhs)
        return self.lin.E @ sol[:self.ny], sol[self.ny:]

    def dx(self, path: str) -> np.ndarray:
        """d x*/dp: full coordinates of the equilibrium per unit parameter."""
        _, dR, dg = self.residual(path)
        return self.solve(dR, dg)[0]

    def derivative(self, path: str) -> dict:
        """d/dp of the reported quantities, with their keys and shapes: potential, energies.LABEL,
        members.NAME.nodes / tip, constraint_forces.LABEL."""
        x = self.result.x
        dPi, dR, dg = self.residual(path)
        dx, dmu = self.solve(dR, dg)
        md = self.model(path)
        de = md.energies(x)
        if np.any(dg):  # (grad Pi = sum f_i grad g_i works on dx: sum f_i grad g_i . dx = -sum f_i dg_i/dp)
            n_joint = self.m - len(self._contact_active())
            f = np.asarray(self.result.constraint_forces["contact"], float)[self._contact_active()]
            dPi -= float(f @ dg[n_joint:])
        if self.water:  # (the drag is no potential's: the gradient does not vanish on dx)
            dPi += float(sum(self._label_gradients().values()) @ dx)
        out = {"potential": dPi, "energies": {lbl: de.get(lbl, 0.0) + float(g @ dx)
                                              for lbl, g in self._label_gradients().items()}, "members": {}}
        for name, mm in self.asm.mesh.members.items():
            nodes = self.asm.member_coordinates(dx, name)[mm.public_nodes, :self.scene.dim]
            out["members"][name] = {"nodes": nodes, "tip": nodes[-1]}
        out["constraint_forces"] = self.force_derivatives(dx, dR, dmu)
        return out

    def _label_gradients(self) -> dict:
        """label -> gradient of that energy at the equilibrium (full coordinates), as result.energies labels them."""
        if not hasattr(self, "_grads"):
            asm, x = self.asm, self.result.x
            grads: dict = {}
            for mk in asm.mapped:
                mk(x)
                g = grads.setdefault(mk.term.label, np.zeros(asm.n))
                g += np.bincount(mk.term.idx.ravel(), mk.G.ravel(), minlength=asm.n)
            if np.any(asm.Q):
                grads["loads"] = grads.get("loads", np.zeros(asm.n)) - asm.Q
            if asm.penalty is not None:
                pc = asm.penalty
                grads["penalty"] = pc.jacobian(x).T @ (pc.k * pc.value(x))
            gw = water_line_gradient(asm, x) if self.water else None
            if gw is not None:  # (in water the water line's energy is booked under gravity)
                grads["gravity"] = grads.get("gravity", np.zeros(asm.n)) + gw
            self._grads = grads
        return self._grads

    def force_derivatives(self, dx: np.ndarray, dR: np.ndarray, dmu: np.ndarray) -> dict:
        asm, lin = self.asm, self.lin
        forces: dict[str, list] = {}
        n_joint = len(lin.multipliers) - len(self._contact_active())
        r = lin.H_full @ dx + dR
        active = self._contact_active()
        if len(active):  # the contact rows' share: their multipliers are minus the contact forces
            r = r + lin.G_full[n_joint:].T @ dmu[n_joint:]
        if asm.exact.m:
            J = asm.exact.jacobian(self.result.x).tocsc()
            cols = np.unique(J.tocsr().indices)
            Jd = J[:, cols].toarray()
            dlam = np.linalg.lstsq(Jd.T, -r[cols], rcond=None)[0]
            for lbl, v in zip(asm.exact.labels, dlam):
                forces.setdefault(lbl, []).append(float(v))
        for name, dofs in getattr(getattr(self.result, "water", None), "drive_labels", ()):
            forces[name] = [-float(r[i]) for i in dofs]  # (fairleads held by drives in water: minus the residual)
        if asm.penalty is not None:
            dc = asm.penalty.jacobian(self.result.x) @ dx
            for lbl, k, v in zip(asm.penalty.labels, asm.penalty.k, dc):
                forces.setdefault(lbl, []).append(float(k * v))
        if "contact" in self.result.constraint_forces and contact.exact_contacts(asm):
            df = np.zeros(len(self.result.constraint_forces["contact"]))
            df[active] = -dmu[n_joint:]
            forces["contact"] = df.tolist()
        return {k: np.asarray(v) for k, v in forces.items()}

    def _contact_active(self) -> np.ndarray:
        """Indices of the exact-contact points held at the equilibrium (as ancf_sym.modal.contact_rows decides)."""
        if not hasattr(self, "_active"):
            self._active = np.zeros(0, int)
            if contact.exact_contacts(self.asm):
                self._active = np.flatnonzero(contact_points(self.asm, self.result)[2])
        return self._active

    # -- one scalar output, many parameters: the adjoint -----------------------------------------------------
    def gradient(self, dJdx: np.ndarray, paths: list[str], partial: Callable[[str], float] | None = None
                 ) -> np.ndarray:
        """dJ/dp for a scalar output J(x) (its gradient dJdx on the full coordinates; `partial(path)` its explicit
        derivative, if any) and many parameters: one adjoint solve, then dJ/dp_k = partial_k - w'dR_k."""
        # (the KKT matrix is symmetric, but for lines in a current: the drag's load stiffness; transposed solve)
        w = self._lu.solve(np.r_[self.lin.E.T @ dJdx, np.zeros(self.m)], trans="T" if self.water else "N")
        wx = self.lin.E @ w[:self.ny]
        out = np.empty(len(paths))
        for k, path in enumerate(paths):
            _, dR, dg = self.residual(path)
            out[k] = -(wx @ dR) - float(w[self.ny:] @ dg) + (partial(path) if partial is not None else 0.0)
        return out


def _stiffness(scene: Scene, result: StaticResult) -> Linearization:
    """K_L, G and E of the equilibrium: the modal linearisation without its mass, damping and input matrices, built
    here directly where no row needs multipliers for its curvature (no exact contact, no bilinear rows): the usual
    scene, where the linearisation's other matrices would cost more than the sensitivity itself."""
    asm = result.assembly
    if contact.exact_contacts(asm) or len(asm.exact.qrow) or getattr(scene, "water", None) is not None:
        return linearize(scene, result, damping_matrix=False)
    part = partition(asm)
    x = result.x
    H = asm.evaluate(x, hessian=True).hessian
    K = part.reduce_matrix(H)
    K = (0.5 * (K + K.T)).tocsc()
    if len(part.rows):
        Gf = asm.exact.subset(part.rows).jacobian(x).tocsr()
    else:
        Gf = sp.csr_matrix((0, asm.n))
    G = (Gf @ part.E).tocsr()
    return Linearization(None, K, None, G, None, part.E, x, np.zeros(G.shape[0]), [], asm, H.tocsc(), Gf)


def static_sensitivities(scene: Scene, result: StaticResult, doc: dict, paths: list[str]) -> dict:
    """{path: derivative dict} (StaticSensitivity.derivative) for each path."""
    s = StaticSensitivity(scene, result, doc)
    return {p: s.derivative(p) for p in paths}
