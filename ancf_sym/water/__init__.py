"""Lines in water: buoyancy, Morison drag and added mass, current, Airy waves and a seabed (docs/water.md).

A scene pays for water only when it names it (Scene.set_water or a [water] table): buoyancy of the submerged
members lowers their gravity term's weight (the same kernel: nothing new to evaluate), the seabed is the existing
ground contact at the depth, and the velocity-dependent Morison forces enter the dynamics beside the damping
forces and the statics as a non-conservative load (Newton on the residual with its exact Jacobian).
"""
from .model import Current, LineCoefficients, Seabed, Water, Waves, set_water
from .stiffness import mooring_stiffness

__all__ = ["Current", "LineCoefficients", "Seabed", "Water", "Waves", "mooring_stiffness", "set_water"]
