"""The answer of a modal analysis: frequencies, mass-normalised mode shapes per member, modal masses, and the static
equilibrium they are about."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ancf_sym.statics.problem import StaticResult
from ancf_sym.modal.linearize import Linearization


@dataclass
class DampedModes:
    """The complex eigenvalues lambda [1/s] of the damped linear system (one of each conjugate pair, by |lambda|):
    frequencies = Im lambda / 2 pi [Hz] (the damped natural frequencies; 0 for an overdamped, real lambda),
    damping_ratios = -Re lambda / |lambda|. A zero (rigid) mode of the undamped analysis is one exact lambda = 0
    here, first."""
    eigenvalues: np.ndarray

    @property
    def frequencies(self) -> np.ndarray:
        return np.abs(self.eigenvalues.imag) / (2 * np.pi)

    @property
    def damping_ratios(self) -> np.ndarray:
        """-Re lambda / |lambda|; undefined for a zero (rigid) mode: NaN there (null in result.json)."""
        a = np.abs(self.eigenvalues)
        return np.divide(-self.eigenvalues.real, a, out=np.full(len(a), np.nan), where=a > 0)

    def to_dict(self) -> dict:
        return {"eigenvalues_real": self.eigenvalues.real.tolist(), "eigenvalues_imag": self.eigenvalues.imag.tolist(),
                "frequencies": self.frequencies.tolist(), "damping_ratios": self.damping_ratios.tolist()}


@dataclass
class ModalResult:
    """status/success: the static solve's and the eigen solve's. frequencies [Hz], ascending: sqrt(w^2)/(2 pi); a
    negative value -sqrt(-w^2)/(2 pi) marks an unstable mode (the equilibrium is a saddle), a zero one a rigid
    motion (`zero`: |w^2| below round-off of the tangent). shapes: mode vectors on the full coordinates (columns,
    M-normalised: phi' M phi = 1 [1/kg]). modal_masses [kg]: phi' M phi with each mode scaled to a largest
    displacement of a member node or body centre of 1 m (None where none moves, e.g. pure torsion of a beam3d)."""
    status: str
    success: bool
    omega2: np.ndarray  # w^2 [1/s^2]
    frequencies: np.ndarray  # [Hz]
    zero: np.ndarray  # bool per mode
    shapes: np.ndarray  # (n, modes) full coordinates
    modal_masses: list
    static: StaticResult
    method: str = ""
    wall_s: float = 0.0
    linearization: Linearization | None = field(default=None, repr=False)
    damped: DampedModes | None = None  # with modal_analysis(..., damped=True): the damped system's eigenvalues
    omega2_imag: np.ndarray | None = None  # Im w^2 [1/s^2] where K is unsymmetric (a current's drag) and some w^2
    # complex; None otherwise. A complex w^2 (a conjugate pair) is a flutter of the undamped linear model: its
    # frequency Re sqrt(w^2) / 2 pi, one of the pair growing at |Im sqrt(w^2)| [1/s] (damped=True says whether the
    # drag's damping holds it); its shape the real part

    @property
    def modes(self) -> int:
        return len(self.frequencies)

    def _member_mode(self, k: int, member: str) -> np.ndarray:
        asm = self.static.assembly
        mm = asm.mesh.members[member]
        return asm.member_coordinates(self.shapes[:, k], member)[mm.public_nodes]

    def displacements(self, k: int, member: str) -> np.ndarray:
        """Mode k's nodal displacements of a member's public nodes, (nodes, dim) [m per sqrt(kg)]."""
        return self._member_mode(k, member)[:, :self.static.assembly.scene.dim]

    def slopes(self, k: int, member: str) -> np.ndarray:
        """Mode k's change of a member's nodal slope coordinates (r_x, and r_y, r_z of beam3d), (nodes, ...)."""
        return self._member_mode(k, member)[:, self.static.assembly.scene.dim:]

    def __repr__(self) -> str:
        f = ", ".join(f"{v:.6g}" for v in self.frequencies[:6]) + (", ..." if self.modes > 6 else "")
        nz = int(np.sum(self.zero))
        return (f"ModalResult({self.status}, {self.modes} modes [Hz]: {f}" + (f"; {nz} zero (rigid)" if nz else "")
                + ")")

    def to_dict(self) -> dict:
        members = list(self.static.assembly.mesh.members)
        return {
            "status": self.status, "success": self.success, "method": self.method, "wall_s": self.wall_s,
            "frequencies": self.frequencies.tolist(), "omega2": self.omega2.tolist(), "zero": self.zero.tolist(),
            "modal_masses": self.modal_masses,
            "modes": [{"frequency": float(self.frequencies[k]),
                       "members": {name: {"displacements": self.displacements(k, name).tolist(),
                                          "slopes": self.slopes(k, name).tolist()} for name in members}}
                      for k in range(self.modes)],
            "damped": self.damped.to_dict() if self.damped is not None else None,
            "omega2_imag": self.omega2_imag.tolist() if self.omega2_imag is not None else None,
            "static": self.static.to_dict(),
        }
