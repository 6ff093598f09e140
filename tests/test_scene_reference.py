"""docs/scenes.md against the code: the generated parts are current, the generator
refuses an undocumented key, and every key the shipped demos use is listed.

When a test here fails because the schema (rftfem/scene/reading.py) or a command's options
changed, regenerate the reference with ``python -m rftfem.reference``.
"""

from __future__ import annotations

import tomllib
from pathlib import Path

import pytest

from rftfem import reference as scene_reference
from rftfem.reference import UndocumentedKey
from rftfem.scene import reading as scene
from rftfem.scene.schema import Array, Free, Leaf, Num, Str, Table

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "scenes.md"
DEMOS = sorted((ROOT / "demos").glob("*.toml"))


def test_reference_is_the_repository_document():
    assert scene_reference.DOC_PATH == DOC


@pytest.mark.parametrize("part", scene_reference.PARTS)
def test_generated_part_is_current(part):
    """(a) The text between the markers is what the generator writes now."""
    text = DOC.read_text(encoding="utf-8")
    parts = {**scene_reference.extract(text), part: scene_reference.GENERATORS[part]()}
    stale = scene_reference.stale_parts(text, parts)
    assert not stale, (
        f"docs/scenes.md: the generated part '{part}' is out of date (rftfem/scene/reading.py or "
        f"the command-line options changed); regenerate it with\n"
        f"    python -m rftfem.reference\n"
        f"{scene_reference.diff(text, parts)}"
    )


def test_hand_written_sections_are_there():
    text = DOC.read_text(encoding="utf-8")
    for heading in ("## Scene keys", "## Command line", "## Outputs", "## Exit status"):
        assert f"\n{heading}\n" in text, heading
    for name in ("probes.csv", "steps.csv", "body.csv", "summary.json", "fields.xdmf"):
        assert name in text.split("## Outputs", 1)[1], name


# ------------------------------------------------------- (b) undocumented keys


def test_generator_refuses_a_leaf_without_doc():
    schema = Table(
        {
            "title": Leaf(Str(), required=True, doc="the name"),
            "speed": Leaf(Num(), 1.0),  # no doc
        },
        doc="top",
    )
    with pytest.raises(UndocumentedKey, match=r"'speed' has no doc"):
        scene_reference.scene_keys_markdown(schema)


def test_generator_refuses_undocumented_keys_at_any_depth():
    documented = {"a": Leaf(Num(), 1.0, doc="a number")}
    cases = {
        "[[parts]].size": Table(
            {"parts": Array(Table({"size": Leaf(Num(), 1.0)}), doc="parts")}, doc="top"
        ),
        "[[parts]]": Table({"parts": Array(Table(dict(documented)))}, doc="top"),
        "box": Table({"box": Table(dict(documented))}, doc="top"),
        "(the top level)": Table(dict(documented)),
    }
    for path, schema in cases.items():
        with pytest.raises(UndocumentedKey) as info:
            scene_reference.scene_keys_markdown(schema)
        assert f"'{path}'" in str(info.value)


def test_generator_refuses_an_optional_leaf_without_default_text():
    schema = Table({"file": Leaf(Str(), None, doc="a path")}, doc="top")
    with pytest.raises(UndocumentedKey, match="'file' has no default and no default_doc"):
        scene_reference.scene_keys_markdown(schema)
    schema.fields["file"].default_doc = 'none: only with kind = "gmsh"'
    assert "none: only with kind" in scene_reference.scene_keys_markdown(schema)


