"""The one-element dynamic model at the drive (seed 1): reduced inertia or mass and its
derivative, static reduced load, velocity and inertia terms, power flow, and their values over
the stroke (analyse) with their peaks certified over the continuous stroke (through
:mod:`optdesign.kinematics.peaks`).
May import: errors, scene, kinematics; never dynamics, design, report, study or cli."""
