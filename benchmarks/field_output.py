"""What writing the fields costs, per way of writing them at the solution's degree.

The displacement and director are P2.  Ways to put them in a file ParaView reads:

- ``vertices``  -- P1 at the mesh's vertices (rftfem before; a roll-up's turn is a polygon);
- ``cells9``    -- 9-node (6-node) cells whose nodes are the P2 dofs, XDMF (rftfem now);
- ``subdivided``-- each cell cut into 4 linear cells through the P2 dofs, XDMF;
- ``vtk``       -- dolfinx's VTKFile, which writes P2 as VTK Lagrange cells (a .vtu per step);
- ``vtx``       -- dolfinx's VTXWriter (ADIOS2; the dolfinx 0.11 stack only).

For a strip of ``--cells`` quadrilaterals, each writer writes the displacement and
the director ``--steps`` times; printed per way: the best and median time per output
step (ms), and the bytes on disk per step (all files, the mesh counted once).

    .venv/bin/python benchmarks/field_output.py                 # 64x8 cells, 20 steps
    .venv-current/bin/python benchmarks/field_output.py --cells 128 16
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

# the repository's .venv when this python3 lacks rftfem (scripts/repository_python.py)
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))
import repository_python  # noqa: E402

repository_python.ensure()


def folder_bytes(folder: Path) -> int:
    return sum(p.stat().st_size for p in folder.rglob("*") if p.is_file())


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cells", type=int, nargs=2, default=[64, 8], metavar=("NX", "NY"))
    parser.add_argument("--steps", type=int, default=20)
    args = parser.parse_args()

    import numpy as np
    from dolfinx import fem, io
    from dolfinx import mesh as dmesh
    from mpi4py import MPI

    import rftfem  # noqa: F401  (sets up the FEniCSx stack)
    from rftfem import compat
    from rftfem.outputs.field_mesh import FieldMesh

    nx, ny = args.cells
    msh = dmesh.create_rectangle(
        MPI.COMM_WORLD,
        [np.array([0.0, 0.0]), np.array([12.0, 1.0])],
        [nx, ny],
        dmesh.CellType.quadrilateral,
    )
    msh = compat.serial_lagrange_mesh(  # the same mesh with 3D coordinates, as rftfem's
        "quadrilateral",
        1,
        compat.geometry_cells(msh)[0][:, [0, 1, 2, 3]].astype(np.int64),
        np.c_[msh.geometry.x[:, :2], np.zeros(len(msh.geometry.x))],
    )
    V2 = compat.function_space(msh, "Lagrange", 2, (3,))
    u = fem.Function(V2, name="displacement")
    d = fem.Function(V2, name="director")
    u.interpolate(lambda x: np.stack([np.sin(x[0]), x[1] * x[0], np.cos(x[0])]))
    d.interpolate(lambda x: np.stack([0 * x[0], 0 * x[0], 1 + 0 * x[0]]))

    def vertices(folder):
        V1 = compat.function_space(msh, "Lagrange", 1, (3,))
        fs = [fem.Function(V1, name=f.name) for f in (u, d)]
        path = str(folder / "fields.xdmf")
        with io.XDMFFile(msh.comm, path, "w") as f:
            f.write_mesh(msh)

        def write(t):
            for g, f in zip(fs, (u, d)):
                g.interpolate(f)
            with io.XDMFFile(msh.comm, path, "a") as file:
                for g in fs:
                    file.write_function(g, t)

        return write

    def on_nodes(folder, subdivide: bool):
        nodes = FieldMesh(V2)
        out_mesh = nodes.mesh
        if subdivide:  # each 9-node cell as four 4-node cells (dolfinx's node order)
            cells9 = compat.local_to_global(
                V2.dofmap.index_map, compat.cell_dofs(V2).ravel()
            ).reshape(-1, 9)
            quads = np.concatenate(
                [
                    cells9[:, [0, 4, 5, 8]],
                    cells9[:, [4, 1, 8, 6]],
                    cells9[:, [5, 8, 2, 7]],
                    cells9[:, [8, 6, 7, 3]],
                ]
            )
            x = V2.tabulate_dof_coordinates()
            out_mesh = compat.serial_lagrange_mesh("quadrilateral", 1, quads, x)
            space = compat.function_space(out_mesh, "Lagrange", 1, (3,))
            source = np.asarray(out_mesh.geometry.input_global_indices)
            order = np.empty(space.dofmap.index_map.size_local, dtype=np.int64)
            order[compat.cell_dofs(space).ravel()] = source[
                compat.geometry_cells(out_mesh)[0].ravel()
            ]
            nodes.space, nodes._order = space, order
        fs = [fem.Function(nodes.space, name=f.name) for f in (u, d)]
        path = str(folder / "fields.xdmf")
        with io.XDMFFile(MPI.COMM_SELF, path, "w") as f:
            f.write_mesh(out_mesh)

        def write(t):
            for g, f in zip(fs, (u, d)):
                nodes.gather(f, g)
            with io.XDMFFile(MPI.COMM_SELF, path, "a") as file:
                for g in fs:
                    file.write_function(g, t)

        return write

    def vtk(folder):
        file = io.VTKFile(msh.comm, str(folder / "fields.pvd"), "w")

        def write(t):
            file.write_function([u, d], t)

        write.close = file.close
        return write

    def vtx(folder):
        writer = io.VTXWriter(msh.comm, str(folder / "fields.bp"), [u, d], engine="BP4")

        def write(t):
            writer.write(t)

        write.close = writer.close
        return write

    ways = {
        "vertices": vertices,
        "cells9": lambda f: on_nodes(f, False),
        "subdivided": lambda f: on_nodes(f, True),
        "vtk": vtk,
    }
    if hasattr(io, "VTXWriter"):
        ways["vtx"] = vtx
    print(
        f"strip of {nx}x{ny} quadrilaterals, {V2.dofmap.index_map.size_global} P2 nodes, "
        f"{args.steps} output steps; dolfinx {compat.versions()['dolfinx']}"
    )
    print(f"{'way':>11} {'best ms/step':>13} {'median ms/step':>15} {'kB/step':>9} {'kB mesh':>8}")
    for name, make in ways.items():
        with tempfile.TemporaryDirectory() as tmp:
            folder = Path(tmp)
            write = make(folder)
            times = []
            write(0.0)
            first = folder_bytes(folder)
            for k in range(args.steps):
                t0 = time.perf_counter()
                write(float(k + 1))
                times.append(time.perf_counter() - t0)
            getattr(write, "close", lambda: None)()
            total = folder_bytes(folder)
        per_step = (total - first) / args.steps
        print(
            f"{name:>11} {1e3 * min(times):13.2f} {1e3 * np.median(times):15.2f} "
            f"{per_step / 1e3:9.1f} {(first - per_step) / 1e3:8.1f}"
        )


if __name__ == "__main__":
    main()
