"""How the fragments of the LDMs of aalund2015's Figure 8 (atrium 260k, 512 maps of 200²) divide between
the splat's small triangles and its long ones (longer than ``splat_max`` texels in the maps), estimated
from the triangles' projected areas (numpy, on the CPU; docs/reference/methods/fast_builds.md, "The long triangles").

    python scripts/fragment_shares.py [--maps N] [--sample K] [--splat-max T]

--sample: maps drawn at random (seed 0) to average over (default 32).
"""
from __future__ import annotations

import argparse

import numpy as np

from ldbench.core.scenes import load_scene
from ldbench.methods.directions import ldm_axes
from ldbench.methods.structures import bounding_sphere, ortho_layers


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--maps", type=int, default=512)
    ap.add_argument("--resolution", type=int, default=200)
    ap.add_argument("--sample", type=int, default=32)
    ap.add_argument("--splat-max", type=float, default=16.0)
    a = ap.parse_args()
    scene = load_scene("atrium:triangles=260000")
    v, f, _, _ = scene.merged()
    c, r = bounding_sphere(scene)
    clip, _, _ = ortho_layers(ldm_axes(a.maps), c, r)
    res = a.resolution
    tri = v[f].astype(np.float64)
    edge = np.linalg.norm(tri - np.roll(tri, 1, axis=1), axis=2).max(1)
    long_ = edge * res / (2 * r) > a.splat_max  # texels per world unit: the map spans the sphere's diameter
    ks = np.random.default_rng(0).choice(a.maps, min(a.sample, a.maps), replace=False)
    small = large = 0.0
    for k in ks:
        w = (tri @ clip[k, :2, :3].T + clip[k, :2, 3]) * (res / 2) + res / 2
        area = np.abs((w[:, 1, 0] - w[:, 0, 0]) * (w[:, 2, 1] - w[:, 0, 1])
                      - (w[:, 1, 1] - w[:, 0, 1]) * (w[:, 2, 0] - w[:, 0, 0])) / 2
        small += area[~long_].sum()
        large += area[long_].sum()
    n = len(ks)
    total = (small + large) / n * a.maps
    print(f"{len(f)} triangles, {int(long_.sum())} longer than {a.splat_max:g} texels; fragments of "
          f"{a.maps} maps of {res}² ~ {total / 1e6:.2f} M: small triangles {small / (small + large):.1%}, "
          f"long {large / (small + large):.1%} (projected areas over {n} maps)")


if __name__ == "__main__":
    main()
