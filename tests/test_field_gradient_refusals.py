"""Field gradients the adjoint does not take (rftfem/studies/field_gradients.py,
``check_field_keys``): refused before any run with a one-line SceneError naming the
key, by the Python API (rftfem.gradient) and the command line (``rftfem optimize
--vary-field``: exit status 2); and the case next to them that is taken, two parts
magnetized by numbers.

The scenes are the strips of tests/test_sensitivity.py."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from conftest import ROOT, write_scene
from test_sensitivity import MAGNET, STRIP

#: the magnetized strip with a second part, magnetized along Y, on the other half
#: (the region "root"); ``{other}`` its magnetization
TWO_PARTS = MAGNET.replace(
    '''[[mesh.regions]]
name = "magnet"''',
    '''[[mesh.regions]]
name = "root"
x = [0.0, 5.0]
[[mesh.regions]]
name = "magnet"''',
).replace(
    """[magnetic.field]""",
    """[[magnetic.parts]]
region = "root"
magnetization = {other}
direction = [0.0, 1.0, 0.0]
[magnetic.field]""",
)

#: the bent and twisted strip, orthotropic (no part)
ORTHOTROPIC = (
    STRIP.replace(
        "nu = 0.3", 'material = "orthotropic"\nE1 = 2.4e6\nE2 = 0.6e6\nG12 = 0.4e6\nnu12 = 0.3'
    )
    .replace("E = 1.2e6\n", "")
    .replace('[[shell.parts]]\nregion = "root"\nE = 2.0e6\n', "")
)

KEY = "magnetic.parts.0.magnetization"


@pytest.mark.parametrize(
    "text, key, message",
    [
        (
            MAGNET.replace("magnetization = 100.0", 'magnetization = "100 + 10*X"'),
            KEY,
            "the part is magnetized by a formula",
        ),
        (
            MAGNET.replace("direction = [1.0, 0.0, 0.0]", 'direction = ["1", "0", "0.1*X"]'),
            KEY,
            "the part is magnetized by a formula",
        ),
        (
            TWO_PARTS.format(other='"50 + 5*X"'),
            KEY,
            "another part is magnetized by a formula or profile",
        ),
        (
            TWO_PARTS.format(other="50.0"),
            "magnetic.parts.2.magnetization",
            "the scene has 2 [[magnetic.parts]]",
        ),
        (ORTHOTROPIC, "shell.E", "the shell is orthotropic"),
    ],
    ids=[
        "magnetization-formula",
        "direction-formula",
        "other-part-formula",
        "part-out-of-range",
        "orthotropic-E",
    ],
)
def test_refused_by_the_api(tmp_path, text, key, message):
    """rftfem.gradient refuses, before any run, with a one-line SceneError naming the
    key (also the folder's run.log): a part magnetized by a formula (its value or its
    direction: a gradient is per cell of a number's or per point of a profile's), a
    cellwise gradient while another part is magnetized by a formula, a part the scene
    does not have, E of an orthotropic shell.  Broke: the test on the part's
    direction formulas dropped (check_field_keys) → the direction-formula case
    refused as "another part is magnetized by a formula" (the part itself)."""
    import rftfem

    assert "orthotropic" in text or "[[magnetic.parts]]" in text
    scene = write_scene(tmp_path, text)
    objective = "tip_uz@end" if key == "shell.E" else "tip_ux@end"
    with pytest.raises(rftfem.SceneError) as info:
        rftfem.gradient(scene, objective, fields=[key], out=tmp_path / "out")
    said = str(info.value)
    print(said)
    assert "\n" not in said and said.startswith(f"field gradient '{key}': ") and message in said
    assert (tmp_path / "out" / "run.log").read_text(encoding="utf-8") == f"rftfem: error: {said}\n"
    assert not (tmp_path / "out" / "probes.csv").exists()


@pytest.mark.parametrize(
    "text, field, message",
    [
        (ORTHOTROPIC, "shell.E=1e5:1e7", "(E and nu of an isotropic shell)"),
        (ORTHOTROPIC, "shell.nu=0.1:0.4", "(E and nu of an isotropic shell)"),
        (MAGNET, f"{KEY}=50:150", "expected one of shell.thickness"),
    ],
    ids=["orthotropic-E", "orthotropic-nu", "magnetization"],
)
def test_refused_by_the_command_line(tmp_path, text, field, message):
    """``rftfem optimize --vary-field`` refuses the modulus and Poisson's ratio of an
    orthotropic shell, and a magnetization (the command varies the shell's fields):
    exit status 2, one line on stderr naming the key, no evaluation run.  Broke: the
    orthotropic test of parse_vary_field dropped → the search started, and
    check_field_keys refused its first evaluation (exit 2, its own message)."""
    scene = write_scene(tmp_path, text)
    out = tmp_path / "out"
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "rftfem",
            "optimize",
            str(scene),
            "--vary-field",
            field,
            "--objective",
            "tip_uz@end",
            "--out",
            str(out),
        ],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=600,
    )
    lines = done.stderr.strip().splitlines()
    print(lines)
    assert done.returncode == 2, done.stderr[-2000:]
    assert len(lines) == 1 and f"--vary-field '{field}'" in lines[0] and message in lines[0]
    assert not list(out.glob("eval-*"))


def test_two_parts_of_numbers_are_taken(tmp_path):
    """With the other part magnetized by a number too (along Y, on X ≤ 5), the cellwise
    gradient by part 0's magnetization is taken: zero on the other part's cells,
    not on its own, and its sum over the cells is the derivative by the part's
    magnetization as a scalar key (a uniform change of m on the part; another
    code path: sensitivity's directional derivative), within 5e-15 (reached 4.4e-16
    and 2.2e-16 on the two stacks).  Broke: the cellwise gradient taken on every
    magnetized cell (_magnetization_gradient's part_cells left out) → the other
    part's cells 4.9e-5 to 2.5e-4."""
    import rftfem

    scene = write_scene(tmp_path, TWO_PARTS.format(other="50.0"))
    got = rftfem.gradient(scene, "tip_ux@end", keys=[KEY], fields=[KEY], out=tmp_path / "out")
    table = got.fields[KEY]
    cells = table[f"d/d{KEY}"].to_numpy()
    own = table["x"].to_numpy() > 5.0
    total = cells.sum()
    print(
        f"cells: {cells}; sum {total:.12e}, scalar key {got.keys[KEY]:.12e}, "
        f"{abs(total / got.keys[KEY] - 1):.2e}"
    )
    assert own.sum() == 4 and (~own).sum() == 4
    assert np.all(cells[~own] == 0.0) and np.all(cells[own] != 0.0)
    assert abs(total / got.keys[KEY] - 1) < 5e-15
