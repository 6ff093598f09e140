"""gmsh meshes of the bodies of the contact tests: a hoop (a short cylinder closed
around its axis), second-order quadrilaterals."""

from __future__ import annotations

import math

import numpy as np


def write_hoop(path, radius: float, width: float, n_around: int, centre_z: float = 0.0):
    """The cylinder x² + (z − centre_z)² = radius², 0 ≤ y ≤ width, about an axis along Y:
    ``n_around`` 9-node quadrilaterals around it (a multiple of 4) and one across, the
    surface group "hoop". Its nodes include the top (0, width/2, centre_z + radius).

    The cells' normals (their node order) point to the axis, so the lower face (the
    mid-surface less half the thickness along the director) is the outer face: at the
    bottom it is the face that meets a floor below."""
    import gmsh

    if n_around % 4:
        raise ValueError(f"n_around = {n_around}: a multiple of 4 (four arcs)")
    gmsh.initialize(readConfigFiles=False)
    gmsh.option.setNumber("General.Terminal", 0)
    try:
        gmsh.model.add("hoop")
        geo = gmsh.model.geo
        centre = geo.addPoint(0, 0, centre_z)
        # the bottom, front, top and back of the circle in the plane y = 0
        corners = [
            geo.addPoint(radius * math.sin(a), 0, centre_z - radius * math.cos(a))
            for a in np.arange(4) * math.pi / 2
        ]
        arcs = [geo.addCircleArc(corners[i], centre, corners[(i + 1) % 4]) for i in range(4)]
        out = geo.extrude([(1, arc) for arc in arcs], 0, width, 0, numElements=[1], recombine=True)
        geo.synchronize()
        for arc in arcs:
            gmsh.model.mesh.setTransfiniteCurve(arc, n_around // 4 + 1)
        surfaces = [tag for dim, tag in out if dim == 2]
        gmsh.model.setPhysicalName(2, gmsh.model.addPhysicalGroup(2, surfaces), "hoop")
        gmsh.model.mesh.generate(2)
        gmsh.model.mesh.setOrder(2)
        # every cell's normal towards the axis (the lower face outside)
        tags, xyz, _ = gmsh.model.mesh.getNodes()
        where = dict(zip(tags.tolist(), xyz.reshape(-1, 3)))
        _, _, nodes = gmsh.model.mesh.getElements(2)
        for cell in np.asarray(nodes[0]).reshape(-1, 9):
            x = np.array([where[int(k)] for k in cell[:4]])
            normal = np.cross(x[1] - x[0], x[3] - x[0])
            radial = x.mean(axis=0) - np.array([0.0, x[:, 1].mean(), centre_z])
            if normal @ radial >= 0.0:
                raise RuntimeError("write_hoop: a cell's normal points away from the axis")
        gmsh.write(str(path))
    finally:
        gmsh.finalize()
    return path
