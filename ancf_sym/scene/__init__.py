"""What the user describes, checked where it is given: members, materials, sections, supports, joints, loads,
damping, point masses (`builder`: the Scene and its parts), the fields' types, units and ranges (`schema`), a
member's strain and bending choices as kernel effects (`member_effects`), closed paths and arcs (`closed`)."""
from ancf_sym.scene.builder import (ELEMENT_KINDS, MAX_COORDINATE, VALUE_FIELDS, Damping, Joint, Load, Material,
                                    Member, PointMass, Scene, Section, Support, fingerprint, structure_spec_key)
from ancf_sym.scene.member_effects import AXIAL
from ancf_sym.util.checks import SceneError

__all__ = ["AXIAL", "Damping", "ELEMENT_KINDS", "Joint", "Load", "MAX_COORDINATE", "Material", "Member", "PointMass",
           "Scene", "SceneError", "Section", "Support", "VALUE_FIELDS", "fingerprint", "structure_spec_key"]
