# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: percent
# ---

# %% [markdown]
# # A fibre-reinforced roller pressed and sheared on a rigid plane: the Python API
#
# This demo uses `fenics_coulomb.ContactProblem` the way a FEniCSx user would: the mesh is made here with
# gmsh, the material is an orthotropic law written in UFL, the boundary conditions are ordinary
# `dolfinx.fem.DirichletBC` objects (one of them on a single component), and the result goes to an XDMF
# file for ParaView.
#
# ```
# python3 demos/api_orthotropic.py --out out/orthotropic
# mpirun -n 2 python3 demos/api_orthotropic.py --out out/orthotropic
# ```
#
# The body is half of a roller of radius R = 0.5 lying along x2 (the half with x2 > 0, cut by the symmetry
# plane x2 = 0), flat on top at x3 = 0.505, its lowest line 0.005 above the rigid plane x3 = 0. Its top is
# moved down by 0.012 and sideways by 0.002 (prescribed, non-zero displacements), so the curved surface is
# pressed onto the plane and dragged along it under Coulomb friction F = 0.3.

# %%
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from mpi4py import MPI
from petsc4py import PETSc

import dolfinx
import dolfinx.fem
import dolfinx.io.gmshio
import gmsh
import numpy as np
import ufl

from fenics_coulomb import ContactProblem, write_results

R, LENGTH, LIFT = 0.5, 0.5, 0.005
TOP_Z = LIFT + R
TOP, SYMMETRY, CURVED = 1, 2, 3

# %% [markdown]
# ## The body, meshed with gmsh
#
# A cylinder along x2 minus the box above its axis leaves the lower half-roller. Its faces are found by
# their centres of mass and become physical groups: the flat top, the symmetry plane x2 = 0 and the
# curved surface, which is the contact boundary.


# %%
def half_roller(comm: MPI.Comm, h: float) -> tuple[dolfinx.mesh.Mesh, dolfinx.mesh.MeshTags]:
    """Mesh the half-roller with tetrahedra of size ``h`` on rank 0 and distribute it."""
    if comm.rank == 0:
        gmsh.initialize(interruptible=False)
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("half_roller")
        cylinder = gmsh.model.occ.addCylinder(0.0, 0.0, TOP_Z, 0.0, LENGTH, 0.0, R)
        upper = gmsh.model.occ.addBox(-R, 0.0, TOP_Z, 2 * R, LENGTH, R)
        gmsh.model.occ.cut([(3, cylinder)], [(3, upper)])
        gmsh.model.occ.synchronize()
        volumes = gmsh.model.getEntities(3)
        gmsh.model.addPhysicalGroup(3, [v[1] for v in volumes], 1)
        groups: dict[int, list[int]] = {TOP: [], SYMMETRY: [], CURVED: []}
        for _, surface in gmsh.model.getEntities(2):
            _, y, z = gmsh.model.occ.getCenterOfMass(2, surface)
            if np.isclose(z, TOP_Z):
                groups[TOP].append(surface)
            elif np.isclose(y, 0.0):
                groups[SYMMETRY].append(surface)
            elif not np.isclose(y, LENGTH):
                groups[CURVED].append(surface)
        for tag, surfaces in groups.items():
            gmsh.model.addPhysicalGroup(2, surfaces, tag)
        gmsh.option.setNumber("Mesh.CharacteristicLengthMax", h)
        gmsh.model.mesh.generate(3)
    msh, _, facet_tags = dolfinx.io.gmshio.model_to_mesh(gmsh.model if comm.rank == 0 else None, comm, 0, gdim=3)
    if comm.rank == 0:
        gmsh.finalize()
    return msh, facet_tags


# %% [markdown]
# ## An orthotropic material in UFL
#
# Carbon fibres along x1 in an epoxy matrix: E₁ = 140 GPa along the fibres, E₂ = E₃ = 10 GPa across,
# shear moduli G₁₂ = G₁₃ = 5 GPa, G₂₃ = 3.5 GPa, Poisson ratios ν₁₂ = ν₁₃ = 0.3, ν₂₃ = 0.45. The stiffness
# in Voigt notation is the inverse of the compliance; σ = C ε is written directly in UFL, so the solver
# sees only the bilinear form (its γ and its multigrid near-nullspace come from the assembled matrix and
# the space, not from a material law).


