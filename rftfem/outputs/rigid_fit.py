"""The best-fit rigid motion of a deformed body (numpy only): what ``rftfem render
--scale`` keeps true while it magnifies a free body's deformation."""

from __future__ import annotations

import numpy as np


def magnified(
    X: np.ndarray, u: np.ndarray, scale: float
) -> tuple[np.ndarray, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Points ``X + u`` drawn with their deformation magnified ``scale`` times about
    the best-fit rigid motion (Kabsch: the rotation R and the centroids' shift that
    bring ``X`` closest to ``X + u`` in the least-squares sense): ``rigid + scale ×
    (x − rigid)``.  A rigid motion is drawn as it is, and the drawn centroid is the
    true one.  Returns ``(drawn points, (R, centroid of X, centroid of x))``."""
    x = X + u
    c_ref, c_now = X.mean(axis=0), x.mean(axis=0)
    H = (X - c_ref).T @ (x - c_now)
    U, _, Vt = np.linalg.svd(H)
    d = np.sign(np.linalg.det(Vt.T @ U.T)) or 1.0
    R = Vt.T @ np.diag([1.0, 1.0, d]) @ U.T
    rigid = (X - c_ref) @ R.T + c_now
    return rigid + scale * (x - rigid), (R, c_ref, c_now)
