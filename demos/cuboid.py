# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: light
# ---

# # Frictional contact of an elastic cuboid with a rigid plane
#
# This demo solves the benchmark of Section 7 of the reference paper (the SCD semismooth* Newton method
# for Coulomb friction) with DOLFINx and PETSc:
#
# ```
# mpirun -n 2 python3 demos/cuboid.py            # case d3/L2, lev 6
# mpirun -n 2 python3 demos/cuboid.py --gap d2 --load L1 --lev 5 --out out/d2L1
# ```
#
# It accepts every flag of `python3 -m fenics_coulomb` (see `--help`) and PETSc options for the Newton
# system with the prefix `-coulomb_` (e.g. `-coulomb_ksp_monitor`).
#
# ## The physics
#
# An aluminium block Ω(d) = {(x1, x2) ∈ (0, 2) × (0, 1), d(x1, x2) < x3 < 1} (E = 70 GPa, ν = 0.334) is
# clamped at x1 = 0, pressed down by P_T = (0, 0, −1) GPa on its top and pushed by P_R on its right face
# (L1: (−0.2, 0, 0) GPa, L2: (−0.17, −0.1, 0) GPa). Its bottom, at height d(x1, x2) above the rigid
# half-space x3 ≤ 0, may touch the obstacle; where it does, the contact force λ ≥ 0 and the friction
# force t obey Coulomb's law ‖t‖ ≤ F λ with F = 0.23: a node sticks (‖t‖ < Fλ, no slip) or slides
# (t = −Fλ·s/‖s‖ against its slip s).
#
# ## The generalized equation
#
# After a trilinear (Q1) finite-element discretization with stiffness A and load l̃, shifting the unknown
# by the gaps, u = ũ + d (d = α e3 at contact nodes), turns the problem into the generalized equation
#
#     0 ∈ A u − l + Q(u),   l = l̃ + A d,
#
# where Q is a product of a 3×3 set-valued map Q̃ per contact node (normal cone of the gap constraint,
# friction subdifferential scaled by the unknown contact force) and zero elsewhere.
#
# ## The method
#
# Each SCD semismooth* Newton iteration makes an *approximation step* with the closed-form resolvent
# (γI + Q̃)⁻¹ per node, reads off the state of every contact node (open, stick, slip) and a subspace of
# the derivative S*Q, and solves one linear system (5.4): the stiffness matrix with the contact rows
# replaced. GMRES with ILU solves it to a relative residual `tol` = 0.1 only, and a non-monotone line
# search globalizes the method. The iteration stops when the residual ‖ŷ‖ dropped by 1e-8 (the paper uses
# 1e-12: `--rtol 1e-12`; `docs/tradeoff` shows what each reduction buys).

# +
from __future__ import annotations

import sys

from fenics_coulomb.cli import run_command

# -

# ## Reading the output
#
# * `out/cuboid/solution.xdmf` — open it in ParaView (File ▸ Open, choose the *Xdmf3 Reader S*). Point
#   fields: `displacement` (use *Warp By Vector* to see the deformed body), `contact_state` (0 open,
#   1 stick, 2 slip; −1 off the contact boundary), `contact_pressure` (normal contact force per area) and
#   `tangential_force` (friction force on the body, opposite to the slip).
# * `out/cuboid/summary.json` — sizes n and p, iterations, Krylov iterations, the residual history, the
#   number of open/stick/slip nodes and timings.
#
# The exit status is 0 when the solve converged, 2 for bad input and 3 when it did not converge (the last
# iterate is written all the same).
#
# ## Run
#
# The defaults differ from the bare command line only in the level (6: 27 744 unknowns) and the output
# directory.

# +
if __name__ == "__main__":
    argv = sys.argv[1:]
    if "--lev" not in argv:
        argv = ["--lev", "6", *argv]
    if "--out" not in argv:
        argv = [*argv, "--out", "out/cuboid"]
    sys.exit(run_command(argv, prog="demos/cuboid.py"))
# -
