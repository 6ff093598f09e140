"""rftfem: large-rotation Reissner-Mindlin shells swimming in viscous fluid.

The public Python API (docs/python.md) is at the top level and loads its
modules on first use, so that ``import rftfem`` stays cheap::

    import rftfem
    scene = rftfem.load_scene("demos/swimming_sheet.toml")
    result = rftfem.run(scene, out="results/sheet")
"""

__version__ = "0.1.0"

# The current stack's dolfinx-solver-real wheel must be imported before dolfinx
# (it loads the MPI and PETSc libraries dolfinx links to).  Doing it here, when
# rftfem is imported, lets user scripts and tests import dolfinx after rftfem.
# This is the only stack difference outside rftfem/compat/.
try:
    import dolfinx_solver  # noqa: F401
except ImportError:
    pass

#: the public names and the module each comes from (loaded on first use)
_PUBLIC = {
    "Scene": "rftfem.api",
    "load_scene": "rftfem.api",
    "scene_from_dict": "rftfem.api",
    "scene_from_toml": "rftfem.api",
    "run": "rftfem.api",
    "gradient": "rftfem.studies.gradient_runs",
    "Gradient": "rftfem.studies.gradient_runs",
    "Result": "rftfem.result",
    "SceneError": "rftfem.errors",
    "RunFailed": "rftfem.errors",
    "RunWarning": "rftfem.errors",
    "RunInterrupted": "rftfem.errors",
}

__all__ = ["__version__", *_PUBLIC]


def __getattr__(name: str):
    if name in _PUBLIC:
        import importlib

        value = getattr(importlib.import_module(_PUBLIC[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'rftfem' has no attribute {name!r}")


def __dir__():
    return sorted([*globals(), *_PUBLIC])
