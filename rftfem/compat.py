"""Every difference between the FEniCSx stacks rftfem runs on, in one place.

The reference stack is Debian 12's dolfinx 0.5.2 (UFL 2022.2, PETSc 3.18); the
current stack is dolfinx >= 0.10 (the ``dolfinx-solver-real`` wheel, conda-forge,
FEniCS images). Differences are detected by feature (``hasattr``, ``try``), never
by comparing version strings, so a stack in between works if its features do.

Nothing outside this module imports ``basix.ufl``, ``dolfinx.io.gmsh(io)`` or
touches ``Function.vector`` / ``x.petsc_vec``.
"""

from __future__ import annotations

import os
from typing import TYPE_CHECKING, Any

import numpy as np

try:  # the dolfinx-solver-real wheel must be imported before dolfinx
    import dolfinx_solver  # noqa: F401
except ImportError:
    pass

import dolfinx
import dolfinx.fem
import dolfinx.fem.petsc
import dolfinx.geometry
import dolfinx.mesh
import ufl
from petsc4py import PETSc

try:
    import basix.ufl as _basix_ufl

    _HAS_BASIX_UFL = hasattr(_basix_ufl, "element") and hasattr(_basix_ufl, "mixed_element")
except ImportError:  # dolfinx 0.5: elements come from UFL
    _basix_ufl = None
    _HAS_BASIX_UFL = False

if TYPE_CHECKING:
    import dolfinx.common
    import gmsh
    from mpi4py import MPI

ScalarType = PETSc.ScalarType


# --- function spaces -------------------------------------------------------


def _element(mesh, family: str, degree: int, shape: tuple[int, ...] = ()):
    """A Lagrange/DG element on ``mesh``'s cell with the given value shape."""
    if _HAS_BASIX_UFL:
        kwargs = {"shape": shape} if shape else {}
        if family in ("DG", "Discontinuous Lagrange"):
            return _basix_ufl.element(
                "Lagrange", mesh.basix_cell(), degree, discontinuous=True, **kwargs
            )
        return _basix_ufl.element(family, mesh.basix_cell(), degree, **kwargs)
    cell = mesh.ufl_cell()
    if family == "DG" and cell.cellname() in ("quadrilateral", "hexahedron"):
        family = "DQ"
    if shape:
        return ufl.VectorElement(family, cell, degree, dim=shape[0])
    return ufl.FiniteElement(family, cell, degree)


def _functionspace(mesh, element):
    if hasattr(dolfinx.fem, "functionspace"):
        return dolfinx.fem.functionspace(mesh, element)
    return dolfinx.fem.FunctionSpace(mesh, element)


def function_space(
    mesh: dolfinx.mesh.Mesh, family: str, degree: int, shape: tuple[int, ...] = ()
) -> dolfinx.fem.FunctionSpace:
    """``family``/``degree`` space with value ``shape`` (``()`` scalar, ``(3,)`` vector)."""
    return _functionspace(mesh, _element(mesh, family, degree, shape))


def quadrature_space(
    mesh: dolfinx.mesh.Mesh, degree: int, shape: tuple[int, ...] = ()
) -> dolfinx.fem.FunctionSpace:
    """A space of values at the points of the cell's default quadrature rule of
    ``degree`` (a form that uses it must integrate with that rule: ``quadrature_degree``
    ``degree``); dolfinx 0.5 makes the element in UFL, 0.11 in basix."""
    if _HAS_BASIX_UFL:
        element = _basix_ufl.quadrature_element(
            mesh.basix_cell(), value_shape=shape, scheme="default", degree=degree
        )
    elif shape:
        element = ufl.VectorElement(
            "Quadrature", mesh.ufl_cell(), degree, dim=shape[0], quad_scheme="default"
        )
    else:
        element = ufl.FiniteElement("Quadrature", mesh.ufl_cell(), degree, quad_scheme="default")
    return _functionspace(mesh, element)


