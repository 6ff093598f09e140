"""Several bodies (``[[body]]``): a watch on how close they come to each other.

The bodies do not touch each other: nothing keeps one out of another (docs/bodies.md).
After each accepted step this looks at the closest pair of nodes of two different
bodies and warns, once per pair, when it comes within ``reach``: the contact planes'
barrier reach if the scene has planes, else the thickest shell's thickness (two
mid-surfaces that close would touch).  Past that point the run goes on, but
the two bodies may pass through each other.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from rftfem.model.effects.base import Effect
from rftfem.model.ranks import gather_rows

if TYPE_CHECKING:
    from rftfem.model.shell_model import Model


class BodiesApart(Effect):
    name = "bodies apart"

    @classmethod
    def active(cls, scene: dict) -> bool:
        return (scene.get("mesh") or {}).get("kind") == "bodies"

    def __init__(self, model: Model):
        from rftfem.model.body_parts import body_parts
        from rftfem.model.effects.contact import REACH_OF_THICKNESS

        super().__init__(model)
        self.parts = body_parts(model)
        thickest = model.material_value("thickness", "max")
        planes = self.scene.get("contact") or []
        reaches = [p["distance"] or REACH_OF_THICKNESS * thickest for p in planes]
        #: how close two bodies may come before it is said
        self.reach = max(reaches) if reaches else thickest
        self.warned: set[tuple[int, int]] = set()

    def after_step(self, t: float) -> list[str]:
        from scipy.spatial import cKDTree

        m = self.model
        n = len(self.parts[0].nodes) if self.parts else 0
        x = m.Vu.tabulate_dof_coordinates()[:n] + m.u_n.x.array.reshape(-1, 3)[:n]
        nodes = [gather_rows(x[p.nodes], m.comm) for p in self.parts]
        lines = []
        for j in range(1, len(nodes)):
            for i in range(j):
                if (i, j) in self.warned or not len(nodes[i]) or not len(nodes[j]):
                    continue
                gap = float(cKDTree(nodes[i]).query(nodes[j], k=1)[0].min())
                if gap < self.reach:
                    self.warned.add((i, j))
                    lines.append(
                        f"bodies '{self.parts[i].name}' and '{self.parts[j].name}' came "
                        f"within {gap:.3g} of each other at t = {t:.6g} (closer than "
                        f"{self.reach:.3g}); bodies do not touch each other, so from here "
                        "they may pass through each other (docs/bodies.md)"
                    )
        return lines
