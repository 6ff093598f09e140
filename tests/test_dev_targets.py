"""dev.sh turns a pytest run that collects nothing into a failure (docs/development.md, "Tests"):
a filter that matches no test must not pass as a green run."""

from __future__ import annotations

import os
import subprocess

from conftest import ROOT


def test_a_run_that_collects_no_test_fails():
    env = {k: v for k, v in os.environ.items() if not k.startswith("PYTEST")}
    done = subprocess.run(
        [
            "bash",
            str(ROOT / "dev.sh"),
            "test",
            "-p",
            "no:cacheprovider",
            "-k",
            "no_test_has_this_name_xyz",
        ],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=900,
        stdin=subprocess.DEVNULL,
    )
    assert done.returncode == 1, done.stdout[-1000:] + done.stderr[-1000:]
    assert "pytest collected no tests (exit 5)" in done.stderr


def _kernels(tmp_path, variants):
    env = {
        k: v for k, v in os.environ.items() if not k.startswith(("PYTEST", "OPENBLAS", "OMP_NUM"))
    }
    env.update(RFTFEM_KERNELS=variants, RFTFEM_KERNEL_LOGS=str(tmp_path))
    return subprocess.run(
        [
            "bash",
            str(ROOT / "dev.sh"),
            "test-kernels",
            "reference",
            "tests/test_layout.py",
            "-k",
            "no_module_over",
        ],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=900,
        stdin=subprocess.DEVNULL,
    )


def test_kernel_variants_run_the_kernels_they_name(tmp_path):
    """./dev.sh test-kernels runs pytest once per variant with every OpenBLAS of the
    stack on the kernels it names (or on one thread), as each log's header shows; a
    kernel type that OpenBLAS does not take (it falls back to the CPU's own) fails the
    variant instead of passing as a run under the machine's kernels."""
    done = _kernels(tmp_path, "Haswell threads1")
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    haswell = (tmp_path / "reference-Haswell.log").read_text()
    one = (tmp_path / "reference-threads1.log").read_text()
    assert "OpenBLAS Haswell, " in haswell and "1 passed" in haswell
    assert ", 1 thread(s)" in one and " 2 thread(s)" not in one and "1 passed" in one
    done = _kernels(tmp_path, "NoSuchCore")
    assert done.returncode == 1
    assert "kernels, not NoSuchCore" in (tmp_path / "reference-NoSuchCore.log").read_text()
