"""Differences between rendering stacks (pyvista/VTK), in one place.

- Off-screen rendering without a display: the VTK wheels render through EGL
  when ``libegl1`` and ``libgl1-mesa-dri`` are installed; VTK is told so with
  ``VTK_DEFAULT_OPENGL_WINDOW=vtkEGLRenderWindow`` (a value the user set wins).
  Without those libraries VTK crashes at the first render on a bare machine.
- Import order: dolfinx 0.5 switches the interpreter's dlopen flags to
  ``RTLD_GLOBAL`` and leaves them so; the shared libraries it loads then clash
  with VTK's, and VTK aborts the process when it draws text (a scalar bar).
  Resetting the flags afterwards does not help, so pyvista must be imported
  before dolfinx. :func:`import_pyvista` detects the situation (the flag, not
  a version) and says so instead of letting the process die. This is why
  ``rftfem render`` never imports dolfinx and why a run renders its
  ``output.render`` picture in a child process.

This module imports neither dolfinx nor pyvista at import time.
"""

from __future__ import annotations

import os
import sys
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from types import ModuleType

    import pyvista

#: what the set-up scripts install for off-screen rendering (Debian package names)
RENDER_DEBIAN_PACKAGES = ("libegl1", "libgl1-mesa-dri")


def _vtk_loaded() -> bool:
    return "vtkmodules.vtkRenderingCore" in sys.modules


def import_pyvista() -> ModuleType:
    """Import and return pyvista, configured for off-screen rendering."""
    if (
        not _vtk_loaded()
        and "dolfinx" in sys.modules
        and sys.getdlopenflags() & getattr(os, "RTLD_GLOBAL", 0)
    ):
        raise RuntimeError(
            "pyvista must be imported before dolfinx on this FEniCSx stack (dolfinx loaded "
            "its libraries with RTLD_GLOBAL and VTK would abort): import "
            "rftfem.outputs.render first, "
            "or render in a separate process (`rftfem render RESULTS_DIR`)"
        )
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    try:
        import pyvista
    except ImportError as exc:
        raise RuntimeError(
            f"rendering needs pyvista ({exc}); scripts/setup.sh installs it"
        ) from None
    pyvista.OFF_SCREEN = True
    return pyvista


def tessellate(grid: pyvista.UnstructuredGrid, level: int) -> pyvista.PolyData:
    """The surface of ``grid`` with nonlinear cells cut into ``2**level`` pieces per
    edge (VTK's nonlinear subdivision).  pyvista 0.47 on warns unless the surface
    algorithm is named; older versions have no such keyword."""
    import inspect

    kwargs = {"nonlinear_subdivision": level}
    if "algorithm" in inspect.signature(grid.extract_surface).parameters:
        kwargs["algorithm"] = "dataset_surface"
    return grid.extract_surface(**kwargs)
