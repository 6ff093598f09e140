"""The shipped scripts run from a plain shell right after the README's two commands:
no environment activated, no venv on PATH.  The Python demos and benchmarks then
start under a python3 without rftfem and re-run themselves under the repository's
.venv (scripts/repository_python.py); the shell scripts put .venv/bin on PATH when
`rftfem` is not on it (scripts/use_repository_env.sh).  Each is run in its quickest
form: the Python scripts' --help, the shell scripts on short, coarse runs."""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import pytest
from conftest import ROOT

SCRIPTS = sorted(
    p.relative_to(ROOT) for p in (*ROOT.glob("demos/*.py"), *ROOT.glob("benchmarks/*.py"))
)


def plain_env() -> dict:
    """The environment of a fresh login shell: the system's PATH, no venv, no
    rftfem variables."""
    keep = {
        k: v
        for k, v in os.environ.items()
        if k
        in (
            "HOME",
            "LANG",
            "LC_ALL",
            "TERM",
            "USER",
            "TMPDIR",
            "OMPI_ALLOW_RUN_AS_ROOT",
            "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM",
        )
    }
    return {**keep, "PATH": "/usr/local/bin:/usr/bin:/bin"}


def pythons_without_rftfem() -> list[str]:
    """The system's python3 (Debian's, with dolfinx but without rftfem), and any
    other python3 first on the user's PATH (one without dolfinx either)."""
    found = []
    for path in ("/usr/bin/python3", shutil.which("python3")):
        if path and Path(path).exists() and path not in found and ".venv" not in path:
            found.append(path)
    return found


def run(cmd, cwd=ROOT, timeout=600, env=None):
    return subprocess.run(
        cmd, cwd=cwd, env=env or plain_env(), capture_output=True, text=True, timeout=timeout
    )


@pytest.mark.parametrize("script", SCRIPTS, ids=str)
def test_python_script_runs_from_a_plain_shell(script):
    """``python3 SCRIPT --help`` with each python3 a user may have first on PATH:
    exit 0 and the script's usage."""
    assert (ROOT / ".venv" / "bin" / "python").exists(), "run ./dev.sh setup first"
    for python in pythons_without_rftfem():
        done = run([python, str(script), "--help"], timeout=300)
        assert done.returncode == 0, f"{python} {script}: {done.stderr[-1500:]}"
        assert "usage" in done.stdout.lower(), done.stdout[-500:]


def test_every_script_calls_the_shim_before_rftfem():
    """Each Python script calls ``repository_python.ensure()`` at module level before
    anything imports rftfem or the FEniCSx stack (its --help alone would not show a
    missing call: most demos import rftfem only once they run)."""
    stack = (
        "import rftfem",
        "from rftfem",
        "import dolfinx",
        "from dolfinx",
        "import mpi4py",
        "from mpi4py",
        "import petsc4py",
        "from petsc4py",
    )
    for script in SCRIPTS:
        lines = (ROOT / script).read_text().splitlines()
        call = [i for i, line in enumerate(lines) if line == "repository_python.ensure()"]
        assert call, f"{script} does not call repository_python.ensure()"
        first = [i for i, line in enumerate(lines) if line.strip().startswith(stack)]
        assert not first or first[0] > call[0], f"{script} imports the stack before the call"


def test_shim_runs_the_script_under_the_repository_environment(tmp_path):
    """A script with the demos' prelude, started by a python3 without rftfem, runs
    again under the repository's .venv: it imports rftfem from this checkout."""
    script = tmp_path / "probe.py"
    script.write_text(
        f"import sys\nsys.path.insert(0, {str(ROOT / 'scripts')!r})\n"
        "import repository_python\nrepository_python.ensure()\n"
        "import rftfem\nprint(rftfem.__file__)\n"
    )
    for python in pythons_without_rftfem():
        done = run([python, str(script)], timeout=300)
        assert done.returncode == 0, done.stderr[-1500:]
        assert done.stdout.strip() == str(ROOT / "rftfem" / "__init__.py"), done.stdout


def test_no_environment_is_a_clear_error(tmp_path):
    """A copy of the repository without .venv: a Python demo and a shell script each
    end with exit 2 and one line saying to run ./dev.sh setup, not a traceback."""
    copy = tmp_path / "repo"
    for sub in ("demos", "scripts"):
        shutil.copytree(ROOT / sub, copy / sub)
    python = pythons_without_rftfem()[0]
    done = run([python, "demos/scallop.py", "--help"], cwd=copy)
    assert done.returncode == 2 and "./dev.sh setup" in done.stderr, done.stderr
    assert len(done.stderr.strip().splitlines()) == 1
    done = run(["bash", "demos/parameter_study.sh", str(tmp_path / "out")], cwd=copy)
    assert done.returncode == 2 and "./dev.sh setup" in done.stderr, done.stderr


@pytest.mark.slow
def test_parameter_study_script_from_a_plain_shell(tmp_path):
    """demos/parameter_study.sh as shipped (four short sheet runs and their table)."""
    done = run(
        ["bash", "demos/parameter_study.sh", "-j", "2", str(tmp_path / "study")], timeout=1800
    )
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    rows = (tmp_path / "study" / "table.csv").read_text().strip().splitlines()
    assert len(rows) == 5, rows


@pytest.mark.slow
def test_strip_scripts_from_a_plain_shell(tmp_path):
    """demos/strip_sweep.sh and demos/strip_convergence.sh on one frequency, few steps
    and a coarse mesh: each run, its table and the sweep's plot (the demo's Python
    code, started as python3)."""
    env = {
        **plain_env(),
        "FREQS": "128",
        "PERIODS": "1",
        "STEPS": "10",
        "SETTLE": "0",
        "WINDOW": "0",
    }
    done = run(
        ["bash", "demos/strip_sweep.sh", str(tmp_path / "sweep"), "--set", "mesh.divisions=[5,1]"],
        env=env,
        timeout=1800,
    )
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    assert (tmp_path / "sweep" / "runs.csv").exists() and (
        tmp_path / "sweep" / "sweep.png"
    ).exists()
    assert not (tmp_path / "sweep" / "f128" / "fields.h5").exists()  # rows only, unless FIELDS=true
    done = run(
        ["bash", "demos/strip_convergence.sh", str(tmp_path / "conv")],
        env={**env, "LEVELS": "1"},
        timeout=1800,
    )
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
