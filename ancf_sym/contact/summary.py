"""What the penalty contacts do at a state: per contact the smallest gap and the normal force (result.json, the
statics' result), nodal gap and force per member, and the VTK point data (with exact contact's forces too)."""
from __future__ import annotations

import numpy as np

from ancf_sym import kernels
from ancf_sym.contact import body as contact_body, exact as contact_exact, gap as contact_gap
from ancf_sym.contact.laws import DrumContact, kernel_call


def report(asm, x: np.ndarray) -> list[dict]:
    """Per penalty contact: kind, smallest gap of the section surface at the nodes [m] and the total normal force
    [N] (from the normal law's gradient along each node's contact normal); the true smallest gap of the centre
    line between the nodes, where it is and what the law sees at its points (ancf_sym.contact.gap.Closest.record:
    smallest_gap, element, xi, s, point, sampled_penetration, hidden_penetration)."""
    return [{**r, **g} for (r, _), g in zip(_reports(asm, x), contact_gap.report(asm, x))]


def node_fields(asm, x: np.ndarray) -> dict[str, dict[str, np.ndarray]]:
    """Per member with contact: nodal 'contact_gap' [m] (smallest over its contacts) and 'contact_force' [N] (sum
    of the normal-law forces lumped at the node), for VTK point data."""
    out: dict = {}
    for r, (gap, force) in _reports(asm, x):
        f = out.setdefault(r["member"], {"contact_gap": np.full(len(gap), np.inf), "contact_force": np.zeros(len(gap))})
        f["contact_gap"] = np.minimum(f["contact_gap"], gap)
        f["contact_force"] = f["contact_force"] + force
    return out


def _reports(asm, x: np.ndarray):
    d = asm.scene.dim
    for c in getattr(asm.scene, "contacts", ()):
        if c.method != "penalty":
            continue
        mm = asm.mesh.members[c.member]
        r = asm.member_coordinates(x, c.member)[:, :d]
        if isinstance(c, DrumContact):
            centre, axis = (c.centre, c.axis) if c.body is None else contact_body.pose(c, asm, x)
            rel = r - centre
            if axis is not None:
                rel = rel - np.outer(rel @ axis, axis)
            rho = np.linalg.norm(rel, axis=1)
            normals = rel / np.maximum(rho, 1e-300)[:, None]
            gaps = rho - c.radius - c.thickness
        else:
            normals = np.tile(c.normal, (len(r), 1))
            gaps = r @ c.normal - c.level - c.thickness
        effect, idx, P = kernel_call(c, asm.mesh, False)
        k = kernels.load(mm.member.element, effect, None if c.gauss == 5 else c.gauss)
        G = np.asarray(k.map(len(idx))(np.asarray(x)[idx].T, P.T)[1]).T[:, :mm.elem_dofs().shape[1]]
        per_node = 2 if mm.member.element.startswith("cable") else 4
        Gp = G.reshape(len(idx), -1, d)[:, ::per_node, :]  # (element, its 2 nodes, position force)
        nodal = np.zeros((len(r), d))
        en = mm.elem_nodes
        np.add.at(nodal, np.r_[en[:, 0], en[:, 1]], np.r_[Gp[:, 0], Gp[:, 1]])
        force = -(nodal * normals).sum(axis=1)
        kind = "circle" if isinstance(c, DrumContact) else "ground"
        yield ({"type": kind, "member": c.member, "min_gap": float(gaps.min()), "normal_force": float(force.sum())},
               (gaps, force))


def point_data(asm, x: np.ndarray, per_element: int, exact_forces=None) -> dict[str, np.ndarray]:
    """VTK point data of a scene with contact, at the points fields.sample gives (per_element per element, members
    in mesh order): 'contact_gap' [m] (NaN on members without contact) and 'contact_force' [N per node, spread
    linearly between nodes], interpolated from the nodal values of node_fields (and, given exact_forces =
    result.constraint_forces['contact'] of a statics with exact contact, contact.exact.node_fields); {} without
    contact."""
    nodal = node_fields(asm, x)
    if exact_forces is not None:
        for name, f in contact_exact.node_fields(asm, x, exact_forces).items():
            g = nodal.setdefault(name, {"contact_gap": np.full(len(f["contact_gap"]), np.inf),
                                        "contact_force": np.zeros(len(f["contact_gap"]))})
            g["contact_gap"] = np.minimum(g["contact_gap"], f["contact_gap"])
            g["contact_force"] = g["contact_force"] + f["contact_force"]
    if not nodal:
        return {}
    gap, force = [], []
    for name, mm in asm.mesh.members.items():
        en = mm.elem_nodes
        xi = np.linspace(0.0, 1.0, per_element + 1)
        f = nodal.get(name)
        if f is None:
            n = len(en) * per_element + 1
            gap.append(np.full(n, np.nan))
            force.append(np.zeros(n))
            continue
        for key, out in (("contact_gap", gap), ("contact_force", force)):
            v = np.outer(f[key][en[:, 0]], 1 - xi) + np.outer(f[key][en[:, 1]], xi)  # (element, sample)
            out.append(np.r_[v[:, :-1].ravel(), v[-1, -1]])  # shared element ends once, as fields.sample
    return {"contact_gap": np.concatenate(gap), "contact_force": np.concatenate(force)}