def geometry_cells(mesh: dolfinx.mesh.Mesh) -> tuple[np.ndarray, int]:
    """The geometry nodes of every cell as a (num_cells, nodes) array, and the
    geometry's degree (1: straight cells, 2: curved ones from a second-order gmsh
    file); dolfinx 0.5 gives an AdjacencyList, 0.11 an array (one per cell type,
    ``dofmaps``)."""
    g = mesh.geometry
    if isinstance(getattr(g, "cmaps", None), list):  # one per cell type (0.10 on)
        cmap, dm = g.cmaps[0], g.dofmaps[0]
    else:
        cmap = g.cmap() if callable(g.cmap) else g.cmap
        dm = g.dofmap
    cells = dm if isinstance(dm, np.ndarray) else dm.array.reshape(-1, dm.links(0).size)
    return cells, int(cmap.degree)


def collapse(sub: dolfinx.fem.FunctionSpace) -> tuple[dolfinx.fem.FunctionSpace, np.ndarray]:
    """``sub.collapse()`` as (space, the sub-space's dofs in the parent as one flat int64
    array): dolfinx 0.5 gives a list of ints, 0.11 a list holding one array."""
    V, dofs = sub.collapse()
    return V, np.asarray(dofs, dtype=np.int64).reshape(-1)


def cell_dofs(V: dolfinx.fem.FunctionSpace) -> np.ndarray:
    """Cell-to-(blocked)-dof table of ``V`` as a (num_cells, dofs_per_cell) array."""
    dm = V.dofmap.list
    if isinstance(dm, np.ndarray):
        return dm
    return dm.array.reshape(-1, V.dofmap.dof_layout.num_dofs)  # AdjacencyList (0.5)


def interpolation_points(V: dolfinx.fem.FunctionSpace) -> np.ndarray:
    pts = V.element.interpolation_points
    return pts() if callable(pts) else pts


def expression(expr: ufl.core.expr.Expr, V: dolfinx.fem.FunctionSpace) -> dolfinx.fem.Expression:
    """A compiled expression evaluated at ``V``'s interpolation points."""
    return dolfinx.fem.Expression(expr, interpolation_points(V))


# --- forms and PETSc objects ------------------------------------------------


def _keyword(function, new: str, old: str) -> str:
    """The name ``function`` uses for an argument renamed between versions."""
    import inspect

    return new if new in inspect.signature(function).parameters else old


def vector_flags(cpuinfo: str = "/proc/cpuinfo", machine: str | None = None) -> tuple[str, ...]:
    """``-mavx2 -mfma`` where this x86-64 CPU has both (read from ``cpuinfo``),
    else nothing.  The flags are part of the JIT cache's key, so a machine without
    them never loads code compiled with them: it compiles its own."""
    import platform

    if (machine or platform.machine()).lower() not in ("x86_64", "amd64"):
        return ()
    try:
        with open(cpuinfo, encoding="ascii", errors="replace") as f:
            for line in f:
                if line.startswith("flags"):
                    have = set(line.split(":", 1)[1].split())
                    return ("-mavx2", "-mfma") if {"avx2", "fma"} <= have else ()
    except OSError:
        pass
    return ()


#: C compiler flags of every form rftfem compiles (benchmarks/form_cost.py):
#: ``-O3`` with the CPU's vector instructions (AVX2 and fused multiply-adds, where it
#: has them) and reassociation, which lets the compiler vectorise the kernels'
#: sums; NaN and infinity keep their meaning (no ``-ffinite-math-only``: a NaN
#: residual must still stop Newton).  ``-fno-math-errno`` emits ``sqrt`` as one
#: instruction.  Results change in the last bits only.  The shell's Jacobian kernel
#: costs about half as much as with the JIT's own ``-O2`` (docs/performance.md).
#: ``RFTFEM_COMPILE_FLAGS`` in the environment replaces them (e.g. "-O2 -g0").
FLAGS_FROM_ENVIRONMENT = bool(os.environ.get("RFTFEM_COMPILE_FLAGS"))
COMPILE_FLAGS = (
    tuple(os.environ["RFTFEM_COMPILE_FLAGS"].split())
    if FLAGS_FROM_ENVIRONMENT
    else (
        "-O3",
        "-g0",
        "-fno-math-errno",
        "-fno-trapping-math",
        "-fno-signed-zeros",
        "-fassociative-math",
        "-freciprocal-math",
    )
    + vector_flags()
)
#: seconds a process waits for another one compiling the same form into the shared
#: JIT cache (runs of a study side by side); the JIT's own 10 s failed them, the
#: shell's Jacobian takes 20-90 s to compile
COMPILE_WAIT = 300

