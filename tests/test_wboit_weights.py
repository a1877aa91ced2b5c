"""wboit's weight functions (McGuire & Bavoil 2013, eq. 7, 8, 9, 10 and the constant weight; the
``weight`` parameter) against an independent numpy model of weighted blended OIT, on a stack of quads where
the weights decide the colour.

The scene: 13 quads facing a camera at the origin (looking down −z), at view depths 0.5 … 320 (spread over
every regime of the four equations: both clamps, the 1e-5 terms, eq. 10's window depth from near to the
1e-2 floor), each covering a rectangle of pixels whose edges lie on pixel boundaries (half a pixel from
every pixel centre), with distinct colours and opacities. So each pixel's fragments are known exactly:
the quads whose rectangle holds it, at exactly their depth (planes facing the camera: the view depth is
constant over a quad, and the window depth is f (z − n) / ((f − n) z), GL's depth range [0, 1] with the
method's clip planes n, f). The model applies the paper's formulas to those fragments and resolves
C = Σ c α w / clamp(Σ α w, 1e-4, 5e4) · (1 − Π(1 − α)) + Π(1 − α) · background.
"""
from __future__ import annotations

import numpy as np
import pytest

from ldbench.core.effects import Effect
from ldbench.core.effects.oit import BACKGROUND
from ldbench.core.scene import Camera, Mesh, Scene
from ldbench.methods.base import View, get_method

W, H = 40, 32
FOV = 40.0
DEPTHS = (0.5, 0.9, 1.6, 3.0, 5.0, 8.0, 13.0, 22.0, 40.0, 70.0, 120.0, 200.0, 320.0)
WEIGHTS = ("eq7", "eq8", "eq9", "eq10", "constant")

# Tolerance, from float32 arithmetic (not llvmpipe's output). GLSL's pow is exp2(y log2 x): log2 within 3 ulp
# (2^-21 absolute near 1), exp2 within (3 + 2|x|) ulp; with exponents ≤ 6 of arguments within 2^±9 that is a
# relative weight error ≤ 3e-5. eq. 10's window depth d carries a few ulp of 1 (≤ 2.4e-7) through the clip
# transform and interpolation, i.e. ≤ 3 · 2.4e-7 / (1 − d) ≤ 5e-5 relative where the 1e-2 floor does not hold
# (1 − d ≥ 0.0149). A relative weight error ε moves a weighted average of colours in [0, 1] by ≤ 2ε, so
# ≤ 2e-4; the revealage (log/exp of ≤ 13 terms), the division and the blend's sum add ~1e-6. Bound 5e-4.
TOL = 5e-4


def camera():
    return Camera((0.0, 0.0, 0.0), (0.0, 0.0, -1.0), (0.0, 1.0, 0.0), FOV)


