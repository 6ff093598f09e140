"""A run's fields.xdmf as VTK's reader can read it: the file itself, or a repaired copy."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from tempfile import TemporaryDirectory

_XINCLUDE = 'xmlns:xi="http://www.w3.org/2001/XInclude"'
_BAD_XINCLUDE = 'xmlns:xi="https://www.w3.org/2001/XInclude"'


def readable(xdmf: Path) -> tuple[Path, TemporaryDirectory | None]:
    """``xdmf``, or a repaired copy of it in a temporary folder (returned with it: the
    copy lasts as long as the folder object).

    rftfem repairs its field file when a run closes it; a run that stopped
    before that (killed outright) or an older rftfem's file can need:

    - the XInclude namespace: some dolfinx versions write it ``https://...``;
      XML parsers know only ``http://www.w3.org/2001/XInclude``, leave every
      time step without its mesh, and VTK's reader then crashes;
    - ``Precision="8"`` on the real arrays, without which VTK reads the
      doubles as float32.

    The copy's data paths point at the original HDF5 files.
    """
    import re

    text = xdmf.read_text(encoding="utf-8", errors="replace")
    undeclared = re.compile(
        r'<DataItem(?![^>]*Precision=)(?![^>]*NumberType="(?:U?Int|Char))'
        r'([^>]*Format="HDF"[^>]*)>'
    )
    if _BAD_XINCLUDE not in text and not undeclared.search(text):
        return xdmf, None
    import tempfile

    tmp = tempfile.TemporaryDirectory(prefix="rftfem-render-")
    text = text.replace(_BAD_XINCLUDE, _XINCLUDE)
    text = undeclared.sub(r'<DataItem\1 Precision="8">', text)
    folder = str(xdmf.parent.resolve())
    text = re.sub(r">\s*(fields(?:-\d+)?\.h5):", lambda m: f">{folder}/{m.group(1)}:", text)
    copy = Path(tmp.name) / "fields.xdmf"
    copy.write_text(text, encoding="utf-8")
    return copy, tmp
