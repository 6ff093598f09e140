"""A run of a static scene in this process with its exact gradient (the adjoint of
:mod:`rftfem.studies.sensitivity`, docs/model.md §7.6): what ``rftfem optimize``
evaluates when it can differentiate its objective."""

from __future__ import annotations

import os
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Iterable, NoReturn

from rftfem.errors import SceneError
from rftfem.studies.sensitivity import check_request, keep_last_step
from rftfem.studies.sensitivity import gradient as adjoint_gradient

if TYPE_CHECKING:
    from collections.abc import Callable, Sequence

__all__ = ["run_with_gradient", "run_with_field_gradients", "gradient", "Gradient"]


def run_with_gradient(
    scene_file: str | Path,
    overrides: list[str],
    folder: str | Path,
    keys: list[str],
    objective: str,
    petsc_args: list[str] | None = None,
) -> tuple[int, float | None, list[float] | None]:
    """Run the static scene (time.scheme resolves to "static") in this process into
    ``folder`` as ``rftfem.studies.batch.run_here`` does (same outputs, exit statuses, messages
    to folder/run.log); if it succeeded return ``(0, J, [dJ/dkey for key in keys])``, J
    the objective on the converged final state and its gradient by the adjoint
    (docs/model.md §7.6), also written to folder/gradient.json.  A failed run gives
    ``(status, None, None)``; a key or objective that cannot be differentiated is a
    SceneError, raised before the run."""
    status, result = _run(scene_file, overrides, folder, keys, (), objective, petsc_args)
    if status != 0:
        return status, None, None
    return 0, result["value"], result["gradient"]


def run_with_field_gradients(
    scene_file: str | Path,
    overrides: list[str],
    folder: str | Path,
    fields: list[str],
    objective: str | list[str],
    petsc_args: list[str] | None = None,
    combine: Callable[[list[float]], tuple[float, Sequence[float]]] | None = None,
) -> tuple[int, float | None, dict | None]:
    """As ``run_with_gradient`` for field keys (``shell.thickness``, ...,
    rftfem/studies/field_gradients.py): ``(0, J, {key: FieldGradient})``.  Each key's
    per-cell gradient is written to folder/gradient-KEY.xdmf (a cell field for
    ParaView), a profile's to folder/gradient-KEY.csv (rows X,Y,Z,dJ/dvalue).  With
    ``combine``, ``objective`` is a list of quantities and J = f(them) (``combine``
    as in sensitivity.gradient)."""
    status, result = _run(scene_file, overrides, folder, [], fields, objective, petsc_args, combine)
    if status != 0:
        return status, None, None
    return 0, result["value"], result["fields"]


def _run(scene_file, overrides, folder, keys, fields, objective, petsc_args, combine=None):
    if not isinstance(scene_file, (str, os.PathLike)):  # a Scene object, a dict ...
        raise SceneError(
            f"expected the scene's file, found {type(scene_file).__name__}; for "
            "a rftfem.Scene use rftfem.gradient(scene, objective, keys, fields)"
        )
    from rftfem.integration.simulation import Simulation
    from rftfem.outputs.writers import write_json
    from rftfem.scene.reading import load_scene
    from rftfem.studies.batch import run_here
    from rftfem.studies.field_gradients import check_field_keys

    try:
        scene = load_scene(str(scene_file), list(overrides))
    except SceneError:
        scene = None  # run_here says why, in run.log, and returns exit status 2
    if scene is not None:
        try:
            for text in objective if combine else [objective]:
                check_request(scene, list(keys), text)
            check_field_keys(scene, list(fields))
        except SceneError as exc:  # said in run.log too, as run_here says a bad scene
            Path(folder).mkdir(parents=True, exist_ok=True)
            (Path(folder) / "run.log").write_text(f"rftfem: error: {exc}\n", encoding="utf-8")
            raise
    result = {}

    def simulate(scene, out_dir, quiet, petsc_args):
        # as simulation.run, with the last step's state kept before its triad update
        sim = Simulation(scene, out_dir=out_dir, quiet=quiet, petsc_args=petsc_args)
        try:
            last = keep_last_step(sim.model)
            sim.run()
            t1 = time.perf_counter()
            if combine:
                parsed = check_request(scene, list(keys), objective[0])[0]
                target = ([check_request(scene, [], text)[1] for text in objective], combine)
            else:
                parsed, target = check_request(scene, list(keys), objective)
            got = adjoint_gradient(sim, last, parsed, target, fields=list(fields))
            J, grad = got[0], got[1]
            print(f"rftfem: the gradient by the adjoint in {time.perf_counter() - t1:.2f} s")
            data = {"objective": objective, "value": J, "gradient": dict(zip(keys, grad))}
            if fields:
                data["fields"] = {g.key: _write_field(sim.model, g, Path(out_dir)) for g in got[2]}
                result["fields"] = {g.key: g for g in got[2]}
            write_json(Path(out_dir) / "gradient.json", data, sim.comm)
            result.update(value=J, gradient=grad)
        finally:
            sim.close()

    status = run_here(scene_file, overrides, Path(folder), petsc_args, simulate=simulate)
    return status, result