def weight_stack():
    """(scene, rectangles (x0, x1, y0, y1) in pixels, row 0 at the top): one quad per DEPTHS entry, listed
    in shuffled depth order."""
    rng = np.random.default_rng(11)
    t = np.tan(np.radians(FOV) / 2)
    meshes, rects = [], []
    for i in rng.permutation(len(DEPTHS)):
        z = DEPTHS[i]
        x0 = int(rng.integers(0, W // 2))
        x1 = int(rng.integers(x0 + W // 4, W + 1))
        y0 = int(rng.integers(0, H // 2))
        y1 = int(rng.integers(y0 + H // 4, H + 1))
        X = lambda px: (px / W * 2 - 1) * t * (W / H) * z  # noqa: E731
        Y = lambda py: (1 - py / H * 2) * t * z  # noqa: E731
        v = np.array([[X(x0), Y(y1), -z], [X(x1), Y(y1), -z], [X(x1), Y(y0), -z], [X(x0), Y(y0), -z]], np.float32)
        meshes.append(Mesh(f"q{i}", v, np.array([[0, 1, 2], [0, 2, 3]]), tuple(rng.uniform(0.05, 0.95, 3)),
                           float(rng.uniform(0.2, 0.7))))
        rects.append((x0, x1, y0, y1))
    return Scene("weight-stack", meshes, camera()), rects


def paper_weight(name: str, z: np.ndarray, d: np.ndarray, a: np.ndarray) -> np.ndarray:
    """McGuire & Bavoil 2013, eq. 7 – 10 (z = |view depth|, d = window depth), or 1."""
    if name == "eq7":
        return a * np.clip(10.0 / (1e-5 + (z / 5.0) ** 2 + (z / 200.0) ** 6), 1e-2, 3e3)
    if name == "eq8":
        return a * np.clip(10.0 / (1e-5 + (z / 10.0) ** 3 + (z / 200.0) ** 6), 1e-2, 3e3)
    if name == "eq9":
        return a * np.clip(0.03 / (1e-5 + (z / 200.0) ** 4), 1e-2, 3e3)
    if name == "eq10":
        return a * np.maximum(1e-2, 3e3 * (1.0 - d) ** 3)
    assert name == "constant"
    return np.ones_like(a)


def wboit_model(scene, rects, near, far, weight: str):
    """(H×W×3 image, H×W fragment counts) of weighted blended OIT over the exactly known fragments."""
    acc, acc_a = np.zeros((H, W, 3)), np.zeros((H, W))
    log_t, count = np.zeros((H, W)), np.zeros((H, W), int)
    for mesh, (x0, x1, y0, y1) in zip(scene.meshes, rects):
        z = float(-mesh.vertices[0, 2])
        d = far * (z - near) / ((far - near) * z)
        a = float(mesh.opacity)
        w = float(paper_weight(weight, np.float64(z), np.float64(d), np.float64(a)))
        acc[y0:y1, x0:x1] += np.asarray(mesh.albedo) * a * w
        acc_a[y0:y1, x0:x1] += a * w
        log_t[y0:y1, x0:x1] += np.log1p(-a)
        count[y0:y1, x0:x1] += 1
    R = np.exp(log_t)[..., None]
    img = acc / np.clip(acc_a, 1e-4, 5e4)[..., None] * (1 - R) + R * np.asarray(BACKGROUND)
    img[count == 0] = BACKGROUND
    return img, count


def run_wboit(gpu, scene, weight, method_cls=None):
    """(result, near, far): one frame, and the clip planes the method's projection used."""
    cls = method_cls or get_method("wboit")
    m = cls(cls.Params(weight=weight))
    m.setup(gpu, scene)
    try:
        r = m.frame(View(scene.camera, W, H), Effect("oit")).resolve()
        _, _, fwd = scene.camera.basis()
        near, far = m.geo.near_far(np.array(scene.camera.origin), fwd)
    finally:
        m.release()
    return r, near, far


def check_weights(gpu, method_cls=None, weights=WEIGHTS):
    """Each weight's GPU image is the model's within TOL; returns the models and the fragment counts."""
    sc, rects = weight_stack()
    models = {}
    for weight in weights:
        r, near, far = run_wboit(gpu, sc, weight, method_cls)
        model, count = wboit_model(sc, rects, near, far, weight)
        models[weight] = model
        assert np.array_equal(r.mask, count > 0) and r.counters["fragments"] == count.sum()
        err = np.abs(np.asarray(r.image, np.float64) - model).max()
        assert err < TOL, f"{weight}: the GPU differs from the paper's formula by {err:.3g}"
    return models, count


def test_every_weight_matches_its_formula(gpu):
    """Each weight's image is the model's within TOL (measured ≤ 3.6e-7 on llvmpipe) — and the test is not
    vacuous: on this stack every two weights give images more than 0.05 apart (measured ≥ 0.117), and most
    pixels blend several fragments (64 % three or more, up to 11)."""
    models, count = check_weights(gpu)
    gaps = {(a, b): float(np.abs(models[a] - models[b]).max()) for i, a in enumerate(WEIGHTS) for b in WEIGHTS[i + 1:]}
    assert min(gaps.values()) > 0.05, gaps
    assert count.max() >= 8 and (count >= 3).mean() > 0.5, (count.max(), (count >= 3).mean())
