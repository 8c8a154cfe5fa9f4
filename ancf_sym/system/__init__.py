"""What statics and dynamics share: the step system on the reduced coordinates (`step_system`) and the graphs it is
built from: elastic forces and tangents (`forces`), damping and contact dissipation (`damping`), the banded path
(`band`, `ldl`), graphs cached by scene structure (`graph_cache`)."""
