"""Output of a two-body solve (issue 18): the XDMF fields on slave and master nodes and the per-pair forces.

The pressed and sheared blocks of tests/model/test_two_body.py (friction 0.3) are solved and written with
``write_xdmf``; the HDF5 data is read back with h5py (no ParaView) and compared, node by node (matched by
coordinates), with quantities recomputed here from the written physical displacement and the pairing: the gap
g + n·(u_s − Σ φ_sj u_j), the master reaction against the lower body's own residual, the traction integrating
to the total contact force. ``pair_forces`` gives equal and opposite forces on the two bodies.
"""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET

from mpi4py import MPI

import dolfinx
import dolfinx.fem.petsc
import h5py
import numpy as np
import ufl
from conftest import gather_by_coordinates, sort_by_coordinates
from test_two_body import MASTER, SLAVE, TIGHT, pressed_blocks

from fenics_coulomb import ContactProblem
from fenics_coulomb.model.checks import unconstrained_residual
from fenics_coulomb.io.fields import contact_functions
from fenics_coulomb.model.forces import contact_areas
from fenics_coulomb.model.pairs.forces import pair_forces
from fenics_coulomb.io.summary import summary, write_summary
from fenics_coulomb.io.xdmf import write_xdmf
from fenics_coulomb.model.pairs import ContactPair

FIELDS = ["displacement", "contact_state", "contact_pressure", "contact_force", "tangential_force",
          "contact_traction", "gap", "contact_normal", "stress", "von_mises", "body", "master_reaction"]


def _gather_rows(comm, *arrays):
    return [np.concatenate(comm.allgather(np.asarray(a))) for a in arrays]


def _read(path):
    """Every point field of the (single) grid, and the vertex coordinates, from the .xdmf/.h5 pair."""
    root = ET.parse(path).getroot()
    (grid,) = root.find("Domain/Grid").findall("Grid")
    items = {a.get("Name"): a.find("DataItem").text.split(":")[1] for a in grid.findall("Attribute")}
    with h5py.File(path.with_suffix(".h5"), "r") as h5:
        x = h5["Mesh/mesh/geometry"][:]
        return list(items), x, {name: h5[dataset][:] for name, dataset in items.items()}


