"""Sensors: what a dynamic run records at its output times besides the energies and the constraint violation."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ancf_sym.bodies import planar as bodies, spatial as spatial_bodies
from ancf_sym.model.assembly import Assembly
from ancf_sym.util.checks import check_keys, fail
from ancf_sym.model.mesh import Probe
from ancf_sym.scene.builder import SceneError
from ancf_sym.scene.schema import SENSOR

SENSOR_KINDS = SENSOR["kind"].choices


@dataclass
class Sensor:
    """What to record at output times.

    kind: "position" | "displacement" (from the reference) | "velocity" of a centreline point;
    "strain" (|r_x| - 1) | "curvature" (|r_x x r_xx| / |r_x|^3) at a point; "coordinates" (all nodal
    coordinates of a node); "body": a rigid body's (x, y, angle, angular velocity), `member` naming the body
    (spatial: centre (3), angular velocity (3, world), axes e1, e2, e3 (9), ancf_sym.bodies.spatial.sensor).
    member and at ("start", "end", node index or material coordinate s [m]) name the
    point. Energies and the constraint violation are always recorded.
    """
    name: str
    kind: str
    member: str
    at: Any = "end"

    @classmethod
    def from_dict(cls, d: dict, index: int) -> "Sensor":
        if isinstance(d, Sensor):
            return d
        if not isinstance(d, dict):
            raise SceneError(f"analysis.sensors[{index}] must be a table with kind, member, at; got {d!r}")
        check_keys(f"analysis.sensors[{index}]", d, SENSOR, ("kind",))  # the keys declared in ancf_sym.scene.schema
        kind = SENSOR["kind"].check(f"analysis.sensors[{index}].kind", d["kind"])
        check_keys(f"analysis.sensors[{index}]", d, SENSOR, ("member",))
        member = SENSOR["member"].check(f"analysis.sensors[{index}].member", d["member"])
        if "name" in d:
            SENSOR["name"].check(f"analysis.sensors[{index}].name", d["name"])
        at = d.get("at", "end")
        name = d.get("name") or f"{kind}_{member}_{at}"
        return cls(str(name), kind, member, at)


class SensorEval:
    """A sensor bound to an assembly: its value from full coordinates and velocities."""

    def __init__(self, sensor: Sensor, asm: Assembly, index: int):
        scene = asm.scene
        self.sensor = sensor
        if sensor.kind == "body":
            if sensor.member not in asm.mesh.bodies:
                raise fail(f"analysis.sensors[{index}].member", f"names no body; bodies: {sorted(asm.mesh.bodies)}",
                           sensor.member)
            self.offset = asm.mesh.bodies[sensor.member]
            self.spatial = scene.dim == 3
            return
        if sensor.member not in asm.mesh.members:
            raise fail(f"analysis.sensors[{index}].member", f"names no member; members: {sorted(asm.mesh.members)}",
                       sensor.member)
        try:
            scene.check_at(sensor.member, sensor.at, node_only=sensor.kind == "coordinates",
                            field_name=f"analysis.sensors[{index}].at")
        except SceneError:
            raise
        mm = asm.mesh.members[sensor.member]
        self.sensor, self.mm, self.dim = sensor, mm, scene.dim
        if sensor.kind == "coordinates":
            self.dofs = mm.node_dofs(mm.node(sensor.at))
            self.probe = None
        else:
            self.probe = Probe(mm, mm.coordinate(sensor.at), scene.dim)
            self.r0 = self.probe.r(asm.x0)

    def __call__(self, x: np.ndarray, v: np.ndarray) -> np.ndarray:
        k = self.sensor.kind
        if k == "body":  # angular velocity c s_dot - s c_dot of the unit vector (c, s)
            o = self.offset
            if self.spatial:
                return spatial_bodies.sensor(x, v, o)
            return np.array([*bodies.state(x, o), x[o + 2] * v[o + 3] - x[o + 3] * v[o + 2]])
        p = self.probe
        if k == "coordinates":
            return x[self.dofs].copy()
        if k == "position":
            return p.r(x)
        if k == "displacement":
            return p.r(x) - self.r0
        if k == "velocity":
            return p.r(v)
        rx = p.rx(x)
        nrm = float(np.linalg.norm(rx))
        if k == "strain":
            return np.array([nrm - 1.0])
        rxx = p.rxx(x)
        if self.dim == 2:
            c = abs(float(rx[0] * rxx[1] - rx[1] * rxx[0]))
        else:
            c = float(np.linalg.norm(np.cross(rx, rxx)))
        return np.array([c / max(nrm, 1e-300) ** 3])

