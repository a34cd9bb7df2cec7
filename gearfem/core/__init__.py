"""The bottom layer: errors, parameter checks, materials, logging, provenance, facet geometry and
MPI-safe file I/O. Imports nothing else from gearfem."""
