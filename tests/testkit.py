"""Shared test kit: small scenes built from meshes (plane, disk, box, sphere, a Cornell-like box) and
closed forms (AO and obscurance of a plane point under a disk), used by the reference and method tests."""
import math
import os
from pathlib import Path

import numpy as np

from ldbench.core.scene import Camera, Mesh, Scene, SpotLight


def disk_occlusion(a, h=1.0, r=1.0, d_max=math.inf, falloff="step", nphi=4096):
    """(1/π)∫ρ(t) cosθ dω over the directions from a plane point (distance a from the disk axis) that
    hit the disk (= 1 − AO; with ``quadratic-second-moment``: 1 − E[V²]). Integrated over the disk in
    polar coordinates about the point's projection: the radial
    integral is closed-form (step: h²/2·[1/(h²+s²)]; quadratic adds −h²/(2d²)·ln(h²+s²)), the angular
    one a 4096-point midpoint rule."""
    a = np.asarray(a, np.float64).reshape(-1)
    phi = (np.arange(nphi) + 0.5) / nphi * 2 * np.pi
    c, s = np.cos(phi)[None], np.sin(phi)[None]
    out = np.empty_like(a)
    for i0 in range(0, len(a), 1024):
        A = a[i0:i0 + 1024, None]
        D = r * r - A * A * s * s
        sq = np.sqrt(np.maximum(D, 0))
        s2 = -A * c + sq
        s1 = np.maximum(0.0, -A * c - sq)
        if math.isfinite(d_max):
            s2 = np.minimum(s2, math.sqrt(max(d_max * d_max - h * h, 0.0)))
        ok = (D > 0) & (s2 > s1)
        h2 = h * h
        g = h2 / 2 * (1 / (h2 + s1 ** 2) - 1 / (h2 + s2 ** 2))
        if falloff == "quadratic":
            g = g - h2 / (2 * d_max ** 2) * np.log((h2 + s2 ** 2) / (h2 + s1 ** 2))
        elif falloff == "quadratic-second-moment":  # E[1 − V²] with V = t²/d_max² on hits
            g = g - h2 / (2 * d_max ** 4) * (s2 ** 2 - s1 ** 2)
        out[i0:i0 + 1024] = np.where(ok, g, 0.0).sum(1) * (2 * np.pi / nphi) / np.pi
    return out


def quad(p0, p1, p2, p3, name, albedo=(0.8, 0.8, 0.8)):
    return Mesh(name, np.array([p0, p1, p2, p3], np.float32), np.array([[0, 1, 2], [0, 2, 3]], np.int32),
                albedo)


def plane(size=40.0, y=0.0, albedo=(0.8, 0.8, 0.8), name="plane"):
    s = size / 2
    return quad((-s, y, -s), (-s, y, s), (s, y, s), (s, y, -s), name, albedo)


def disk(r=1.0, h=1.0, seg=128, name="disk"):
    a = np.arange(seg) * 2 * np.pi / seg
    v = np.concatenate([[[0, h, 0]], np.stack([r * np.cos(a), np.full(seg, h), r * np.sin(a)], -1)])
    f = np.array([[0, 1 + (i + 1) % seg, 1 + i] for i in range(seg)], np.int32)
    return Mesh(name, v.astype(np.float32), f, (0.5, 0.5, 0.5))


def box(lo, hi, name, albedo=(0.75, 0.75, 0.75)):
    v = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])], np.float32)
    f = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1], [2, 3, 7], [2, 7, 6],
                  [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]], np.int32)
    return Mesh(name, v, f, albedo)


def sphere(c, r, n, name, albedo=(0.75, 0.75, 0.75)):
    th, ph = np.linspace(0, np.pi, n + 1), np.linspace(0, 2 * np.pi, 2 * n + 1)
    T, P = np.meshgrid(th, ph, indexing="ij")
    v = np.stack([np.sin(T) * np.cos(P), np.cos(T), np.sin(T) * np.sin(P)], -1).reshape(-1, 3) * r + np.array(c)
    w, f = 2 * n + 1, []
    for i in range(n):
        for j in range(2 * n):
            a = i * w + j
            f += [[a, a + w, a + 1], [a + 1, a + w, a + w + 1]]
    return Mesh(name, v.astype(np.float32), np.array(f, np.int32), albedo)


