"""gearfem.core.forms.kept_form: a DOLFINx form whose compiled code is kept within the process
gives the form dolfinx.fem.form gives (the same numbers on meshes, subdomains, coefficients and
constants of its own), and a form of a signature seen before compiles nothing."""

from __future__ import annotations

import numpy as np
import pytest
import ufl
from dolfinx import fem, mesh
from dolfinx.fem.petsc import assemble_matrix, assemble_vector
from mpi4py import MPI

import gearfem  # noqa: F401
from gearfem.core.forms import kept_derivative_form, kept_form, num_kept


def _problem(comm, n: int, k: float, marker_y: float):
    """Functional, linear and bilinear forms on a unit cube of n^3 cells (P1) with a coefficient,
    a constant k and the facets of the face x = 0 with y < marker_y tagged 1."""
    msh = mesh.create_unit_cube(comm, n, n, n)
    fdim = msh.topology.dim - 1
    facets = mesh.locate_entities_boundary(
        msh, fdim, lambda x: np.isclose(x[0], 0.0) & (x[1] < marker_y)
    )
    tags = mesh.meshtags(msh, fdim, facets, np.full(len(facets), 1, dtype=np.int32))
    V = fem.functionspace(msh, ("Lagrange", 1))
    f = fem.Function(V)
    f.interpolate(lambda x: 1.0 + x[0] + 2.0 * x[1] * x[2])
    c = fem.Constant(msh, k)
    ds = ufl.Measure("ds", domain=msh, subdomain_data=tags)
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    forms = (
        c * f * f * ufl.dx + f * ds(1),
        c * ufl.inner(ufl.grad(f), ufl.grad(v)) * ufl.dx + f * v * ds(1),
        c * f * ufl.inner(ufl.grad(u), ufl.grad(v)) * ufl.dx + u * v * ds(1),
    )
    return forms


def _values(a, assembled_form):
    rank = len(a.arguments())
    if rank == 0:
        return np.array([assembled_form.mesh.comm.allreduce(fem.assemble_scalar(assembled_form))])
    if rank == 1:
        b = assemble_vector(assembled_form)
        b.ghostUpdate()
        out = b.array.copy()
        b.destroy()
        return out
    A = assemble_matrix(assembled_form)
    A.assemble()
    out = np.array([A.norm(), A.getDiagonal().sum()])
    A.destroy()
    return out


def _check_equal(comm):
    first = _problem(comm, 3, 2.0, 0.5)
    second = _problem(comm, 4, 3.5, 0.7)  # another mesh, coefficient, constant and subdomain
    for a in first:
        kept_form(a)
    kept = num_kept()
    for forms in (first, second):
        for a in forms:
            np.testing.assert_allclose(
                _values(a, kept_form(a)), _values(a, fem.form(a)), rtol=1e-14, atol=1e-14
            )
    # the second mesh's forms have the first's signatures: nothing compiled again
    assert num_kept() == kept


def test_kept_form_gives_dolfinx_form_and_compiles_once():
    _check_equal(MPI.COMM_SELF)


@pytest.mark.mpi
def test_kept_form_on_every_rank_after_one_ranks_own():
    """A form kept on one rank only (built on COMM_SELF there) and then wanted on every rank: the
    ranks agree to compile it together (no rank left waiting in FFCx's collective compile), and
    the forms equal dolfinx's."""
    comm = MPI.COMM_WORLD
    if comm.rank == 0:
        for a in _problem(MPI.COMM_SELF, 2, 1.5, 0.3):
            kept_form(a)
    comm.barrier()
    _check_equal(comm)


def test_kept_derivative_form_gives_the_expanded_derivative():
    """The Jacobian of a nonlinear residual (radiation-like T^4, a T-dependent conductivity) from
    the kept derivative equals dolfinx's form of the expanded derivative on a second problem of
    the same kind; a residual that does not depend on T has none."""
    derivatives = []
    for n, k in ((3, 2.0), (4, 0.7)):
        msh = mesh.create_unit_cube(MPI.COMM_SELF, n, n, n)
        V = fem.functionspace(msh, ("Lagrange", 1))
        T = fem.Function(V)
        T.interpolate(lambda x: 300.0 + 10.0 * x[0] * x[1])
        q = fem.Function(V)
        q.interpolate(lambda x: 1.0 + x[2])
        c = fem.Constant(msh, k)
        v = ufl.TestFunction(V)
        F = (c + 0.01 * T) * ufl.inner(ufl.grad(T), ufl.grad(v)) * ufl.dx
        F += 1e-8 * T**4 * v * ufl.ds - q * v * ufl.dx
        kept = num_kept()
        J = kept_derivative_form(F, T)
        assert J is not None
        derivatives.append(num_kept() - kept)
        a = ufl.algorithms.expand_derivatives(ufl.derivative(F, T))
        np.testing.assert_allclose(_values(a, J), _values(a, fem.form(a)), rtol=1e-13)
        assert kept_derivative_form(-q * v * ufl.dx + c * v * ufl.ds, T) is None
    assert derivatives[1] == 0  # the second problem compiled nothing
