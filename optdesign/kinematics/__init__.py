"""Positions of the scene's points as CasADi graphs of the sweep coordinate s and the parameters:
constructions (fixed, polar, dyad, slider, attach), Newton-solved loops, assembly margins, and
their velocities and accelerations; the certification of extrema over the continuous stroke
(:mod:`.peaks`, the one used by every layer) and with it the assembly check over the whole stroke.
May import: errors, scene; nothing further down the pipeline."""
