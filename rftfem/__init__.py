"""rftfem: large-rotation Reissner-Mindlin shells swimming in viscous fluid."""

__version__ = "0.1.0"
