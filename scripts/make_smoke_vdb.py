#!/usr/bin/python3
"""Writes data/volumes/smoke_plume.vdb: a small smoke plume as a simulation package would export it.

A fog volume named "density" (float, stored as half), Y up as in Houdini and Blender's VDB export,
0.05 world units a voxel, its base at y = 0, turned 20° about Y (a rotated container), plus a
"temperature" grid (hotter near the base) so that a scene can choose a grid by name. The density
is band-limited noise (a power-law spectrum, as turbulence has) inside a plume that widens and
sways with height and fades out at the top; voxels below 0.02 stay inactive (background 0).

Written by OpenVDB itself through its Python binding (Debian: python3-openvdb, python3-numpy);
deterministic (seed below). Run from the repository root: /usr/bin/python3 scripts/make_smoke_vdb.py
"""
import math
import sys

import numpy as np
import pyopenvdb as vdb

SEED = 20240521
NX, NY, NZ = 40, 64, 40      # x, y (up), z
VOXEL = 0.05
OUT = sys.argv[1] if len(sys.argv) > 1 else "data/volumes/smoke_plume.vdb"


def noise(shape, rng, slope=2.7):
    """Gaussian noise whose spectrum falls as |k|^-slope/2: smooth, multi-scale, in [0, 1]."""
    k = [np.fft.fftfreq(n) for n in shape]
    kx, ky, kz = np.meshgrid(*k, indexing="ij")
    kk = np.sqrt(kx**2 + ky**2 + kz**2)
    kk[0, 0, 0] = 1.0
    spectrum = (rng.standard_normal(shape) + 1j * rng.standard_normal(shape)) * kk ** (-slope / 2)
    spectrum[0, 0, 0] = 0
    field = np.real(np.fft.ifftn(spectrum))
    field -= field.min()
    return field / field.max()


def main():
    rng = np.random.default_rng(SEED)
    n = noise((NX, NY, NZ), rng)                      # indexed [x, y, z]
    x = (np.arange(NX) - (NX - 1) / 2)[:, None, None]
    y = np.arange(NY)[None, :, None] / (NY - 1)       # 0 at the base, 1 at the top
    z = (np.arange(NZ) - (NZ - 1) / 2)[None, None, :]
    sway_x = 4.0 * np.sin(2.4 * y + 0.5) * y
    sway_z = 3.0 * np.sin(3.1 * y + 1.7) * y
    radius = 3.0 + 13.0 * y**0.8                      # voxels: narrow base, wide top
    r = np.sqrt((x - sway_x) ** 2 + (z - sway_z) ** 2) / radius
    mask = np.clip(1.0 - r, 0.0, 1.0) ** 0.6 * np.clip((1.0 - y) * 2.5, 0.0, 1.0)
    density = np.clip(mask * (n - 0.3) * 2.8, 0.0, 1.0).astype(np.float32)
    density[density < 0.02] = 0.0
    temperature = (density > 0) * np.clip(1.0 - 1.4 * y, 0.0, 1.0).astype(np.float32) * 900.0 + 300.0

    transform = vdb.createLinearTransform(voxelSize=VOXEL)
    transform.rotate(math.radians(20.0), vdb.Axis.Y)
    # the base centre (index ((NX-1)/2, 0, (NZ-1)/2)) at the world origin
    origin = transform.indexToWorld(((NX - 1) / 2, 0, (NZ - 1) / 2))
    transform.translate((-origin[0], -origin[1], -origin[2]))

    grids = []
    for name, values, background in (("density", density, 0.0),
                                      ("temperature", temperature.astype(np.float32), 300.0)):
        grid = vdb.FloatGrid(background)
        grid.copyFromArray(values, ijk=(0, 0, 0), tolerance=0.0)
        grid.name = name
        grid.gridClass = vdb.GridClass.FOG_VOLUME
        grid.transform = transform
        grid.saveFloatAsHalf = True
        grid.prune(0.0)
        grids.append(grid)
    vdb.write(OUT, grids=grids, metadata={"creator": "sombra scripts/make_smoke_vdb.py", "seed": SEED})
    print(f"{OUT}: density {grids[0].activeVoxelCount()} active voxels, "
          f"range {density.min():.3f}..{density.max():.3f}")


if __name__ == "__main__":
    main()
