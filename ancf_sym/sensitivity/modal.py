"""Exact derivatives of natural frequencies with respect to scene parameters, the prestress change included.

For a simple eigenvalue w^2 with M-normalised mode phi (phi' M phi = 1, G phi = 0):

    d w^2 / dp = phi' (dK_L/dp - w^2 dM/dp) phi,    dK_L/dp = dK/dp|_x + D K[dx*/dp]

dK/dp|_x: the kernels' Hessians with their coefficients' derivatives (ancf_sym.sensitivity.model_derivative);
D K[dx]: the third derivatives of the elastic energies along the static sensitivity dx*/dp (the kernels'
compiled Hessian-vector companions: phi' (d(H phi)/dq) dx), plus the multipliers' change times the constraint
curvature of bilinear rows, and 2 mu'(dG phi) of those rows turning with dx (mu: the mode's multipliers).
Exact contact: the points held at the equilibrium are rows of G as in the statics' sensitivity; a drum's rows add
their curvature's change -sum (df_i Hess g_i + f_i D Hess g_i [dx]) and their turn 2 mu'(Hess g dx phi)
(ancf_sym.sensitivity.contact_state.drum_form; ground rows are linear); an equilibrium with a point at zero gap and
zero force is refused (the active set, and with it the frequencies, change one-sidedly there).
Frequencies f = w / 2 pi: df/dp = (d w^2/dp) / (8 pi^2 f). Repeated frequencies have
no derivative (their modes mix): such a pair is reported as NaN with the reason in `notes`.
"""
from __future__ import annotations

import casadi as ca
import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ancf_sym.contact import laws as contact
from ancf_sym import kernels, registry
from ancf_sym.modal.result import ModalResult
from ancf_sym.scene.builder import Scene
from ancf_sym.model.reduced import partition
from ancf_sym.contact import exact as contact_exact
from ancf_sym.modal.contact_rows import contact_points
from ancf_sym.sensitivity.contact_state import curved_contact_rows, drum_form, drum_terms
from ancf_sym.sensitivity.model_derivative import ParameterError
from ancf_sym.sensitivity.static import StaticSensitivity
from ancf_sym.sensitivity.water_derivative import unsymmetric, water_terms

REPEATED_REL = 1e-6  # relative gap below which two frequencies count as one repeated eigenvalue

_HVP: dict = {}


def _hvp(element: str, effect: str, N: int) -> ca.Function:
    key = (element, effect, N)
    if key not in _HVP:
        _HVP[key] = kernels.load_hvp(element, effect).map(N)
    return _HVP[key]


