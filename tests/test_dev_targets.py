"""dev.sh turns a pytest run that collects nothing into a failure (docs/development.md, "Tests"):
a filter that matches no test must not pass as a green run."""

from __future__ import annotations

import os
import subprocess

from conftest import ROOT


def test_a_run_that_collects_no_test_fails():
    env = {k: v for k, v in os.environ.items() if not k.startswith("PYTEST")}
    done = subprocess.run(["bash", str(ROOT / "dev.sh"), "test", "-p", "no:cacheprovider",
                           "-k", "no_test_has_this_name_xyz"], cwd=ROOT, env=env,
                          capture_output=True, text=True, timeout=900, stdin=subprocess.DEVNULL)
    assert done.returncode == 1, done.stdout[-1000:] + done.stderr[-1000:]
    assert "pytest collected no tests (exit 5)" in done.stderr