#: SNES's converged reason for a residual that is NaN or infinite: PETSc 3.18 calls it
#: DIVERGED_FNORM_NAN, PETSc >= 3.22 DIVERGED_FUNCTION_NANORINF (compared by name)
SNES_NOT_FINITE = ("DIVERGED_FNORM_NAN", "DIVERGED_FUNCTION_NANORINF")


def form(
    ufl_form: ufl.Form | list[ufl.Form], jit_options: dict | None = None
) -> dolfinx.fem.Form | list[dolfinx.fem.Form]:
    """Compile a UFL form (list of forms allowed) to a dolfinx Form, with
    ``COMPILE_FLAGS`` and ``COMPILE_WAIT`` unless ``jit_options`` gives its own."""
    options = {
        "cffi_extra_compile_args": list(COMPILE_FLAGS),
        "timeout": COMPILE_WAIT,
        **(jit_options or {}),
    }
    try:
        return dolfinx.fem.form(ufl_form, **{_JIT_KEY: options})
    except Exception as error:
        # the C compiler refused a user's flags: a bad option, not a traceback
        if FLAGS_FROM_ENVIRONMENT and "CompileError" in str(error):
            from rftfem.errors import SceneError

            raise SceneError(
                "RFTFEM_COMPILE_FLAGS: the C compiler failed with the flags "
                f"'{' '.join(COMPILE_FLAGS)}' (unset it, or give flags it "
                "accepts)"
            ) from error
        raise


def petsc_vec(f: dolfinx.fem.Function) -> PETSc.Vec:
    """The PETSc vector wrapping a Function's (owned + ghost) values."""
    x = f.x
    if hasattr(x, "petsc_vec"):
        return x.petsc_vec
    return f.vector


def scatter_add(f: dolfinx.fem.Function) -> None:
    """Sum a Function's ghost entries into their owners, then copy the sums back to
    the ghosts (a nodal sum over cells of several processes)."""
    vec = petsc_vec(f)
    vec.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    vec.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)


def create_vector(L: Any, V: dolfinx.fem.FunctionSpace) -> PETSc.Vec:
    """A ghosted PETSc vector for the linear form ``L`` on space ``V``.

    Here and in the assembly calls below, a form that maps its own unknowns
    (rftfem/model/directors.py, ``MappedForm``) is handed its own method."""
    if hasattr(L, "create_vector"):
        return L.create_vector()
    try:
        return dolfinx.fem.petsc.create_vector(V)
    except (TypeError, AttributeError, RuntimeError):
        return dolfinx.fem.petsc.create_vector(L)


def create_matrix(a: Any, kind: str | None = None) -> PETSc.Mat:
    """A PETSc matrix for the bilinear form ``a``; ``kind`` a PETSc matrix type
    (``"baij"``, ...; None: dolfinx's default), named ``mat_type`` in dolfinx 0.5."""
    if hasattr(a, "create_matrix"):
        return a.create_matrix(kind)
    if kind is None:
        return dolfinx.fem.petsc.create_matrix(a)
    create = dolfinx.fem.petsc.create_matrix
    return create(a, **{_keyword(create, "kind", "mat_type"): kind})


def assemble_vector(b: PETSc.Vec, L: Any) -> None:
    if hasattr(L, "assemble_vector"):
        return L.assemble_vector(b)
    dolfinx.fem.petsc.assemble_vector(b, L)


def assemble_matrix(A: PETSc.Mat, a: Any, bcs: list[dolfinx.fem.DirichletBC]) -> None:
    if hasattr(a, "assemble_matrix"):
        return a.assemble_matrix(A, bcs)
    dolfinx.fem.petsc.assemble_matrix(A, a, bcs=bcs)