def test_two_body_fields_and_pair_forces(mpi_tmp_path):
    comm = MPI.COMM_WORLD
    V, ft, a, bcs, _ = pressed_blocks(comm, top=(0.0015, 0.0, -0.004), lower=(4, 3, 2), upper=(4, 3, 2))
    pair = ContactPair(ft, slave=SLAVE, master=MASTER, friction=0.3)
    # small sliding: the written tractions are per area of the surface the pairing measured, here the reference
    # one, so their integral over it is the total force (finite sliding measures the deformed surface)
    with ContactProblem(a, None, bcs, contact_pairs=[pair], settings=TIGHT, petsc_options_prefix="tbout_",
                        sliding="small") as problem:
        _, result = problem.solve()
        assert result.converged and result.counts["stick"] + result.counts["slip"] > 0
        model = problem.model
        path = mpi_tmp_path / "solution.xdmf"
        write_xdmf(path, model, result)
        forces = pair_forces(model, result, [pair])
        data = summary(model, result)
        write_summary(mpi_tmp_path / "summary.json", data, comm)
        functions = {f.name: f for f in contact_functions(model, result)}
        # independent ingredients: the physical u at every node, the lower body's own residual, the pairing
        n = V.dofmap.index_map.size_local
        r0 = V.dofmap.index_map.local_range[0]
        x_all = np.concatenate(comm.allgather(V.tabulate_dof_coordinates()[:n]))
        u_all = np.concatenate(comm.allgather(result.displacement.reshape(-1, 3)))  # rows = global blocks
        assert np.allclose(u_all, np.concatenate(comm.allgather(problem.u.x.array[: 3 * n].reshape(-1, 3))))
        residual = unconstrained_residual(model, result.displacement)
        pairing = model.pairing
        # the gap's constant part: the pairing's g(X + u_c) linearized about the configuration, g − n·w(u_c)
        # (finite sliding; the pairing's own gap with small sliding)
        gap_constant = model.contact.gap[model.coupling.paired_mask(model.contact.size)]
        stencil, weights, gap0, normals, force, xs, areas = _gather_rows(
            comm, pairing.master_blocks, pairing.weights, gap_constant, pairing.frames[:, :, 2], result.contact_force,
            pairing.coordinates, contact_areas(model)[model.coupling.paired_mask(model.contact.size)])
        slave_blocks = pairing.blocks.astype(np.int64) + r0
        (slave_global,) = _gather_rows(comm, slave_blocks)
        # ∫ traction ds over the slave surface = Σ nodal contact forces (traction = f_i / ∫ φ_i ds)
        ds = ufl.Measure("ds", domain=V.mesh, subdomain_data=ft)
        t = functions["contact_traction"]
        integral = [comm.allreduce(dolfinx.fem.assemble_scalar(dolfinx.fem.form(t[k] * ds(SLAVE))), op=MPI.SUM)
                    for k in range(3)]
        x_res, res = gather_by_coordinates(V, residual.ravel())
    comm.barrier()

    names, x, fields = _read(path)
    assert names == FIELDS
    order = np.lexsort(np.round(x, 9).T[::-1])
    x, fields = x[order], {k: v[order] for k, v in fields.items()}
    xs_sorted, _ = sort_by_coordinates(x_all, u_all)
    assert np.allclose(x, xs_sorted)
    total = force.sum(axis=0)
    scale = np.abs(total).max()
    assert scale > 0

    # the physical displacement u = M z
    _, u_sorted = sort_by_coordinates(x_all, u_all)
    assert np.allclose(fields["displacement"], u_sorted, rtol=0, atol=1e-14)

    # the body id: one value per block, the two blocks told apart
    lower, upper = x[:, 2] < 5e-4, x[:, 2] > 5e-4  # the blocks: x3 <= 0 and x3 >= 1e-3
    assert lower.any() and upper.any()
    assert len(set(fields["body"][lower])) == 1 and len(set(fields["body"][upper])) == 1
    assert {int(fields["body"][lower][0]), int(fields["body"][upper][0])} == {1, 2}
    assert fields["body"].dtype == np.int32

    # contact fields on exactly the slave contact nodes, matched by coordinates
    slave_points = {tuple(r) for r in np.round(xs, 9)}
    on_slave = np.array([tuple(r) in slave_points for r in np.round(x, 9)])
    assert on_slave.sum() == result.p == len(xs)
    assert np.all(fields["contact_state"][~on_slave] == -1) and np.all(fields["contact_state"][on_slave] >= 0)
    assert np.all(np.isclose(x[on_slave, 2], 1e-3))  # the upper block's bottom (the slave surface)
    for name in ("contact_pressure", "contact_force", "tangential_force", "contact_traction", "gap", "contact_normal"):
        assert not np.any(fields[name][~on_slave]), name
    key = np.lexsort(np.round(xs, 9).T[::-1])
    # gap = g + n·w with w_s = u_s − Σ_j φ_sj u_j, from the written displacement
    w = u_all[slave_global] - np.einsum("ij,ijk->ik", weights, u_all[np.maximum(stencil, 0)])
    gap = gap0 + np.einsum("ij,ij->i", normals, w)
    assert np.allclose(fields["gap"][on_slave], gap[key], rtol=0, atol=1e-10 * np.abs(u_all).max())
    assert fields["gap"][on_slave].min() >= -1e-10 * np.abs(u_all).max()
    assert np.allclose(fields["contact_normal"][on_slave], normals[key], atol=1e-14)
    # contact_force = the nodal force; contact_pressure = its normal part per area (the mortar D_j), the
    # traction's normal component
    assert np.allclose(fields["contact_force"][on_slave], force[key], rtol=0, atol=1e-14 * scale)
    pressure = np.einsum("ij,ij->i", normals, force)[key] / areas[key]
    assert np.allclose(fields["contact_pressure"][on_slave], pressure, rtol=0, atol=1e-10 * np.abs(pressure).max())
    assert np.allclose(np.einsum("ij,ij->i", normals[key], fields["contact_traction"][on_slave]),
                       fields["contact_pressure"][on_slave], rtol=0, atol=1e-10 * np.abs(pressure).max())
    # complementarity of the written fields
    assert np.abs(fields["gap"][on_slave] * fields["contact_pressure"][on_slave]).max() <= (
        1e-8 * scale * np.abs(u_all).max())
    assert np.allclose(integral, total, rtol=0, atol=1e-10 * scale)

    # the master reaction: zero off the master surface, minus the total slave force, the lower body's residual
    reaction = fields["master_reaction"]
    assert not np.any(reaction[~np.isclose(x[:, 2], 0.0)])
    assert np.allclose(reaction.sum(axis=0), -total, rtol=0, atol=1e-10 * scale)
    on_master = np.isclose(x[:, 2], 0.0)
    assert np.allclose(reaction[on_master], res.reshape(-1, 3)[on_master], rtol=0, atol=1e-9 * scale)
    assert np.allclose(x_res, x)

    # per pair: equal and opposite forces from each body's own residual, in summary.json
    (entry,) = forces
    assert entry["slave"] == [SLAVE] and entry["master"] == [MASTER] and entry["contact_nodes"] == result.p
    assert entry["prescribed_nodes"] == 0 and entry["balance"] < 1e-8
    assert np.allclose(entry["force_on_slave_body"], total, rtol=0, atol=1e-9 * scale)
    assert np.allclose(entry["force_on_master_body"], reaction.sum(axis=0), rtol=0, atol=1e-9 * scale)
    assert entry["force_on_slave_body"][2] > 0 and abs(entry["force_on_slave_body"][0]) > 1e-3 * scale
    written = json.loads((mpi_tmp_path / "summary.json").read_text())
    assert written["contact_pairs"][0]["balance"] == data["contact_pairs"][0]["balance"] < 1e-8
    assert np.allclose(written["contact_pairs"][0]["force_on_slave_body"], entry["force_on_slave_body"])
