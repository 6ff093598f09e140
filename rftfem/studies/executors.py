"""Where the runs of a sweep, a study or a design loop happen (``--executor``).

Every executor runs one scene with its overrides into one folder and returns the
exit status of ``rftfem run``; the commands call :meth:`Executor.run` from as many
threads as runs may go side by side, so an executor is only a way to start a run:

- ``local`` (the default): this machine's processes: a child ``rftfem run`` per
  run (``--jobs`` side by side, ``--np P``: under ``mpirun -n P``), or, for one
  run at a time on one process, the runs in the command's own process
  (:mod:`rftfem.studies.batch`);
- ``dask``: a Dask ``LocalCluster`` of ``--jobs`` single-threaded worker processes;
- ``dask://HOST:PORT``: the workers of a running Dask scheduler (``dask scheduler``
  and ``dask worker`` on a cluster's nodes, sharing the file system);
- ``slurm``: dask-jobqueue's ``SLURMCluster``: ``--jobs`` batch jobs of one worker
  each, with the options of ``--slurm KEY=VALUE`` or an ``--executor-config`` file
  (docs/running.md, "Sweeps on a cluster").

On a Dask worker a run is a child ``rftfem run`` (under ``mpirun -n P`` with
``--np P``) started by the worker: each run has its own process, so no two runs'
PETSc ever share a communicator, and what the engine ships is only what pickles
(the scene file's path, the overrides, the folder). The child dies with its
worker. A run whose worker dies is started once more on another worker (the
scheduler's ``allowed-failures`` is 1); if that one dies too the run is a failure
whose reason says so. Nothing else is retried: a run that fails by itself has
failed.
"""

from __future__ import annotations

import re
import shutil
from pathlib import Path
from typing import TYPE_CHECKING

from rftfem.errors import SceneError
from rftfem.studies.slurm import SLURM_KEYS, slurm_cluster, slurm_options

if TYPE_CHECKING:
    import argparse

    import distributed
    import distributed.deploy

#: seconds to wait for a Dask scheduler given by address before saying it is unreachable
CONNECT_TIMEOUT = 8.0
#: exit status of a run whose worker died twice (not one of rftfem run's own)
WORKER_DIED = 137


def add_arguments(
    parser: argparse.ArgumentParser,
    command: str,
    runs: str = "runs",
    jobs_note: str = "",
    reuse_note: str = "",
) -> None:
    """The options that sweep, study and optimize share: ``--set`` and ``--unset`` (for
    every run), ``--out``, ``--jobs``, ``--np``, ``--reuse``, ``--executor`` and its
    options. ``command`` names the default folder (results/<command>-<scene file
    stem>), ``runs`` what its runs are called (levels, evaluations); the notes end
    the help of --jobs and --reuse."""
    from rftfem.scene.overrides import add_override_arguments

    add_override_arguments(parser)
    _add_run_options(parser, command, runs, jobs_note, reuse_note)
    _add_executor_options(parser)


def _add_run_options(
    parser: argparse.ArgumentParser, command: str, runs: str, jobs_note: str, reuse_note: str
) -> None:
    """``--out``, ``--jobs``, ``--np`` and ``--reuse``."""
    parser.add_argument(
        "--out",
        metavar="DIR",
        type=Path,
        default=None,
        help=f"the folder of the {runs} and tables (default results/{command}-<scene file stem>)",
    )
    parser.add_argument(
        "--jobs",
        metavar="J",
        type=int,
        default=1,
        help=f"{runs} side by side (local processes, or Dask workers; default 1){jobs_note}",
    )
    parser.add_argument(
        "--np",
        metavar="P",
        type=int,
        default=1,
        help=f"each {runs[:-1]} under mpirun -n P (with the local executor, one at a time)",
    )
    parser.add_argument(
        "--reuse",
        action="store_true",
        help=f"keep the {runs} --out already holds finished from the same "
        "content (the completed scene, the files it names, the PETSc "
        f"options); run only the others{reuse_note}",
    )