def apply_lifting(
    b: PETSc.Vec, a: Any, bcs: list[dolfinx.fem.DirichletBC], x0: PETSc.Vec, scale: float
) -> None:
    """``b -= scale * A (g - x0)`` on the rows coupled to Dirichlet dofs."""
    if hasattr(a, "apply_lifting"):
        return a.apply_lifting(b, bcs, x0, scale)
    dolfinx.fem.petsc.apply_lifting(b, [a], bcs=[bcs], x0=[x0], **{_LIFTING_KEY: scale})


def set_bc(
    b: PETSc.Vec,
    bcs: list[dolfinx.fem.DirichletBC],
    x0: PETSc.Vec | None = None,
    scale: float = 1.0,
) -> None:
    dolfinx.fem.petsc.set_bc(b, bcs, x0, scale)


# --- geometry ---------------------------------------------------------------


def colliding_cells(mesh: dolfinx.mesh.Mesh, points: np.ndarray) -> list[np.ndarray]:
    """For each row of ``points`` (N, 3): the local cells that contain it."""
    tdim = mesh.topology.dim
    geom = dolfinx.geometry
    if hasattr(geom, "bb_tree"):
        tree = geom.bb_tree(mesh, tdim)
        candidates = geom.compute_collisions_points(tree, points)
    else:
        tree = geom.BoundingBoxTree(mesh, tdim)
        candidates = geom.compute_collisions(tree, points)
    cells = geom.compute_colliding_cells(mesh, candidates, points)
    return [np.asarray(cells.links(i)) for i in range(points.shape[0])]