# %%
def orthotropic_stiffness(E: tuple[float, float, float], G: tuple[float, float, float],
                          nu: tuple[float, float, float]) -> np.ndarray:
    """Voigt stiffness (order 11, 22, 33, 23, 13, 12) from E_i, G_23, G_13, G_12 and ν_12, ν_13, ν_23."""
    (e1, e2, e3), (nu12, nu13, nu23) = E, nu
    compliance = np.diag([1 / e1, 1 / e2, 1 / e3, 1 / G[0], 1 / G[1], 1 / G[2]])
    compliance[0, 1] = compliance[1, 0] = -nu12 / e1
    compliance[0, 2] = compliance[2, 0] = -nu13 / e1
    compliance[1, 2] = compliance[2, 1] = -nu23 / e2
    return np.linalg.inv(compliance)


def strain_voigt(w: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
    """Engineering strains (ε11, ε22, ε33, 2ε23, 2ε13, 2ε12)."""
    e = ufl.sym(ufl.grad(w))
    return ufl.as_vector([e[0, 0], e[1, 1], e[2, 2], 2 * e[1, 2], 2 * e[0, 2], 2 * e[0, 1]])


# %% [markdown]
# ## Boundary conditions
#
# * the symmetry plane x2 = 0: only u2 = 0 (a one-component condition on the sub-space `V.sub(1)`);
# * the top: u3 = −0.012 and u1 = 0.002 (non-zero values; the solver lifts them into the load).
#
# Nodes with any constrained component are never contact nodes, so the curved surface's nodes on the
# symmetry plane are excluded from contact, as they would be by a mirrored body.


# %%
def boundary_conditions(V: dolfinx.fem.FunctionSpace, tags: dolfinx.mesh.MeshTags,
                        push: float, shear: float) -> list[dolfinx.fem.DirichletBC]:
    fdim = V.mesh.topology.dim - 1
    bcs = []
    for component, value, tag in ((1, 0.0, SYMMETRY), (2, -push, TOP), (0, shear, TOP)):
        dofs = dolfinx.fem.locate_dofs_topological(V.sub(component), fdim, tags.find(tag))
        bcs.append(dolfinx.fem.dirichletbc(PETSc.ScalarType(value), dofs, V.sub(component)))
    return bcs


# %% [markdown]
# ## Solve
#
# `ContactProblem` takes the forms, the boundary conditions, the contact boundary as facet tags with
# markers, the friction coefficient and PETSc options under a prefix of our choice. The obstacle is the
# default one, the plane x3 = 0.


# %%
def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Orthotropic half-roller on a rigid plane (ContactProblem)")
    parser.add_argument("--h", type=float, default=0.05, help="mesh size (default 0.05)")
    parser.add_argument("--push", type=float, default=0.012)
    parser.add_argument("--shear", type=float, default=0.002)
    parser.add_argument("--friction", type=float, default=0.3)
    parser.add_argument("--out", default="out/orthotropic")
    args = parser.parse_args(argv)
    comm = MPI.COMM_WORLD
    out = Path(args.out)

    msh, tags = half_roller(comm, args.h)
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    C = ufl.as_matrix(orthotropic_stiffness((140.0, 10.0, 10.0), (3.5, 5.0, 5.0), (0.3, 0.3, 0.45)).tolist())
    a = ufl.inner(C * strain_voigt(u), strain_voigt(v)) * ufl.dx
    bcs = boundary_conditions(V, tags, args.push, args.shear)

    with ContactProblem(a, None, bcs=bcs, contact=(tags, [CURVED]), friction=args.friction,
                        settings={"rtol": 1e-10}, petsc_options_prefix="roller_",
                        petsc_options={"ksp_max_it": 1000}) as problem:
        uh, result = problem.solve()
        checks = problem.checks(result)

        # %% [markdown]
        # ## Output for ParaView
        #
        # `solution.xdmf` holds the displacement, the contact states (0 open, 1 stick, 2 slip), the normal
        # contact forces and the friction forces; in ParaView open it with the *Xdmf3 Reader S* and apply
        # *Warp By Vector* with `displacement`. `summary.json` has the iterations, the contact states and the
        # physics checks.

        # %%
        write_results(out, problem, result, extra={"demo": "api_orthotropic", "checks": checks})
    counts = result.counts
    if comm.rank == 0:
        print(f"{'converged' if result.converged else 'NOT converged'} in {result.iterations} Newton iterations: "
              f"p = {result.p} contact nodes, open/stick/slip {counts['open']}/{counts['stick']}/{counts['slip']}; "
              f"largest physics residual {max(v for k, v in checks.items() if k != 'contact_resultant'):.1e}; "
              f"contact force {json.dumps([round(c, 6) for c in checks['contact_resultant']])}; results in {out}/")
    return 0 if result.converged else 3


if __name__ == "__main__":
    sys.exit(main())
