"""The SLURM cluster of ``--executor slurm``: its options and dask-jobqueue's ``SLURMCluster``."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import TYPE_CHECKING

from rftfem.errors import SceneError

if TYPE_CHECKING:
    import dask_jobqueue

#: the options of ``--slurm KEY=VALUE`` and their dask-jobqueue names
SLURM_KEYS = {
    "queue": "queue",
    "account": "account",
    "walltime": "walltime",
    "memory": "memory",
    "cores": "cores",
    "job_extra": "job_extra_directives",
    "prologue": "job_script_prologue",
    "interface": "interface",
    "local_directory": "local_directory",
    "log_directory": "log_directory",
}
SLURM_DEFAULTS = {"memory": "4GB", "walltime": "01:00:00"}


def slurm_options(options: list[str], config: Path | None) -> dict:
    """The SLURMCluster keyword arguments of ``--slurm`` and ``--executor-config``."""
    values: dict = dict(SLURM_DEFAULTS)
    extra: list[str] = []
    if config is not None:
        import tomllib

        try:
            table = tomllib.loads(Path(config).read_text(encoding="utf-8")).get("slurm", {})
        except (OSError, tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
            raise SceneError(
                f"--executor-config {config}: cannot be read as TOML ({' '.join(str(exc).split())})"
            ) from None
        if not isinstance(table, dict):
            raise SceneError(f"--executor-config {config}: [slurm] must be a table")
        for key, value in table.items():
            if key not in SLURM_KEYS:
                raise SceneError(
                    f"--executor-config {config}: unknown [slurm] key '{key}' "
                    f"(known: {', '.join(SLURM_KEYS)})"
                )
            if key == "job_extra":
                extra += [str(v) for v in (value if isinstance(value, list) else [value])]
            else:
                values[key] = value
    for text in options:
        key, sep, value = text.partition("=")
        if not sep or key not in SLURM_KEYS:
            raise SceneError(
                f"--slurm {text}: expected KEY=VALUE with KEY one of {', '.join(SLURM_KEYS)}"
            )
        if key == "job_extra":
            extra.append(value)
        else:
            values[key] = value
    kwargs = {SLURM_KEYS[k]: v for k, v in values.items()}
    if "cores" in kwargs:
        try:
            kwargs["cores"] = int(kwargs["cores"])
        except (TypeError, ValueError):
            raise SceneError(f"--slurm cores={kwargs['cores']}: expected a whole number") from None
    if extra:
        kwargs["job_extra_directives"] = extra
    return kwargs


def slurm_cluster(slurm: list[str], config: Path | None, np: int) -> dask_jobqueue.SLURMCluster:
    """The SLURMCluster of ``--slurm`` and ``--executor-config``, one worker of ``np``
    cores a job unless they say otherwise (no job is submitted yet)."""
    try:
        from dask_jobqueue import SLURMCluster
    except ImportError as exc:
        raise SceneError(f"--executor slurm: dask-jobqueue is not installed here ({exc})") from None
    kwargs = slurm_options(list(slurm), config)
    kwargs.setdefault("cores", max(1, np))
    kwargs.setdefault("processes", 1)
    kwargs.setdefault("python", sys.executable)
    try:
        return SLURMCluster(**kwargs)
    except (TypeError, ValueError) as exc:
        raise SceneError(f"--slurm: {' '.join(str(exc).split())}") from None


__all__ = ["SLURM_KEYS", "SLURM_DEFAULTS", "slurm_options", "slurm_cluster"]
