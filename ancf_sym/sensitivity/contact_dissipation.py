"""Contact damping and friction in the dynamic sensitivities: the parameters contacts[i].mu | damping, the part of
contacts[i].stiffness | hertz that acts through the friction force, and the notes on where the derivative of a
run with penalty contacts is one-sided.

The dissipation function of a contact point (ancf_sym.elements.contact)

    D = 1/2 c delta (n.w)^2 + mu (k delta + kh delta^1.5) (sqrt(|w_t|^2 + eps^2) - eps)

is linear in c, in mu, and (at fixed mu) in the normal law's (k, kh) jointly, so its force f_d = dD/dv and the
force's derivative with respect to one of them at fixed (q, v) is the compiled dissipation kernel itself with its
parameter columns replaced: d/dc (c = 1, mu = 0), d/dmu (c = 0, mu = 1), d/dk (c = 0, k = 1, kh = 0), d/dkh
(c = 0, k = 0, kh = 1): exact, no difference quotient. The force's exact tangents df_d/dq, df_d/dv are already in
the step system's dissipation graph (ancf_sym.system.damping), hence in the differentiated step's matrix and its
velocity term (ancf_sym.sensitivity.alpha_run.step_matrix).

Where the derivative is not defined: the regularised Coulomb law is smooth in the slip velocity (there is no
stick-slip kink: across |w_t| ~ eps its slope mu f_n / eps is steep but finite), and the penetration max(0, -gap)
has a kink at zero gap, where a contact point touches down or lifts off. `notes` names the steps after which the
set of contact points (the laws' Gauss points) with positive penetration changes.

Statics and modal analysis: a static equilibrium and its undamped frequencies do not depend on mu or c (the
friction and damping forces vanish at rest): those paths are refused there by name
(ancf_sym.sensitivity.model_derivative), not answered with zeros a calibration could not use.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ancf_sym import kernels
from ancf_sym.contact import gap as contact_gap
from ancf_sym.contact import laws as contact
from ancf_sym.elements.quadrature import gauss01
from ancf_sym.scene.builder import SceneError
from ancf_sym.sensitivity.paths import get_parameter, parse_path
from ancf_sym.util.casadi_buffers import bind

DISSIPATION_KEYS = ("mu", "damping")  # parameters of the dissipation alone
LAW_KEYS = ("stiffness", "hertz")  # the normal law's: they scale the friction force too


def dissipation_index(doc: dict, path: str) -> int | None:
    """i of a path contacts[i].mu | damping (a contact's friction coefficient or damping, which act on velocities
    only), else None; checked: the contact exists and is a penalty contact."""
    p = parse_path(path)
    if p.keys[0] != "contacts" or len(p.keys) != 3 or p.keys[2] not in DISSIPATION_KEYS:
        return None
    get_parameter(doc, path)
    if doc["contacts"][p.keys[1]].get("method", "penalty") != "penalty":
        raise SceneError(f"parameter path {path!r}: an exact contact has no friction or damping")
    return p.keys[1]


def _column(names: list, key: str) -> int:
    return names.index({"damping": "c", "mu": "mu", "stiffness": "k", "hertz": "kh"}[key])


def _unit_parameters(element: str, effect: str, P: np.ndarray, key: str) -> np.ndarray:
    """The kernel's parameter rows whose dissipation is dD/dp for p the contact's `key` (module docstring)."""
    names = kernels.parameters(element, effect)
    U = np.array(P, float)
    U[:, _column(names, "damping")] = 0.0
    if key == "mu":
        U[:, _column(names, "mu")] = 1.0
    elif key == "damping":
        U[:, _column(names, "damping")] = 1.0
        U[:, _column(names, "mu")] = 0.0
    else:  # (mu kept: the friction force mu f_n(k, kh) ..., linear in k and kh jointly)
        U[:, _column(names, "stiffness")] = 1.0 if key == "stiffness" else 0.0
        U[:, _column(names, "hertz")] = 1.0 if key == "hertz" else 0.0
    return U


_MAPPED: dict = {}


def dissipation_forcing(run, path: str) -> np.ndarray | None:
    """d f_d/dp at fixed states for every stored state (run: an alpha_run.AlphaRun), on the reduced coordinates
    (steps + 1, nf); None where p changes no contact's dissipation force (another path, a stiffness of a contact
    without friction)."""
    p = parse_path(path)
    if p.keys[0] != "contacts" or len(p.keys) != 3 or p.keys[2] not in DISSIPATION_KEYS + LAW_KEYS:
        return None
    c = run.scene.contacts[p.keys[1]]
    key = p.keys[2]
    if c.method != "penalty" or (key in LAW_KEYS and not c.mu):
        return None
    mesh = run.asm.mesh
    effect, idx, P = contact.kernel_call(c, mesh, True)
    element = mesh.members[c.member].member.element
    gauss = None if c.gauss == 5 else c.gauss
    U = _unit_parameters(element, effect, P, key)
    X, V = run.X, run.V_full
    k, (ne, nd) = len(X), idx.shape
    fk = (element, effect, gauss, k * ne)
    if fk not in _MAPPED:
        _MAPPED[fk] = kernels.load_grad(element, effect, gauss).map(k * ne)
    Z = np.concatenate([X[:, idx], V[:, idx]], axis=2)  # (k, ne, 2 nd): each element's [q; v]
    e, g = np.zeros(k * ne), np.zeros(k * ne * 2 * nd)
    _, evaluate = bind(_MAPPED[fk], [np.ascontiguousarray(Z).ravel(), np.ascontiguousarray(np.tile(U, (k, 1))).ravel()],
                       [e, g])
    evaluate()
    fv = g.reshape(k, ne, 2 * nd)[:, :, nd:].reshape(k, ne * nd)  # (the v-part of D's gradient: the force)
    # (element rows summed onto the unknowns: E' times the scatter of (element, row) to its coordinate)
    scatter = sp.csr_matrix((np.ones(idx.size), (np.arange(idx.size), idx.ravel())), shape=(idx.size, X.shape[1]))
    return np.asarray((fv @ (scatter @ run.S.E)))


def point_gaps(asm, c, X: np.ndarray) -> np.ndarray:
    """(states, elements x gauss) the gap at the law's own points (its Gauss points) in the full states X: ground,
    fixed drums and drums carried by bodies (their centre and axis in each state, contact.gap.surfaces)."""
    A = contact_gap.cubic(asm, c, X)  # (S, n_el, 4, d)
    S, ne = A.shape[:2]
    xi = gauss01(c.gauss)[0]
    powers = np.vander(xi, 4, increasing=True)  # (gauss, 4)
    r = np.einsum("gk,snkd->sngd", powers, A)
    if not contact_gap.is_drum(c):
        g = r @ c.normal - c.level - c.thickness
    else:
        centre, P = contact_gap.surfaces(asm, c, X)
        d = np.einsum("sngd,sed->snge", r - centre[:, None, None, :], P)
        g = np.linalg.norm(d, axis=3) - c.radius - c.thickness
    return g.reshape(S, ne * len(xi))


def dissipation_notes(run) -> list[str]:
    """What the derivative of a run with contact damping or friction does and does not cover: the steps where a
    contact point of a dissipative contact touches down or lifts off (its gap at the step's end changes sign: the
    kink of max(0, -gap) in the normal, damping and friction forces), and the regularised friction law's
    smoothness. Empty without dissipative contacts."""
    notes = []
    for i, c in enumerate(run.scene.contacts):
        if not c.dissipative:
            continue
        what = " and ".join(w for w, on in (("damping", c.damping), ("friction", c.mu)) if on)
        on = point_gaps(run.asm, c, run.X)[1:] < 0.0  # (the states after each step; the start is the reference)
        change = np.flatnonzero(np.any(on[1:] != on[:-1], axis=1)) + 2
        if len(change):
            t = run.t[change]
            notes.append(f"contacts[{i}] ({what}): contact points touch down or lift off in {len(change)} step(s) "
                         f"(first at t = {t[0]:.6g} s, last at {t[-1]:.6g} s): the penetration's kink at zero gap "
                         "makes the derivative one-sided there")
        else:
            notes.append(f"contacts[{i}] ({what}): no contact point touches down or lifts off after the first step")
        if c.mu:
            notes.append(f"contacts[{i}] friction: the regularised Coulomb law (eps = {c.eps:g} m/s) is smooth in "
                         "the slip velocity: stick-slip transitions are no kink of it, and its derivative is exact "
                         f"across them (steep, slope mu f_n / eps, where the slip speed is below eps)")
    return notes