def test_a_key_added_to_the_validator_fails_the_reference(monkeypatch, tmp_path):
    """A key the validator accepts but the reference does not list: no doc -> the
    generator fails; with a doc but not regenerated -> the document is stale."""
    motion = scene.SCHEMA.fields["motion"].item.fields
    monkeypatch.setitem(motion, "phase", Leaf(Num(), 0.0))
    path = tmp_path / "scene.toml"
    path.write_text(
        'title = "t"\n[mesh]\n[shell]\n[time]\n[[motion]]\ncomponent = "uz"\nphase = 0.5\n'
    )
    assert scene.load_scene(path)["motion"][0]["phase"] == 0.5  # the validator takes it
    with pytest.raises(UndocumentedKey, match=r"'\[\[motion\]\]\.phase' has no doc"):
        scene_reference.scene_keys_markdown()

    monkeypatch.setitem(motion, "phase", Leaf(Num(), 0.0, unit="rad", doc="phase shift"))
    text = DOC.read_text(encoding="utf-8")
    keys = scene_reference.scene_keys_markdown()
    assert "`[[motion]].phase`" in keys
    assert scene_reference.stale_parts(
        text, {**scene_reference.extract(text), "scene keys": keys}
    ) == ["scene keys"]


def test_a_changed_default_makes_the_reference_stale(monkeypatch):
    time = scene.SCHEMA.fields["time"].fields
    monkeypatch.setattr(time["max_cuts"], "default", 9)
    text = DOC.read_text(encoding="utf-8")
    keys = scene_reference.scene_keys_markdown()
    assert scene_reference.stale_parts(
        text, {**scene_reference.extract(text), "scene keys": keys}
    ) == ["scene keys"]


def test_every_schema_key_is_in_the_document():
    keys = scene_reference.extract(DOC.read_text(encoding="utf-8"))["scene keys"]
    for path in scene_reference.documented_paths():
        assert f"`{path}`" in keys, path


@pytest.mark.parametrize(
    "path, default",
    [
        (p, n.default)
        for p, n in scene_reference.walk()
        if isinstance(n, Leaf) and not n.required and not n.default_doc
    ],
)
def test_listed_defaults_read_back_as_the_defaults(path, default):
    """The default the reference prints is valid TOML for the real default."""
    assert tomllib.loads(f"v = {scene_reference._toml(default)}")["v"] == default


# ------------------------------------------------------------ (c) demo scenes


def _used_keys(data: dict, display: str, free: set[str]):
    for key, value in data.items():
        path = f"{display}.{key}" if display else key
        if path in free:
            yield path + ".*"
        elif isinstance(value, dict):  # a table; in an array's entry named by its path
            yield path if display.startswith("[[") else f"[{path}]"
            yield from _used_keys(value, path, free)
        elif isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
            array = scene_reference._array_item(path)  # [[body.parts]] in [[body]]
            yield array
            for item in value:
                yield from _used_keys(item, array, free)
        else:
            yield path


@pytest.mark.parametrize("demo", DEMOS, ids=[p.name for p in DEMOS])
def test_every_key_of_a_demo_scene_is_in_the_reference(demo):
    free = {p for p, n in scene_reference.walk() if isinstance(n, Free) and not p.endswith(".*")}
    listed = set(scene_reference.documented_paths())
    keys = scene_reference.extract(DOC.read_text(encoding="utf-8"))["scene keys"]
    used = sorted(set(_used_keys(tomllib.loads(demo.read_text(encoding="utf-8")), "", free)))
    assert used
    missing = [k for k in used if k not in listed or f"`{k}`" not in keys]
    assert not missing, f"{demo.name} uses keys docs/scenes.md does not list: {missing}"


# ------------------------------------------------------------- the command


def test_check_and_rewrite(tmp_path, capsys):
    copy = tmp_path / "scenes.md"
    text = DOC.read_text(encoding="utf-8")
    body = scene_reference.extract(text)["scene keys"]
    copy.write_text(
        text.replace(body, body.replace("| `mesh.length` |", "| `mesh.len` |")), encoding="utf-8"
    )
    assert scene_reference.main(["--check", "--file", str(copy)]) == 1
    assert "python -m rftfem.reference" in capsys.readouterr().err
    assert scene_reference.main(["--file", str(copy)]) == 0
    assert scene_reference.main(["--check", "--file", str(copy)]) == 0
    fresh = copy.read_text(encoding="utf-8")
    assert scene_reference.extract(fresh) == scene_reference.generate()
    assert fresh.split("<!-- generated")[0] == text.split("<!-- generated")[0]
