"""XDMF files as ParaView's and VTK's readers read them."""

from __future__ import annotations

import os


def repair_xdmf_namespace(path: str | os.PathLike[str]) -> None:
    """Give an XDMF file written by ``dolfinx.io.XDMFFile`` the XInclude namespace
    that XML parsers know.

    dolfinx 0.11 writes ``xmlns:xi="https://www.w3.org/2001/XInclude"``; the
    namespace is ``http://...`` and nothing else, so ParaView's and VTK's
    readers ignore every ``xi:include`` (the time steps lose their mesh and VTK
    crashes). dolfinx 0.5 writes it right. Detected by content: a right file is
    left alone. (``rftfem.outputs.render`` reads a file that was never repaired, e.g.
    of a killed run, through a repaired copy.)
    """
    from pathlib import Path

    path = Path(path)
    text = path.read_text(encoding="utf-8")
    bad = 'xmlns:xi="https://www.w3.org/2001/XInclude"'
    if bad in text:
        tmp = path.with_suffix(".xdmf.tmp")
        tmp.write_text(
            text.replace(bad, 'xmlns:xi="http://www.w3.org/2001/XInclude"'), encoding="utf-8"
        )
        tmp.replace(path)
