"""The C compiler flags of rftfem's forms (rftfem/compat/compilation.py, docs/running.md):
vector instructions only where the CPU has them, the environment's flags
replacing the defaults, and every form compiled with them."""

from __future__ import annotations

import os
import subprocess
import sys

from conftest import ROOT

from rftfem import compat


def _cpuinfo(tmp_path, flags: str):
    path = tmp_path / "cpuinfo"
    path.write_text(f"processor\t: 0\nvendor_id\t: X\nflags\t\t: fpu sse2 {flags}\n\n")
    return str(path)


def test_vector_instructions_only_where_the_cpu_has_them(tmp_path):
    both = _cpuinfo(tmp_path, "avx avx2 fma bmi2")
    assert compat.vector_flags(both, "x86_64") == ("-mavx2", "-mfma")
    assert compat.vector_flags(_cpuinfo(tmp_path, "avx avx2"), "x86_64") == ()  # no FMA
    assert compat.vector_flags(_cpuinfo(tmp_path, "avx fma"), "x86_64") == ()  # no AVX2
    assert compat.vector_flags(both, "aarch64") == ()  # not x86
    assert compat.vector_flags(str(tmp_path / "missing"), "x86_64") == ()


def test_defaults_keep_nan_and_the_environment_replaces_them():
    flags = compat.COMPILE_FLAGS if not os.environ.get("RFTFEM_COMPILE_FLAGS") else ()
    # a NaN residual must still stop Newton: nothing that assumes finite values
    assert not {"-ffast-math", "-ffinite-math-only", "-Ofast"} & set(flags)
    env = dict(os.environ, RFTFEM_COMPILE_FLAGS="-O1 -g0")
    done = subprocess.run(
        [sys.executable, "-c", "from rftfem import compat; print(' '.join(compat.COMPILE_FLAGS))"],
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.split() == ["-O1", "-g0"]


def test_every_form_is_compiled_with_them(monkeypatch):
    seen = {}

    def fake_form(ufl_form, **kwargs):
        seen.update(kwargs)
        return "compiled"

    monkeypatch.setattr(compat.dolfinx.fem, "form", fake_form)
    assert compat.form("a form") == "compiled"
    (options,) = seen.values()
    assert options["cffi_extra_compile_args"] == list(compat.COMPILE_FLAGS)


def test_flags_the_compiler_refuses_are_one_line(tmp_path):
    """A bad RFTFEM_COMPILE_FLAGS is a bad option (exit 2, one line naming it, after
    the compiler's own line naming the flag), not a traceback."""
    env = dict(os.environ, RFTFEM_COMPILE_FLAGS="-O2 -fno-such-flag-xyz")
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "rftfem",
            "run",
            str(ROOT / "demos" / "rollup.toml"),
            "--out",
            str(tmp_path / "out"),
            "--quiet",
        ],
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 2, done.stderr[-2000:]
    assert "Traceback" not in done.stderr, done.stderr[-2000:]
    last = done.stderr.strip().splitlines()[-1]
    assert last.startswith("rftfem: error: RFTFEM_COMPILE_FLAGS: the C compiler failed"), last
