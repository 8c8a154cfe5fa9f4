"""Contact of members with the ground, fixed drums and bodies' drums.

`laws` declares them (the scene's `contact_ground` / `contact_drum`) and names the kernels of
their normal law and of their damping and friction; `body` the drums carried by rigid bodies; `gap` the true
smallest gap of a centre line and the check that the penalty law saw it; `exact` exact contact as unilateral rows
of the statics; `steps` the Newton step limit that keeps points from crossing a drum; `summary` what the contacts do
at a state (gaps, forces, VTK point data).
"""
from ancf_sym.contact.laws import (LABEL, ContactLaw, DrumContact, GroundContact, check_dynamics,
                                   dissipation_calls, drum, energy_terms, exact_contacts, ground,
                                   unilateral)
from ancf_sym.contact.summary import node_fields, point_data, report

__all__ = ["LABEL", "ContactLaw", "DrumContact", "GroundContact", "check_dynamics", "dissipation_calls", "drum",
           "energy_terms", "exact_contacts", "ground", "node_fields", "point_data", "report",
           "unilateral"]