def nearest_cells(
    mesh: dolfinx.mesh.Mesh, points: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For each row of ``points``: the local cell nearest to it (among the cells of its
    nearest geometry node), the distance to that cell and the cell's size (its largest
    node-to-node distance); -1, inf, 0 on a process without cells."""
    x = mesh.geometry.x
    cells, _ = geometry_cells(mesh)
    n = len(points)
    out = (np.full(n, -1, dtype=np.int32), np.full(n, np.inf), np.zeros(n))
    if len(cells) == 0:
        return out
    for i, p in enumerate(points):
        node = int(np.argmin(np.linalg.norm(x - p, axis=1)))
        near = np.flatnonzero((cells == node).any(axis=1)).astype(np.int32)
        d2 = dolfinx.geometry.squared_distance(
            mesh, mesh.topology.dim, near, np.tile(p, (len(near), 1))
        )
        k = int(np.argmin(d2))
        corners = x[cells[near[k]]]
        out[0][i], out[1][i] = near[k], float(np.sqrt(max(d2[k], 0.0)))
        out[2][i] = float(np.max(np.linalg.norm(corners[:, None] - corners[None], axis=2)))
    return out


# --- meshes -----------------------------------------------------------------


def gmsh_model_to_mesh(
    model: type[gmsh.model] | None, comm: MPI.Comm, rank: int = 0, gdim: int = 3
) -> tuple[dolfinx.mesh.Mesh, dolfinx.mesh.MeshTags, dolfinx.mesh.MeshTags]:
    """(mesh, cell_tags, facet_tags) from a gmsh model built on ``rank``."""
    try:
        from dolfinx.io import gmsh as _gmshio  # dolfinx >= 0.10
    except ImportError:
        from dolfinx.io import gmshio as _gmshio  # dolfinx 0.5 - 0.9
    out = _gmshio.model_to_mesh(model, comm, rank, gdim=gdim, **_shared_facet_partitioner())
    if hasattr(out, "mesh"):  # MeshData (>= 0.10)
        return out.mesh, out.cell_tags, out.facet_tags
    return out[0], out[1], out[2]


def _shared_facet_partitioner() -> dict:
    """``partitioner=`` keeping both cells of every facet on the processes that share
    it (ghost mode ``shared_facet``), which interior-facet integrals (``dS``, the
    spring hinges) need across a partition.  dolfinx >= 0.10 defaults to no ghost
    cells and its ``create_cell_partitioner(mode, max_facet_to_cell_links)`` takes
    the mode; 0.6-0.9 take the mode alone; 0.5 passes the mode to ``create_mesh``
    instead, and its gmsh reader already asks for ``shared_facet``."""
    make = getattr(dolfinx.mesh, "create_cell_partitioner", None)
    mode = dolfinx.mesh.GhostMode.shared_facet
    for args in ((mode, 2), (mode,)):
        try:
            return {"partitioner": make(*args)}
        except TypeError:
            continue
    return {}


def serial_lagrange_mesh(
    cell: str, degree: int, cells: np.ndarray, x: np.ndarray
) -> dolfinx.mesh.Mesh:
    """A mesh on this process alone (``COMM_SELF``) with Lagrange geometry of
    ``degree`` on ``cell`` ("quadrilateral"/"triangle") in 3D, from nodes ``x``
    and ``cells`` in dolfinx's node order.  0.5 takes ``(comm, cells, x, domain)``
    with a UFL element, 0.10 on ``(comm, cells, e, x)`` with a basix one."""
    from mpi4py import MPI

    if _HAS_BASIX_UFL:
        domain = ufl.Mesh(_basix_ufl.element("Lagrange", cell, degree, shape=(3,)))
        return dolfinx.mesh.create_mesh(MPI.COMM_SELF, cells, domain, x)
    domain = ufl.Mesh(ufl.VectorElement("Lagrange", ufl.Cell(cell, geometric_dimension=3), degree))
    return dolfinx.mesh.create_mesh(MPI.COMM_SELF, cells, x, domain)


def local_to_global(index_map: dolfinx.common.IndexMap, local: np.ndarray) -> np.ndarray:
    """Global numbers of the local indices ``local`` of ``index_map``."""
    return np.asarray(index_map.local_to_global(np.asarray(local, dtype=np.int32)), dtype=np.int64)


def create_meshtags(
    mesh: dolfinx.mesh.Mesh, dim: int, entities: np.ndarray, values: np.ndarray
) -> dolfinx.mesh.MeshTags:
    order = np.argsort(entities)
    return dolfinx.mesh.meshtags(
        mesh, dim, entities[order].astype(np.int32), values[order].astype(np.int32)
    )


# --- versions ---------------------------------------------------------------


def versions() -> dict:
    import petsc4py

    v = PETSc.Sys.getVersion()
    return {
        "dolfinx": dolfinx.__version__,
        "ufl": getattr(ufl, "__version__", "unknown"),
        "petsc": ".".join(str(i) for i in v),
        "petsc4py": petsc4py.__version__,
    }


def petsc_unlimited() -> int:
    """The value that switches a PETSc tolerance off.

    PETSc ≥ 3.22 has ``PETSC_UNLIMITED`` (−3) and reads −1 as "the default"
    (a divergence tolerance of 1e4); older versions switch off with −1.
    """
    return int(getattr(PETSc, "UNLIMITED", -1))


def has_mumps() -> bool:
    return bool(PETSc.Sys.hasExternalPackage("mumps"))


# arguments renamed between dolfinx versions, detected once: jit_params → jit_options,
# scale → alpha (apply_lifting)
_JIT_KEY = _keyword(dolfinx.fem.form, "jit_options", "jit_params")
_LIFTING_KEY = _keyword(dolfinx.fem.petsc.apply_lifting, "alpha", "scale")


# --- output files ------------------------------------------------------------


def repair_xdmf_namespace(path: str | os.PathLike[str]) -> None:
    """Give an XDMF file written by ``dolfinx.io.XDMFFile`` the XInclude namespace
    that XML parsers know.

    dolfinx 0.11 writes ``xmlns:xi="https://www.w3.org/2001/XInclude"``; the
    namespace is ``http://...`` and nothing else, so ParaView's and VTK's
    readers ignore every ``xi:include`` (the time steps lose their mesh and VTK
    crashes). dolfinx 0.5 writes it right. Detected by content: a right file is
    left alone. (``rftfem.outputs.render`` reads a file that was never repaired, e.g.
    of a killed run, through a repaired copy.)
    """
    from pathlib import Path

    path = Path(path)
    text = path.read_text(encoding="utf-8")
    bad = 'xmlns:xi="https://www.w3.org/2001/XInclude"'
    if bad in text:
        tmp = path.with_suffix(".xdmf.tmp")
        tmp.write_text(
            text.replace(bad, 'xmlns:xi="http://www.w3.org/2001/XInclude"'), encoding="utf-8"
        )
        tmp.replace(path)