class ModalSensitivity:
    """Frequency derivatives of a modal result (its static equilibrium's sensitivity inside)."""

    def __init__(self, modal: ModalResult, scene: Scene, doc: dict):
        if not modal.success:
            raise ValueError(f"frequency sensitivities need a successful modal result (status {modal.status!r})")
        self.modal = modal
        # (with exact contact, the static sensitivity refuses a point touching without pressing)
        self.static = StaticSensitivity(scene, modal.static, doc, modal.linearization, "frequency sensitivities")
        asm = self.static.asm
        self._rows = partition(asm).rows  # the exact rows kept with multipliers (rows of G)
        self._water = water_terms(asm)  # (lines in water: the water line's and the added mass's state derivatives)
        self._left = unsymmetric(asm)  # (lines in a current: K unsymmetric, the left eigenvectors enter)
        if self._left and self.static.m:
            raise ParameterError("frequency sensitivities of lines in a current with constraint rows kept with "
                                 "multipliers (rigid joints, bodies, exact contact) are not available")
        if contact.exact_contacts(asm):  # the held points are rows (as in the statics' sensitivity)
            drums = curved_contact_rows(asm)
            if drums:
                raise ParameterError(f"frequency sensitivities with exact drum contact on beam3d members or spatial "
                                     f"bodies (members {drums}) are not available: the drum rows' curvature changes "
                                     "with the state, which needs their gap kernels' third derivatives (not compiled)")
        if asm.penalty is not None and len(asm.penalty.qrow):
            raise ParameterError("frequency sensitivities with penalty rigid joints are not available")
        for mk in asm.curved:
            t = mk.term
            if not registry.has_third_derivatives(t.element, t.effect, t.gauss):
                raise ParameterError(f"frequency sensitivities need the third derivatives of every curved energy; "
                                     f"{t.element}/{t.effect} (gauss {t.gauss}) has none compiled")

    def _third(self, dx: np.ndarray, phi: np.ndarray) -> float:
        """phi' (D K[dx]) phi over the curved kernels."""
        x, out = self.modal.static.x, 0.0
        for mk in self.static.asm.curved:
            t = mk.term
            N = len(t.idx)
            dhv = _hvp(t.element, t.effect, N)(x[t.idx].T, t.P.T, phi[t.idx].T)[1].full()
            nd = t.idx.shape[1]
            D = dhv.reshape(nd, N, nd).transpose(1, 0, 2)  # per element d(H phi)/dq
            out += float(np.einsum("ei,eij,ej->", phi[t.idx], D, dx[t.idx]))
        return out

    def _third_vector(self, dx: np.ndarray, phi: np.ndarray) -> np.ndarray:
        """(D K[dx]) phi on the full coordinates over the curved kernels (d(H phi)/dq dx per element)."""
        x, n = self.modal.static.x, len(dx)
        out = np.zeros(n)
        for mk in self.static.asm.curved:
            t = mk.term
            N, nd = t.idx.shape
            dhv = _hvp(t.element, t.effect, N)(x[t.idx].T, t.P.T, phi[t.idx].T)[1].full()
            D = dhv.reshape(nd, N, nd).transpose(1, 0, 2)
            out += np.bincount(t.idx.ravel(), np.einsum("eij,ej->ei", D, dx[t.idx]).ravel(), minlength=n)
        return out

    def shape_derivative(self, path: str) -> np.ndarray:
        """d(mode shapes)/dp, full coordinates (n, modes), of the M-normalised shapes (phi' M phi = 1 kept): per
        mode Nelson's bordered system, with the rows G of the points held in exact contact (y: the reduced mode,
        mu its multipliers, K_L y + G'mu = w^2 M y, G y = 0):

            [K - w^2 M  G'  M y] [dy ]   [-(dK - dw^2 M - w^2 dM) y - dG'mu]
            [G          0   0  ] [dmu] = [-dG y                           ]
            [y'M        0   0  ] [c  ]   [-y'dM y / 2                     ]

        (dK: the kernels' tangents' derivatives, the prestress's change and, on a drum, the held points' curvature
        -sum f_i Hess g_i changing; dG: a drum row turning with the state, Hess g_i dx; ground rows are constant).
        Scenes with rigid joints (bilinear rows): not available. Repeated frequencies: NaN columns."""
        m, s = self.modal, self.static
        lin, asm = s.lin, s.asm
        if self._left:
            raise ParameterError("mode-shape derivatives of lines in a current (an unsymmetric K) are not available "
                                 "(frequencies are)")
        if len(asm.exact.qrow):
            raise ParameterError("mode-shape derivatives with rigid joints (bilinear constraint rows kept in the "
                                 "modes) are not available")
        x = m.static.x
        md = s.model(path)
        dR = md.residual(x)[1]
        dx, dmu = s.solve(dR)
        df, _ = self.derivative(path)
        E, G = lin.E, lin.G
        ng, nr = G.shape[0], len(self._rows)
        drums = contact.exact_contacts(asm) and any(r.A is None for r in contact_exact.rows(asm))
        if drums:
            fc, _, active = contact_points(asm, m.static)
        EtE = (E.T @ E).tocsc()
        out = np.full((len(x), m.modes), np.nan)
        for k in range(m.modes):
            if not np.isfinite(df[k]) or m.zero[k]:
                continue
            w2, phi = m.omega2[k], m.shapes[:, k]
            y = spla.spsolve(EtE, E.T @ phi)
            dw2 = df[k] * 8 * np.pi ** 2 * m.frequencies[k]
            dKphi = md.hessian_vector(x, phi) + self._third_vector(dx, phi)
            turn = np.zeros(ng)
            if drums:  # (the drum rows' curvature changing, dG'mu, and the rows' turn dG y)
                v, turn[nr:] = drum_terms(asm, x, fc, active, -dmu[nr:], self._mode_multipliers(k)[nr:], phi, dx)
                dKphi = dKphi + v
            dMphi = E.T @ (md.dM @ phi) if md.dM is not None else np.zeros(len(y))
            if self._water is not None:  # (the water line's change along dx; the added mass's at x and along dx)
                dKphi = dKphi + self._water.third_vector(x, dx, phi)
                dMphi = dMphi + E.T @ self._water.mass_vectors(x, phi, dx)[1]
                if md.water is not None and md.water.added_mass_moves():  # (md.dM: at the reference's tangents)
                    dMphi = dMphi + E.T @ (md.water.mass_vectors(x, phi, dx)[0] -
                                           md.water.mass_vectors(asm.x0, phi, dx)[0])
            My = lin.M @ y
            col, row = sp.csc_matrix(My[:, None]), sp.csr_matrix(My[None, :])
            A = sp.bmat([[lin.K - w2 * lin.M, G.T, col], [G, None, None], [row, None, None]] if ng else
                        [[lin.K - w2 * lin.M, col], [row, None]], format="csc")
            rhs = np.r_[-(E.T @ dKphi - dw2 * My - w2 * dMphi), -turn, -0.5 * float(y @ dMphi)]
            out[:, k] = E @ spla.spsolve(A, rhs)[:len(y)]
        return out

    def _unsymmetric(self, k: int, md, x: np.ndarray, dx: np.ndarray) -> tuple[float, str | None]:
        """(d f_k/dp, note) of lines in a current (no constraint rows): the left eigenvector psi of the reduced
        pencil by two steps of inverse iteration on (K - sigma M)' next to w^2 (its error shrinks by (sigma - w^2) /
        (gap) each step: sigma = w^2 (1 + 1e-9) leaves ~1e-18), then d w^2/dp = psi' (dK - w^2 dM) phi / psi' M phi
        with dK the kernels' and the water's (the drag's load stiffness included) at fixed x plus their change along
        dx. A complex w^2 (a mode the current feeds) has no frequency derivative here: NaN with a note."""
        m, lin = self.modal, self.static.lin
        if m.omega2_imag is not None and m.omega2_imag[k] != 0.0:
            return np.nan, f"mode {k}: complex w^2 (the current feeds or damps it): no frequency derivative"
        E, w2, phi = lin.E, float(m.omega2[k]), m.shapes[:, k]
        y = spla.spsolve((E.T @ E).tocsc(), E.T @ phi)
        lu = spla.splu((lin.K - w2 * (1 + 1e-9) * lin.M).T.tocsc())
        z = lin.M.T @ y
        for _ in range(2):
            z = lu.solve(z)
            z = z / np.linalg.norm(z)
        psi = E @ z
        dK = md.hessian_form(x, phi, psi) + float(psi @ self._third_vector(dx, phi))
        dK += self._water.third_form(x, dx, phi, psi)
        dM = float(psi @ (md.dM @ phi)) if md.dM is not None else 0.0
        dM += self._water.mass_form(x, phi, dx, psi)[1]
        if md.water is not None and md.water.added_mass_moves():  # (md.dM: at the reference's tangents)
            x0 = self.static.asm.x0
            dM += md.water.mass_form(x, phi, dx, psi)[0] - md.water.mass_form(x0, phi, dx, psi)[0]
        dw2 = (dK - w2 * dM) / float(z @ (lin.M @ y))
        return dw2 / (8 * np.pi ** 2 * m.frequencies[k]), None

    def _mode_multipliers(self, k: int) -> np.ndarray:
        """The mode's multipliers mu of the rows of G (K_L y + G'mu = w^2 M y, least squares)."""
        lin = self.static.lin
        E = lin.E
        y = spla.spsolve((E.T @ E).tocsc(), E.T @ self.modal.shapes[:, k])
        r = self.modal.omega2[k] * (lin.M @ y) - lin.K @ y
        return np.linalg.lstsq(lin.G.T.toarray(), r, rcond=None)[0]

    def _row_turn(self, k: int, dx: np.ndarray) -> float:
        """2 mu'(dG phi): the kept bilinear rows turn with dx (G phi = 0 must hold for the perturbed mode too), mu
        the mode's multipliers."""
        lin, asm = self.static.lin, self.static.asm
        if not lin.G.shape[0]:
            return 0.0
        phi = self.modal.shapes[:, k]
        mu = self._mode_multipliers(k)
        mu_all = np.zeros(asm.exact.m)
        mu_all[self._rows] = mu[:len(self._rows)]  # (contact rows after them: drum_form)
        return 2.0 * float(dx @ (asm.exact.hessian(mu_all) @ phi))

    def derivative(self, path: str) -> tuple[np.ndarray, list[str]]:
        """(d frequencies / dp [Hz per unit], notes)."""
        m, s = self.modal, self.static
        x = m.static.x
        md = s.model(path)
        dPi, dR = md.residual(x)
        dx, dmu = s.solve(dR)
        asm = s.asm
        dlam = None
        if len(asm.exact.qrow):  # bilinear rows: their curvature weighted by the multipliers' change
            forces = s.force_derivatives(dx, dR, dmu)
            taken: dict = {}
            dlam = []
            for lbl in asm.exact.labels:
                k = taken.get(lbl, 0)
                dlam.append(float(forces[lbl][k]))
                taken[lbl] = k + 1
            Hq = asm.exact.hessian(np.asarray(dlam))
        drums = None
        if contact.exact_contacts(asm) and any(r.A is None for r in contact_exact.rows(asm)):
            fc, _, active = contact_points(asm, m.static)  # (the held points' forces change: -dmu of their rows)
            drums = (fc, active, -dmu[len(self._rows):])
        out, notes = np.zeros(m.modes), []
        f = m.frequencies
        for k in range(m.modes):
            if m.zero[k]:
                continue
            others = np.delete(f, k)
            if np.any(np.abs(others - f[k]) <= REPEATED_REL * abs(f[k])):
                out[k] = np.nan
                notes.append(f"mode {k}: repeated frequency {f[k]:.6g} Hz has no derivative")
                continue
            phi = m.shapes[:, k]
            if self._left:  # (an unsymmetric K: d w^2 = psi' (dK - w^2 dM) phi / psi' M phi, psi the left vector)
                out[k], note = self._unsymmetric(k, md, x, dx)
                notes += [note] if note else []
                continue
            dK = md.hessian_form(x, phi, phi) + self._third(dx, phi)
            if dlam is not None:
                dK += float(phi @ (Hq @ phi)) + self._row_turn(k, dx)
            if drums is not None:
                fc, active, dfc = drums
                dK += drum_form(asm, x, fc, active, dfc, self._mode_multipliers(k)[len(self._rows):], phi, dx)
            dM = float(phi @ (md.dM @ phi)) if md.dM is not None else 0.0
            if self._water is not None:  # (the water line's Jacobian and the turning added mass move with dx)
                dK += self._water.third_form(x, dx, phi)
                dM += self._water.mass_form(x, phi, dx)[1]
                if md.water is not None and md.water.added_mass_moves():  # (md.dM: at the reference's tangents)
                    dM += md.water.mass_form(x, phi, dx)[0] - md.water.mass_form(asm.x0, phi, dx)[0]
            dw2 = dK - m.omega2[k] * dM
            out[k] = dw2 / (8 * np.pi ** 2 * f[k])
        return out, notes