H_DISK, R_DISK = 1.0, 1.0  # the disk of the analytic AO tests: height and radius


def cornell_like(light=True):
    """Open-front 2×2×2 box with a block and a 16-ring sphere (~1k triangles)."""
    ms = [quad((-1, 0, -1), (-1, 0, 1), (1, 0, 1), (1, 0, -1), "floor"),
          quad((-1, 2, -1), (1, 2, -1), (1, 2, 1), (-1, 2, 1), "ceiling"),
          quad((-1, 0, -1), (1, 0, -1), (1, 2, -1), (-1, 2, -1), "back"),
          quad((-1, 0, -1), (-1, 2, -1), (-1, 2, 1), (-1, 0, 1), "left", (0.63, 0.06, 0.04)),
          quad((1, 0, -1), (1, 0, 1), (1, 2, 1), (1, 2, -1), "right", (0.14, 0.45, 0.09)),
          box((-0.7, 0, -0.6), (-0.1, 1.2, 0.0), "block"),
          sphere((0.45, 0.35, 0.3), 0.35, 15, "ball")]
    cam = Camera(origin=(0, 1, 3.9), target=(0, 1, 0), up=(0, 1, 0), fov_y=39.3)
    lights = [SpotLight(position=(0, 1.95, 0), target=(0, 0, 0), intensity=(5, 5, 5), cutoff_angle=60)] if light else []
    return Scene("cornell_like", ms, cam, lights)


def disk_ao_formula(a, h=1.0, r=1.0):
    """Classic AO (d_max = ∞) under a coaxial parallel disk: 1 − ½[1 − (h²+a²−r²)/√((h²+a²+r²)² − 4a²r²)]."""
    a = np.asarray(a, np.float64)
    return 1 - 0.5 * (1 - (h * h + a * a - r * r) / np.sqrt((h * h + a * a + r * r) ** 2 - 4 * a * a * r * r))


# ---- layered structures: overlapping quads rasterized into two 16² layers (test_linked_list, test_layered)
LAYER_W = LAYER_H = 16


def _quad4(corners, name):
    return Mesh(name, np.array(corners, np.float32), np.array([[0, 1, 2], [0, 2, 3]], np.int32))


def _flat(z, x0, x1, y0, y1, name):
    return _quad4([[x0, y0, z], [x1, y0, z], [x1, y1, z], [x0, y1, z]], name)


# Overlapping quads in [-1, 1]² (edges off the texel centres of a 16² map): three parallel to the
# map, one tilted (depth varies across it), one quad listed twice at the same depth (a tie).
LAYER_MESHES = [
    _flat(0.30, -0.97, 0.97, -0.97, 0.97, "big"),
    _flat(-0.50, -0.53, 0.91, -0.21, 0.81, "a"),
    _flat(0.70, -0.91, 0.13, -0.89, 0.33, "b"),
    _quad4([[-0.33, -0.71, -0.40], [0.61, -0.71, 0.20], [0.61, 0.23, 0.20], [-0.33, 0.23, -0.40]], "tilted"),
    _flat(-0.10, -0.27, 0.58, -0.66, 0.19, "c"),
    _flat(-0.10, 0.05, 0.44, 0.02, 0.52, "tie"),
]


def quads_scene():
    return Scene("quads", LAYER_MESHES, Camera((0, 0, 5), (0, 0, 0)))


def layer_transforms():
    """Layer 0: orthographic along z, depth = z. Layer 1: the same raster mirrored in x, depth = -2z + 1."""
    c0 = np.eye(4)
    c0[2, 2] = 0.5
    c1 = c0.copy()
    c1[0, 0] = -1.0
    rows = np.array([[0, 0, 1, 0], [0, 0, -2, 1]], float)
    return np.stack([c0, c1]), rows


