"""rftfem: large-rotation Reissner-Mindlin shells swimming in viscous fluid."""

__version__ = "0.1.0"

# The current stack's dolfinx-solver-real wheel must be imported before dolfinx
# (it loads the MPI and PETSc libraries dolfinx links to).  Doing it here, when
# rftfem is imported, lets user scripts and tests import dolfinx after rftfem.
# This is the only stack difference outside rftfem/compat.py.
try:
    import dolfinx_solver  # noqa: F401
except ImportError:
    pass
