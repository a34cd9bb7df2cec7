"""Small-strain linear isotropic elasticity of the contact bodies (UFL).

Strong form in each body Ω_b: −div σ(u) = 0, σ = 2μ ε(u) + λ tr(ε(u)) I, ε = sym(∇u), with
Dirichlet supports and contact tractions on the boundary. The weak form's bilinear part
a(u, v) = ∫ σ(u) : ε(v) dx is the stiffness K of every contact solver, and of the compliances the
condensed solver stores (:mod:`gearfem.contact.compliance`): this module is part of their key.
"""

from __future__ import annotations

import ufl


def elastic_stress(u, mu, lmbda):
    """Linear isotropic stress σ = 2μ ε(u) + λ tr(ε(u)) I (UFL)."""
    eps = ufl.sym(ufl.grad(u))
    return 2.0 * mu * eps + lmbda * ufl.tr(eps) * ufl.Identity(len(u))


def stiffness_form(V, mu, lmbda):
    """a(u, v) = ∫ σ(u) : ε(v) dx on the vector space V (UFL form; Lamé parameters in Pa)."""
    du, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    return ufl.inner(elastic_stress(du, mu, lmbda), ufl.sym(ufl.grad(v))) * ufl.dx