def _add_executor_options(parser: argparse.ArgumentParser) -> None:
    """``--executor`` and the options of ``--executor slurm``."""
    parser.add_argument(
        "--executor",
        metavar="E",
        default="local",
        help="where the runs happen: local (this machine's processes, the "
        "default), dask (a local Dask cluster of --jobs workers), "
        "dask://HOST:PORT (a running Dask scheduler), slurm "
        "(dask-jobqueue's SLURMCluster, --jobs batch jobs)",
    )
    parser.add_argument(
        "--slurm",
        metavar="KEY=VALUE",
        action="append",
        default=[],
        help="with --executor slurm: a SLURMCluster option, one of "
        + ", ".join(SLURM_KEYS)
        + " (job_extra repeatable: an "
        "#SBATCH line's option, e.g. job_extra=--constraint=cpu); "
        "repeatable",
    )
    parser.add_argument(
        "--executor-config",
        metavar="FILE",
        type=Path,
        default=None,
        help="with --executor slurm: a TOML file whose [slurm] table holds "
        "the same options (the command line's win)",
    )
    parser.add_argument(
        "--print-job-script",
        action="store_true",
        help="with --executor slurm: print the batch job script and stop (nothing is submitted)",
    )


class Executor:
    """Starts runs; :meth:`run` is called from several threads at once."""

    name = "local"

    def run(
        self,
        scene_file: str | Path,
        overrides: list[str],
        folder: Path,
        petsc_args: list[str] | None = None,
    ) -> int:
        raise NotImplementedError

    def close(self) -> None:
        pass

    def describe(self) -> str:
        return self.name


class LocalExecutor(Executor):
    """This machine: child processes, or this process for one run at a time."""

    def __init__(self, jobs: int = 1, np: int = 1, in_process: bool | None = None):
        from rftfem.studies.batch import launcher

        self.jobs, self.np = jobs, np
        self.launcher = launcher(np)
        self.in_process = (jobs == 1 and np == 1) if in_process is None else in_process

    def run(
        self,
        scene_file: str | Path,
        overrides: list[str],
        folder: Path,
        petsc_args: list[str] | None = None,
    ) -> int:
        from rftfem.studies.batch import run_child, run_here

        if self.in_process:
            return run_here(scene_file, list(overrides), Path(folder), petsc_args)
        return run_child(scene_file, list(overrides), Path(folder), self.launcher, petsc_args)

    def describe(self) -> str:
        how = "in this process" if self.in_process else f"{self.jobs} process(es) at a time"
        return f"local ({how}" + (f", each on {self.np}" if self.np > 1 else "") + ")"


def remote_run(
    scene_file: str, overrides: list[str], folder: str, np: int, petsc_args: list[str]
) -> int:
    """What a Dask worker does for one run: a fresh folder, then a child ``rftfem
    run`` (under mpirun with ``np`` > 1) that dies if the worker dies."""
    from rftfem.studies.batch import launcher, run_child

    folder = Path(folder)
    if folder.exists():  # a run whose first worker died left its partial outputs
        shutil.rmtree(folder)
    return run_child(scene_file, overrides, folder, launcher(np), petsc_args, die_with_parent=True)


class DaskExecutor(Executor):
    """Runs submitted to a Dask cluster: each a task that starts a child run."""

    def __init__(
        self,
        client: distributed.Client,
        np: int = 1,
        cluster: distributed.deploy.Cluster | None = None,
        name: str = "dask",
    ):
        self.client, self.cluster, self.np, self.name = client, cluster, np, name

    def run(
        self,
        scene_file: str | Path,
        overrides: list[str],
        folder: Path,
        petsc_args: list[str] | None = None,
    ) -> int:
        from distributed import KilledWorker

        future = self.client.submit(
            remote_run,
            str(Path(scene_file).resolve()),
            list(overrides),
            str(Path(folder).resolve()),
            self.np,
            list(petsc_args or []),
            pure=False,
        )
        try:
            return int(future.result())
        except KilledWorker as exc:
            folder = Path(folder)
            folder.mkdir(parents=True, exist_ok=True)
            (folder / "run.log").write_text(
                f"rftfem: the Dask worker running this died, and so did the one it was "
                f"given to next ({exc.__class__.__name__})\n",
                encoding="utf-8",
            )
            return WORKER_DIED

    def close(self) -> None:
        self.client.close()
        if self.cluster is not None:
            self.cluster.close()

    def describe(self) -> str:
        workers = len(self.client.scheduler_info().get("workers", {}))
        return f"{self.name} ({workers} worker(s), dashboard {self.client.dashboard_link})"


