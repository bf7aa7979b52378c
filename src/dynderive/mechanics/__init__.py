"""The engine: joints, planar and spatial kinematics, Lagrange operators, the generalized and
maximal-coordinate derivations, the straight-line programs of the recursive algorithms, and
the cheap tidying that keeps results readable. Pure functions of a ``Robot`` and its symbols."""
