"""Scenes: reading a TOML scene, its keys and their checks (docs/scenes.md).

- ``reading``: read a file or text, validate and complete; ``dotted_keys``: one
  key set or removed by its dotted path; ``overrides``: ``--set`` and ``--unset``
  on every command that reads a scene; ``python_changes``: the same from Python;
- ``keys``: the top-level tables (``title``, ``[shell]``, ``[output]``) and the
  checks across them; ``time_keys``, ``solver_keys``, ``mesh_keys``,
  ``material_keys``: ``[time]``, ``[solver]``, ``[mesh]`` and the material;
  ``time_rules``: the time table's rules that read the rest of the scene;
  ``bodies``: several ``[[body]]`` tables; each effect's keys live with the effect
  (``rftfem.model.effects``);
- the schema language: ``schema`` (tables, arrays, the walk), ``validators`` (one
  value), ``messages`` (the wording of every error), ``rows`` (tables over time),
  ``expressions`` and ``formula_grammar`` (the formulas a number may be),
  ``selectors`` (``where`` and region names);
- ``fields``, ``profiles``: material fields and CSV profiles; ``scales``: the
  drives' periods and the scene's dimensionless groups;
- ``key_reference``: docs/scenes.md's table of keys; ``toml_writer``: scenes as
  text.

Nothing here imports dolfinx at import time.
"""
