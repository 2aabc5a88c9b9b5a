"""The continuous model in NumPy: the contact and heat-exchange laws at x = 1, the Robin shift
r(x), the steady states and the manufactured exact solution. Nothing here knows of meshes or
PETSc."""