def _inside(p, tri):
    a, b, c = tri
    def s(p, q, r):
        return (p[0] - r[0]) * (q[1] - r[1]) - (q[0] - r[0]) * (p[1] - r[1])
    d1, d2, d3 = s(p, a, b), s(p, b, c), s(p, c, a)
    return not ((min(d1, d2, d3) < 0) and (max(d1, d2, d3) > 0))


def expected_lists(with_material: bool = False, snap_bits: int | None = None):
    """Per layer and texel, the sorted depths of every triangle covering the texel centre (CPU);
    ``with_material``: sorted (depth, material id) pairs (the id is the mesh index, as Scene.merged).
    ``snap_bits``: depths on the plane through the vertices snapped to that many sub-pixel bits, as a GPU
    whose fill rule has ``snapped_plane`` interpolates (ldbench/methods/structures/splat.py); else through the given ones."""
    clip, rows = layer_transforms()
    size = np.array([LAYER_W, LAYER_H], np.float64)
    out = np.empty((2, LAYER_H, LAYER_W), object)
    for k in range(2):
        for y in range(LAYER_H):
            for x in range(LAYER_W):
                px = ((x + 0.5) / LAYER_W * 2 - 1, (y + 0.5) / LAYER_H * 2 - 1)
                ds = []
                for mid, m in enumerate(LAYER_MESHES):  # planar quads: covered = inside either triangle, once
                    for f in m.faces:
                        v = m.vertices[f].astype(np.float64)
                        ndc = (clip[k][:2, :3] @ v.T).T
                        if _inside(px, ndc):
                            # depth at the texel centre: barycentric interpolation in the raster plane (window)
                            w = (ndc + 1.0) * 0.5 * size
                            if snap_bits is not None:
                                w = np.round(w * 2.0 ** snap_bits) / 2.0 ** snap_bits
                            T = np.array([[w[0, 0] - w[2, 0], w[1, 0] - w[2, 0]],
                                          [w[0, 1] - w[2, 1], w[1, 1] - w[2, 1]]])
                            l0, l1 = np.linalg.solve(T, np.array([x + 0.5, y + 0.5]) - w[2])
                            p = l0 * v[0] + l1 * v[1] + (1 - l0 - l1) * v[2]
                            z = rows[k][:3] @ p + rows[k][3]
                            ds.append((z, mid) if with_material else z)
                            break
                out[k, y, x] = sorted(ds)
    return out


def read_only_parent(tmp_path):
    """A folder in which nothing can be created: a 0o555 folder, or for root (who ignores permission bits)
    a path under /sys, which refuses even root; skips the test where there is neither."""
    import pytest

    if os.geteuid() == 0:
        if not Path("/sys").is_dir():
            pytest.skip("running as root without /sys: no read-only folder to try")
        return Path("/sys/ldbench-no-such-dir")
    parent = tmp_path / "ro"
    parent.mkdir()
    parent.chmod(0o555)
    return parent


def wall_floor_scene() -> Scene:
    """A 4 m grey floor and a red 4 × 2.5 m wall along its left edge, a spot light aimed at the wall."""
    floor = quad((-2, 0, -2), (-2, 0, 2), (2, 0, 2), (2, 0, -2), "floor", (0.8, 0.8, 0.8))
    wall = quad((-2, 0, -2), (-2, 2.5, -2), (-2, 2.5, 2), (-2, 0, 2), "wall", (0.8, 0.25, 0.1))
    light = SpotLight(position=(0.5, 1.6, 0.0), target=(-2.0, 1.0, 0.0), intensity=(20, 20, 20), cutoff_angle=40)
    cam = Camera(origin=(2.6, 2.2, 3.2), target=(-0.8, 0.5, 0.0), up=(0, 1, 0), fov_y=55.0)
    return Scene("wall_floor", [floor, wall], cam, [light])
