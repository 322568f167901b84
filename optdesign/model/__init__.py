"""The one-element dynamic model at the drive (seed 1): reduced inertia or mass and its
derivative, static reduced load, velocity and inertia terms, power flow, their values over the
stroke (analyse), and the certification of peaks over the continuous stroke (:mod:`.peaks`).
May import: errors, scene, kinematics; never dynamics, design, report, study or cli."""
