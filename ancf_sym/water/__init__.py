"""Lines in water: buoyancy, Morison drag and added mass, current, Airy waves and a seabed (docs/water.md).

A scene pays for water only when it names it (Scene.set_water or a [water] table): buoyancy of the submerged
members lowers their gravity term's weight (the same kernel: nothing new to evaluate), the seabed is the existing
ground contact at the depth, and the velocity-dependent Morison forces enter the dynamics beside the damping
forces and the statics as a non-conservative load (Newton on the residual with its exact Jacobian).

Each part lives with its stage of the data flow: the declaration in ancf_sym.scene.water, the wet points, forces
and waves in ancf_sym.model (water_points, water_forces, waves), the step system's terms in ancf_sym.system.water,
the statics in ancf_sym.statics.water, the fairlead's and a moored body's stiffness in ancf_sym.statics.mooring, the
modal analysis's linear model in ancf_sym.modal.water (modal_analysis takes a scene in water); this package gathers
the names a user imports.
"""
from ancf_sym.scene.water import Current, LineCoefficients, Seabed, Water, Waves, set_water
from ancf_sym.statics.mooring import body_mooring_stiffness, mooring_stiffness

__all__ = ["Current", "LineCoefficients", "Seabed", "Water", "Waves", "body_mooring_stiffness", "mooring_stiffness",
           "set_water"]