def _write_field(model, g, out_dir: Path) -> dict:
    """A field gradient's files; their names and the total (the derivative by a
    uniform change of the field) for gradient.json."""
    import numpy as np

    from rftfem.outputs.writers import write_cell_field

    stem = f"gradient-{g.key}"
    if g.cells is not None:
        write_cell_field(out_dir / f"{stem}.xdmf", model.mesh, g.cells)
        n = g.cells.function_space.dofmap.index_map.size_local
        total = model.comm.allreduce(float(np.sum(g.cells.x.array[:n])))
        out = {"cells": f"{stem}.xdmf", "uniform": total}
    else:  # a magnetization profile's gradient at the nodes
        write_cell_field(out_dir / f"{stem}.xdmf", model.mesh, g.nodal_field)
        out = {"nodes": f"{stem}.xdmf"}
    out.update({k: v for k, v in g.extra.items() if not k.startswith("d_")})
    if g.profile is not None:
        points, values = g.profile
        values = np.asarray(values).reshape(len(points), -1)
        names = ("mx", "my", "mz") if values.shape[1] == 3 else ("value",)
        if model.comm.rank == 0:
            rows = "\n".join(
                ",".join(repr(float(v)) for v in (*p, *d)) for p, d in zip(points, values)
            )
            header = ",".join(["X", "Y", "Z"] + [f"dJ/d{n}" for n in names])
            (out_dir / f"{stem}.csv").write_text(f"{header}\n{rows}\n", encoding="utf-8")
        out["profile"] = f"{stem}.csv"
    return out


@dataclass
class Gradient:
    """What :func:`gradient` returns: the objective's value, its derivatives by the
    scalar keys (a pandas Series indexed by key) and by the fields (key -> a pandas
    DataFrame of x, y, z and the derivative by the value at each cell), and the run
    folder (gradient.json, gradient-KEY.xdmf/.csv)."""

    value: float
    keys: Any
    fields: dict
    folder: Path


def gradient(
    scene: Any,
    objective: str,
    keys: Iterable[str] = (),
    fields: Iterable[str] = (),
    out: str | os.PathLike | None = None,
) -> Gradient:
    """Run the static ``scene`` (a Scene, a file or a dict) into ``out`` and return
    the derivatives of ``objective`` (a quantity of the last state, ``tip_uz@end``)
    by scalar ``keys`` (``shell.E``, ``load.0.value.2``) and by material ``fields``
    (``shell.thickness``: per cell), by the adjoint (docs/model.md §7.6), as
    ``rftfem optimize`` gets them.  A bad key or objective raises SceneError, a run
    that fails RunFailed (its ``folder`` set)."""
    import tempfile

    import pandas as pd

    from rftfem.api import _scene_of, default_out

    scene, keys, fields = _scene_of(scene), list(keys), list(fields)
    out = Path(out) if out is not None else default_out(scene)
    # the scene as its file with its changes, or as a file of its own in its folder
    # (where its relative file names are read from)
    if scene.path is not None:
        source, overrides = scene.path, scene.overrides
    else:
        handle, name = tempfile.mkstemp(".toml", ".rftfem-gradient-", scene.folder)
        os.close(handle)
        source, overrides = scene.save(name), []
    try:
        status, result = _run(source, overrides, out, keys, fields, objective, [])
    finally:
        if scene.path is None:
            source.unlink(missing_ok=True)
    if status != 0:
        _raise_failure(out, status)
    tables = _cell_tables(result)
    return Gradient(
        float(result["value"]),
        pd.Series(dict(zip(keys, result.get("gradient") or [])), dtype=float),
        tables,
        out,
    )


def _raise_failure(out: Path, status: int) -> NoReturn:
    """The failed run's last ``rftfem:`` line of out/run.log as a SceneError (a bad
    scene) or a RunFailed with its ``folder``."""
    from rftfem.errors import RunFailed

    log = (out / "run.log").read_text(encoding="utf-8", errors="replace")
    line = next(
        (ln for ln in reversed(log.splitlines()) if ln.startswith("rftfem: ")),
        f"the run ended with exit status {status}",
    )
    text = line.removeprefix("rftfem: ").removeprefix("error: ")
    if status == SceneError.exit_status:
        raise SceneError(text)
    exc = RunFailed(text)
    exc.folder = out
    raise exc


def _cell_tables(result: dict) -> dict:
    """Each cellwise field gradient as a DataFrame of x, y, z and d/dKEY (the cells
    this process owns)."""
    import pandas as pd

    tables = {}
    for key, g in (result.get("fields") or {}).items():
        if g.cells is None:
            continue
        x = g.cells.function_space.tabulate_dof_coordinates()
        n = g.cells.function_space.dofmap.index_map.size_local
        tables[key] = pd.DataFrame(
            {"x": x[:n, 0], "y": x[:n, 1], "z": x[:n, 2], f"d/d{key}": g.cells.x.array[:n]}
        )
    return tables
