"""Scenes: reading a TOML scene, its keys and their checks (docs/scenes.md).

- ``reading``: read a file or text, apply ``--set`` and ``--unset``, validate and
  complete; ``overrides``: those two options on every command that reads a scene;
- ``keys``: the top-level tables (``title``, ``[shell]``, ``[time]``, ``[output]``,
  ``[solver]``) and the checks across them; ``mesh_keys`` the ``[mesh]`` table;
  each effect's keys live with the effect (``rftfem.model.effects``);
- ``schema``, ``validators``, ``expressions``: the key types, their checks, and
  the formulas a number may be; ``selectors``: ``where`` and region names;
- ``scales``: the drives' periods and the scene's dimensionless groups;
- ``reference``: docs/scenes.md's generated parts; ``toml_writer``: scenes as text.

Nothing here imports dolfinx at import time.
"""