def _dask():
    try:
        import dask
        import distributed
    except ImportError as exc:
        raise SceneError(
            f"--executor: Dask is not installed here ({exc}); scripts/setup.sh "
            "installs dask, distributed and dask-jobqueue"
        ) from None
    # a run whose worker dies is given to another worker once, then is a failure
    dask.config.set(
        {"distributed.scheduler.allowed-failures": 1, "distributed.worker.daemon": False}
    )
    return distributed


def make_executor(
    spec: str,
    jobs: int = 1,
    np: int = 1,
    slurm: list[str] = (),
    config: Path | None = None,
    print_job_script: bool = False,
    in_process: bool | None = None,
) -> Executor | None:
    """The executor ``--executor spec`` names (None after ``--print-job-script``, which
    prints the job script instead). Bad options and unreachable schedulers are
    SceneErrors."""
    spec = (spec or "local").strip()
    if spec != "slurm" and (slurm or config is not None or print_job_script):
        raise SceneError(
            "--slurm, --executor-config and --print-job-script go with --executor slurm"
        )
    if spec == "local":
        return LocalExecutor(jobs, np, in_process)
    if spec == "dask":
        return _local_cluster(jobs, np)
    match = re.fullmatch(r"dask://([^:/\s]+):(\d+)", spec)
    if match:
        return _scheduler(spec, f"tcp://{match.group(1)}:{match.group(2)}", np)
    if spec == "slurm":
        return _slurm(jobs, np, slurm, config, print_job_script)
    raise SceneError(f"--executor {spec}: expected local, dask, dask://HOST:PORT or slurm")


def _local_cluster(jobs: int, np: int) -> DaskExecutor:
    """``--executor dask``: a LocalCluster of ``jobs`` single-threaded workers."""
    distributed = _dask()
    import logging

    cluster = distributed.LocalCluster(
        n_workers=jobs,
        threads_per_worker=1,
        processes=True,
        dashboard_address=":0",
        silence_logs=logging.ERROR,
    )
    return DaskExecutor(distributed.Client(cluster), np, cluster)


def _scheduler(spec: str, address: str, np: int) -> DaskExecutor:
    """``--executor dask://HOST:PORT``: the running scheduler at ``address``."""
    distributed = _dask()
    try:
        client = distributed.Client(address, timeout=CONNECT_TIMEOUT)
    except (OSError, TimeoutError) as exc:
        raise SceneError(
            f"--executor {spec}: no Dask scheduler answers at {address} "
            f"within {CONNECT_TIMEOUT:g} s ({exc.__class__.__name__})"
        ) from None
    return DaskExecutor(client, np, None, name=spec)


def _slurm(
    jobs: int, np: int, slurm: list[str], config: Path | None, print_job_script: bool
) -> DaskExecutor | None:
    """``--executor slurm``: ``jobs`` batch jobs of a SLURMCluster (None after
    ``--print-job-script``, which prints the job script instead)."""
    _dask()
    cluster = slurm_cluster(slurm, config, np)
    if print_job_script:
        print(cluster.job_script())
        cluster.close()
        return None
    if shutil.which(cluster.job_cls.submit_command.split()[0]) is None:
        cluster.close()
        raise SceneError(
            "--executor slurm: sbatch is not on PATH (not a SLURM login "
            "node); --print-job-script shows the job script"
        )
    cluster.scale(jobs=jobs)
    distributed = _dask()
    return DaskExecutor(distributed.Client(cluster), np, cluster, name="slurm")


def check_executor_options(jobs: int, np: int, executor: str, what: str = "runs") -> None:
    """``--jobs`` and ``--np`` as :func:`rftfem.studies.batch.check_jobs` says for the
    local executor; with Dask both may be given (J workers, each run on P processes)."""
    from rftfem.studies.batch import check_jobs

    if (executor or "local") == "local":
        check_jobs(jobs, np, what)
    elif jobs < 1 or np < 1:
        raise SceneError("--jobs and --np: expected at least 1")


__all__ = [
    "add_arguments",
    "make_executor",
    "Executor",
    "LocalExecutor",
    "DaskExecutor",
    "remote_run",
    "slurm_options",
    "check_executor_options",
    "WORKER_DIED",
]
