"""Positions of the scene's points as CasADi graphs of the sweep coordinate s and the parameters:
constructions (fixed, polar, dyad, slider, attach), Newton-solved loops, assembly margins, and
their velocities and accelerations.  May import: errors, scene; nothing further down the pipeline."""
