"""The keys of ``[shell]`` and ``[[shell.parts]]`` that set the material, and their
checks across keys (docs/scenes.md, "[shell]" and "Material fields").

Isotropic (the default): ``E`` and ``nu``.  Orthotropic: ``E1``, ``E2``, ``G12``,
``nu12`` in the frame of the ``fibre`` (a direction in the surface), with the
transverse shear moduli ``G13`` (in the plane of fibre and normal) and ``G23``
(across it), both ``G12`` unless given: a fibre composite or a stretched
elastomer sheet whose transverse shear is not measured.  Every modulus, the
thickness and the density may vary over the body (rftfem/scene/fields.py).
"""

from __future__ import annotations

from rftfem.errors import SceneError
from rftfem.scene.fields import REFERENCE, MaterialField, is_field
from rftfem.scene.schema import NONNEGATIVE, POSITIVE, Formulas, Leaf, Num, Str, fmt

__all__ = ["SHELL_MATERIAL", "PART_MATERIAL", "PART_KEYS", "material_keys", "check_material"]

_INHERITED = "inherited from [shell]"
_POISSON = Num(-1.0, 0.5, lo_open=True, hi_open=True)
#: the orthotropic moduli
ORTHOTROPIC = ("E1", "E2", "G12", "nu12", "G13", "G23")
#: the keys a part may set (inherited from [shell] when left out)
PART_KEYS = ("E", "nu", "thickness", "density") + ORTHOTROPIC
_FIELD = " A number, a formula of X, Y, Z or a profile file (docs/scenes.md)."

_DOCS = {
    "thickness": (MaterialField(POSITIVE), 0.1, "length", "Shell thickness."),
    "E": (
        MaterialField(POSITIVE),
        1.2e6,
        "force/length²",
        'Young\'s modulus (material = "isotropic").',
    ),
    "nu": (MaterialField(_POISSON), 0.0, "", 'Poisson\'s ratio (material = "isotropic").'),
    "density": (
        MaterialField(NONNEGATIVE),
        0.0,
        "mass/length³",
        "Mass per volume, with mass in force·time²/length (t/mm³ for N, mm, s). "
        "Above 0 (here or in a part) the body has inertia and the automatic scheme "
        "is generalized-alpha.",
    ),
    "E1": (
        MaterialField(POSITIVE),
        None,
        "force/length²",
        'Young\'s modulus along the fibre (material = "orthotropic").',
    ),
    "E2": (
        MaterialField(POSITIVE),
        None,
        "force/length²",
        "Young's modulus across the fibre, in the surface.",
    ),
    "G12": (MaterialField(POSITIVE), None, "force/length²", "In-plane shear modulus."),
    "nu12": (
        MaterialField(Num(-1.0, None, lo_open=True)),
        None,
        "",
        "Major Poisson's ratio (contraction across the fibre under a pull along it); ν12² < E1/E2.",
    ),
    "G13": (
        MaterialField(POSITIVE),
        None,
        "force/length²",
        "Transverse shear modulus in the plane of the fibre and the normal.",
    ),
    "G23": (
        MaterialField(POSITIVE),
        None,
        "force/length²",
        "Transverse shear modulus in the plane across the fibre and the normal.",
    ),
}
_DEFAULT_DOC = {
    "E1": 'required with material = "orthotropic"',
    "E2": 'required with material = "orthotropic"',
    "G12": 'required with material = "orthotropic"',
    "nu12": 'required with material = "orthotropic"',
    "G13": "G12",
    "G23": "G12",
}

SHELL_MATERIAL = {
    "material": Leaf(
        Str(("isotropic", "orthotropic")),
        "isotropic",
        doc='"isotropic" (E, nu) or "orthotropic" (E1, E2, G12, nu12 along '
        "`fibre`; G13, G23). The plane-stress law of either, rotated into "
        "the surface at every point (docs/model.md §3).",
    ),
    **{
        key: Leaf(check, default, unit=unit, doc=doc + _FIELD, default_doc=_DEFAULT_DOC.get(key))
        for key, (check, default, unit, doc) in _DOCS.items()
    },
    "fibre": Leaf(
        Formulas(REFERENCE, nonzero=True),
        None,
        default_doc="shell.axis",
        doc="The fibre direction of an orthotropic shell in reference coordinates, "
        "each entry a number or a formula of X, Y, Z; projected on the surface "
        "and normalised at every point (it may not be along the normal).",
    ),
}

PART_MATERIAL = {
    key: Leaf(
        _DOCS[key][0],
        unit=_DOCS[key][2],
        default_doc=_INHERITED,
        doc=f"{_DOCS[key][3].split('(')[0].strip()} on the region."
        if key in ("E", "nu")
        else f"{_DOCS[key][3]} On the region.",
    )
    for key in PART_KEYS
}


def material_keys(shell: dict) -> tuple[str, ...]:
    """The scene keys that make the material of this shell (the moduli its law uses,
    then thickness and density)."""
    if shell.get("material", "isotropic") == "orthotropic":
        return ORTHOTROPIC + ("thickness", "density")
    return ("E", "nu", "thickness", "density")


def check_material(shell: dict) -> None:
    """The material keys across each other (in place: G13, G23 default to G12, the
    fibre to shell.axis, parts inherit what they leave out)."""
    orthotropic = shell["material"] == "orthotropic"
    for key in ORTHOTROPIC:
        given = [f"shell.{key}"] if shell[key] is not None else []
        given += [
            f"shell.parts.{i}.{key}" for i, p in enumerate(shell["parts"]) if p.get(key) is not None
        ]
        if given and not orthotropic:
            raise SceneError(
                f"{given[0]}: an orthotropic modulus; it needs shell.material = "
                f'"orthotropic" (found "{shell["material"]}")'
            )
    if shell["fibre"] is not None and not orthotropic:
        raise SceneError(
            "shell.fibre: the fibre of an orthotropic shell; it needs "
            f'shell.material = "orthotropic" (found "{shell["material"]}")'
        )
    if orthotropic:
        for key in ("E1", "E2", "G12", "nu12"):
            if shell[key] is None:
                raise SceneError(
                    f"missing required key 'shell.{key}' (shell.material = "
                    '"orthotropic" needs E1, E2, G12 and nu12)'
                )
        for key in ("G13", "G23"):
            if shell[key] is None:
                shell[key] = shell["G12"]
        if shell["fibre"] is None:
            shell["fibre"] = list(shell["axis"])
    for part in shell["parts"]:
        for key in PART_KEYS:
            if part.get(key) is None:
                part[key] = shell[key]
    if orthotropic:
        for where, table in [("shell", shell)] + [
            (f"shell.parts.{i}", p) for i, p in enumerate(shell["parts"])
        ]:
            check_poisson(*(table[k] for k in ("E1", "E2", "nu12")), f"{where}.nu12")


def check_poisson(
    E1: float | str | dict[str, str],
    E2: float | str | dict[str, str],
    nu12: float | str | dict[str, str],
    key: str,
) -> None:
    """ν12 ν21 < 1 (ν21 = ν12 E2/E1): the plane-stress stiffness is positive definite;
    numbers only (fields are checked at the nodes, rftfem/model/materials.py)."""
    if any(is_field(v) for v in (E1, E2, nu12)):
        return
    if nu12 * nu12 * E2 >= E1:
        raise SceneError(
            f"{key}: expected ν12² < E1/E2 = {fmt(E1 / E2)} (a positive "
            f"definite stiffness), found ν12 = {fmt(nu12)}"
        )
