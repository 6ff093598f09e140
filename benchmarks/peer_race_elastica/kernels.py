"""numba kernels of the PyElastica side of the peer race (benchmarks/peer_race_elastica/run.py):
resistive-force drag lumped at the rod's nodes, and the couple of a uniform field
on magnetized elements.  Imported by .venv-elastica's python only."""

import math

if __name__ == "__main__":  # a module, not a script: --help says so, nothing else runs
    import argparse

    argparse.ArgumentParser(
        description="numba kernels of the peer race's PyElastica side; imported by run.py, not run"
    ).parse_args()
    raise SystemExit(0)

from numba import njit  # noqa: E402


@njit(cache=True)
def rft_drag(vel, dirs, lengths, c1, c2, c3, ext):
    n = dirs.shape[2]
    for i in range(n + 1):
        a = i - 1 if i > 0 else 0
        b = i if i < n else n - 1
        li = 0.0
        if i > 0:
            li += 0.5 * lengths[i - 1]
        if i < n:
            li += 0.5 * lengths[i]
        for k in range(3):
            c = c3 if k == 0 else (c2 if k == 1 else c1)
            dx = 0.5 * (dirs[k, 0, a] + dirs[k, 0, b])
            dy = 0.5 * (dirs[k, 1, a] + dirs[k, 1, b])
            dz = 0.5 * (dirs[k, 2, a] + dirs[k, 2, b])
            nrm = math.sqrt(dx * dx + dy * dy + dz * dz)
            dx /= nrm
            dy /= nrm
            dz /= nrm
            s = c * li * (dx * vel[0, i] + dy * vel[1, i] + dz * vel[2, i])
            ext[0, i] -= s * dx
            ext[1, i] -= s * dy
            ext[2, i] -= s * dz


@njit(cache=True)
def magnetic_couple(dirs, moments, bx, by, bz, ext_torque):
    # the moment m d3 (along the material axis) in the lab; tau = m x B, then Q tau
    for e in range(moments.shape[0]):
        m = moments[e]
        if m == 0.0:
            continue
        mx, my, mz = m * dirs[2, 0, e], m * dirs[2, 1, e], m * dirs[2, 2, e]
        tx = my * bz - mz * by
        ty = mz * bx - mx * bz
        tz = mx * by - my * bx
        for k in range(3):
            ext_torque[k, e] += dirs[k, 0, e] * tx + dirs[k, 1, e] * ty + dirs[k, 2, e] * tz
