"""DOLFINx forms whose compiled code is kept within the process.

:func:`dolfinx.fem.form` hands every UFL form to FFCx, which finds the compiled module in its disk
cache (``~/.cache/fenics``) by the form's signature: for a form compiled before, about 2-5 ms of
signature, listing of the cache directory and module loading, every time. A code that creates
many problems of one kind (the diagnosis's surrogate evaluates a thermal problem of the same
forms some hundred times, the tests and studies likewise) spends a fifth of its time there on a
small model.

:func:`kept_form` does what :func:`dolfinx.fem.form` does, with the compiled form (``ufcx_form``,
its module and code) kept by the UFL signature and the scalar type: the signature is FFCx's own
cache key (the form's integrands with its coefficients, constants, arguments and domains
renumbered in order, its elements and subdomain ids), so two forms of one signature have the
same compiled code whatever mesh, functions and subdomain data they carry. Those are attached
from the form at hand, exactly as :func:`dolfinx.fem.form` attaches them.

Collective over the mesh's communicator, like :func:`dolfinx.fem.form`: on several ranks the
ranks first agree whether every one has the form kept (one ``allreduce``), so that a form kept on
one rank only (one built on ``MPI.COMM_SELF`` earlier) never leaves the others in FFCx's
collective compilation alone.
"""

from __future__ import annotations

import numpy as np
import ufl
from dolfinx import default_scalar_type, fem, jit
from dolfinx.fem.forms import Form, form_cpp_class, get_integration_domains
from mpi4py import MPI
from ufl.algorithms import expand_derivatives

#: The compiled forms of this process: (ufcx_form, module, code) by (UFL signature, scalar type),
#: and for a derivative also the places of its coefficients and constants in the residual's.
_COMPILED: dict[tuple, tuple] = {}


def kept_form(expr: ufl.Form, dtype=default_scalar_type) -> Form:
    """The DOLFINx form of the UFL form ``expr`` (one form; collective over its mesh's
    communicator), its compiled code reused from an earlier form of the same signature."""
    if not isinstance(expr, ufl.Form) or expr.empty():
        return fem.form(expr, dtype=dtype)
    key = (expr.signature(), np.dtype(dtype).str)
    comm = expr.ufl_domain().ufl_cargo().comm
    compiled = _kept(key, comm)
    if compiled is None:
        _COMPILED[key] = compiled = _compile(comm, expr, dtype)
    return _attach(
        compiled,
        dtype,
        expr,
        [arg.ufl_function_space() for arg in expr.arguments()],
        expr.coefficients(),
        expr.constants(),
    )


def kept_derivative_form(F: ufl.Form, u: fem.Function, dtype=default_scalar_type) -> Form | None:
    """The DOLFINx form of the Gateaux derivative of the residual ``F`` with respect to ``u`` in
    the direction of a trial function of ``u``'s space (what :func:`dolfinx.fem.form` of the
    expanded ``ufl.derivative(F, u)`` gives); None where it vanishes.

    Kept by ``F``'s signature and the place of ``u`` among its coefficients: expanding the
    derivative (UFL's algebra, 20-60 ms for a thermal residual) and finding its compiled code
    happen once per kind of residual, and each later residual of that kind gives the derivative
    its own coefficients and constants at the places the first one's came from. Collective over
    the mesh's communicator."""
    coefficients, constants = F.coefficients(), F.constants()
    place = next((i for i, c in enumerate(coefficients) if c is u), None)
    if place is None:
        return None
    key = ("derivative", F.signature(), place, np.dtype(dtype).str)
    comm = F.ufl_domain().ufl_cargo().comm
    compiled = _kept(key, comm)
    if compiled is None:
        dF = expand_derivatives(ufl.derivative(F, u))
        if dF.empty():
            _COMPILED[key] = compiled = (None, None, None, None)
        else:
            index = {id(c): i for i, c in enumerate(coefficients)}
            cindex = {id(c): i for i, c in enumerate(constants)}
            places = (
                tuple(index[id(c)] for c in dF.coefficients()),
                tuple(cindex[id(c)] for c in dF.constants()),
            )
            _COMPILED[key] = compiled = (*_compile(comm, dF, dtype), places)
    if compiled[0] is None:
        return None
    coefficient_places, constant_places = compiled[3]
    return _attach(
        compiled,
        dtype,
        F,  # the derivative integrates over the residual's measures
        [F.arguments()[0].ufl_function_space(), u.function_space],
        [coefficients[i] for i in coefficient_places],
        [constants[i] for i in constant_places],
    )


def _kept(key: tuple, comm: MPI.Comm):
    """The compiled form kept under ``key`` if every rank of ``comm`` keeps it, else None."""
    compiled = _COMPILED.get(key)
    if comm.size > 1 and not comm.allreduce(compiled is not None, op=MPI.LAND):
        return None
    return compiled


def _compile(comm: MPI.Comm, expr: ufl.Form, dtype) -> tuple:
    """``expr`` compiled by FFCx (collective over ``comm``, its mesh's communicator): the
    ``ufcx_form``, its module and code."""
    return tuple(jit.ffcx_jit(comm, expr, form_compiler_options={"scalar_type": dtype}))


def _attach(compiled: tuple, dtype, expr: ufl.Form, spaces, coefficients, constants) -> Form:
    """What :func:`dolfinx.fem.form` attaches to the compiled form: the argument spaces, the
    coefficients in the compiled form's order, the constants, and the integration entities of
    each subdomain id of each integral type the compiled form has (from ``expr``'s subdomain
    data: a derivative's are its residual's, which may have integral types the derivative has
    not)."""
    ufcx_form, module, code = compiled[:3]
    sd = expr.subdomain_data()
    (domain,) = list(sd.keys())
    coeffs = [
        coefficients[ufcx_form.original_coefficient_positions[i]]._cpp_object
        for i in range(ufcx_form.num_coefficients)
    ]
    offsets = [ufcx_form.form_integral_offsets[i] for i in range(len(fem.IntegralType) + 1)]
    ids = {
        fem.IntegralType(i).name: [
            ufcx_form.form_integral_ids[j] for j in range(offsets[i], offsets[i + 1])
        ]
        for i in range(len(offsets) - 1)
    }
    subdomains = {
        fem.IntegralType[name]: get_integration_domains(fem.IntegralType[name], data[0], ids[name])
        for name, data in sd[domain].items()
        if ids[name]
    }
    cpp = form_cpp_class(dtype)(
        [module.ffi.cast("uintptr_t", module.ffi.addressof(ufcx_form))],
        [V._cpp_object for V in spaces],
        coeffs,
        [c._cpp_object for c in constants],
        subdomains,
        [],
        domain.ufl_cargo(),
    )
    return Form(cpp, ufcx_form, code, module)


def num_kept() -> int:
    """How many compiled forms this process keeps."""
    return len(_COMPILED)


__all__ = ["kept_derivative_form", "kept_form", "num_kept"]
