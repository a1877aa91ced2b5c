"""How many list nodes the LDM AO's walks read at aalund2015's Figure 8 settings (atrium 260k, 512 maps of 200²,
the Figure 8 camera), from the G-buffer and the maps' lists built on this machine's GL and read back (numpy;
docs/reference/methods/fast_builds.md, "What bounds them now"). The query is ``ldm_query`` of ldbench/methods/ldm/ldm_trace.glsl
(texel, receiver-plane threshold with the bias and crease window), and a walk's length counts every node it
loads, the one that ends it included.

    python scripts/walk_lengths.py [--size S]

Prints the mean nodes per query of the early-stop walk from the list's front (the adapter's), of the walk
from the back for the queries along -v, and of the shorter of the two ends per query.
"""
from __future__ import annotations

import argparse

import numpy as np

from ldbench.core.effects import Effect
from ldbench.core.gpu import Gpu
from ldbench.core.scenes import load_scene
from ldbench.methods.base import View
from ldbench.methods.ldm import Ldm, LdmParams


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--size", type=int, default=160, help="image side (the Figure 8 frame: 800)")
    a = ap.parse_args()
    gpu = Gpu()
    sc = load_scene("atrium:triangles=260000")
    p = LdmParams.from_dict({"directions": 512, "resolution": 200, "structure.layout": "linear"})
    m = Ldm(p)
    m.setup(gpu, sc)
    m.frame(View(sc.camera, a.size, a.size), Effect("ao", d_max=10.32, falloff="quadratic")).resolve()
    pos, nor, _ = m.gbuf.read()
    s = m.ls
    end = np.frombuffer(gpu.read(s.offsets, 4 * s.n_lists), np.uint32).astype(np.int64)
    begin = np.concatenate([[0], end[:-1]])
    depth = np.frombuffer(gpu.read(s.depth_buf), np.float32)[:end[-1]]
    u, w, v = (np.frombuffer(gpu.read(m.axes_buf), np.float32).reshape(-1, 3, 4)[:, i, :3].astype(np.float64)
               for i in range(3))
    hit = pos[..., 3] > 0.5
    x = pos[hit][:, :3].astype(np.float64)
    n = nor[hit][:, :3].astype(np.float64)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    size, radius = p.resolution, m.radius
    bias, crease = p.trace.bias * m.texel, p.trace.crease * m.texel
    total = {"front": 0, "back for -v": 0, "nearer end": 0}
    queries = 0
    for k in range(m.n_maps):
        r = x - m.centre
        f = (np.stack([r @ u[k], r @ w[k]], 1) / radius * 0.5 + 0.5) * size
        px = np.clip(np.floor(f).astype(int), 0, size - 1)
        delta = (px + 0.5 - f) * (2 * radius / size)
        zx, c = r @ v[k], n @ v[k]
        sigma = np.where(c > 0, 1.0, -1.0)
        s_self = -(delta[:, 0] * (n @ u[k]) + delta[:, 1] * (n @ w[k])) / np.maximum(sigma * c, 1e-8)
        thr = (np.maximum(s_self, -crease) + bias)[:, None]
        lst = (k * size + px[:, 1]) * size + px[:, 0]
        length = end[lst] - begin[lst]
        j = np.arange(length.max())[None, :]
        valid = j < length[:, None]
        d = depth[np.minimum(begin[lst][:, None] + j, len(depth) - 1)]
        tp, tn = d - zx[:, None], zx[:, None] - d

        def steps(mask):  # the nodes read: those passed, and the one that ends the walk
            return np.minimum((valid & mask).sum(1) + 1, length)
        front = np.where(sigma > 0, steps(tp <= thr), steps(tn > thr))
        back = np.where(sigma > 0, steps(tp > thr), steps(tn <= thr))
        used = np.abs(c) >= 1e-6
        total["front"] += front[used].sum()
        total["back for -v"] += np.where(sigma > 0, front, back)[used].sum()
        total["nearer end"] += np.minimum(front, back)[used].sum()
        queries += used.sum()
    m.release()
    print(f"{queries} queries ({a.size}² view, {int(hit.sum())} pixels on the scene); mean nodes per query:")
    for name, t in total.items():
        print(f"  {name}: {t / queries:.3f}")


if __name__ == "__main__":
    main()
