"""The continuous model in NumPy: the contact laws at x = 1, the Robin shift r(x), the stationary
state and the manufactured exact solution. Nothing here knows of meshes or PETSc."""
