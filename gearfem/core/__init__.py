"""The bottom layer: errors, parameter checks, materials, logging, provenance, facet geometry,
MPI-safe file I/O, the Newton driver shared by every nonlinear solve (``newton``) and the one way
PETSc options are set (``petsc``). Imports nothing else from gearfem."""
