"""``alpha-blend`` (ldbench/methods/alpha_blend): plain over blending in submission order on llvmpipe. It equals a
numpy fold of each pixel's fragments in mesh order (the order the rasterizer keeps per pixel); it equals
the exact composite when the meshes are submitted back to front, and the exact reference exposes it when
they are not; coverage is every pixel a fragment reached."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from ldbench.core.scene import Scene
from ldbench.methods.base import registry
from ldbench.references.oit import composite_hits, intersections, render_oit
from test_oit import H, W, run, stack_scene

EXACT = 1e-5


def submission_model(scene):
    """Each pixel's fragments composited with the last-submitted mesh in front (over blending in order)."""
    hits = intersections(scene, W, H)
    return composite_hits(scene, dataclasses.replace(hits, depth=-hits.mesh.astype(np.float64))), hits


def test_registered():
    cls = registry()["alpha-blend"]
    assert cls.effects == frozenset({"oit"}) and cls.paper == "yang2010" and cls.Params().to_dict() == {}


def test_equals_the_submission_order_fold_and_the_reference_exposes_it(gpu):
    sc = stack_scene()
    model, hits = submission_model(sc)
    ref = render_oit(sc, W, H)
    r = run(gpu, sc, "alpha-blend")
    assert np.array_equal(r.mask, ref.mask) and r.mask.sum() > 100
    assert float(np.abs(np.asarray(r.image) - model).max()) < EXACT
    wrong = np.abs(np.asarray(r.image) - ref.mean).max(axis=2)
    assert wrong.max() > 0.05 and (wrong > 0.01).sum() > 50  # the shuffled order is visible
    assert (hits.counts() >= 2).sum() > 100


def test_back_to_front_submission_is_exact(gpu):
    sc = stack_scene()
    eye = np.array(sc.camera.origin)
    far_first = sorted(sc.meshes, key=lambda m: -float(np.linalg.norm(m.vertices.mean(0) - eye)))
    sorted_sc = Scene("stack-sorted", far_first, sc.camera)
    r = run(gpu, sorted_sc, "alpha-blend")
    ref = render_oit(sorted_sc, W, H)
    assert float(np.abs(np.asarray(r.image) - ref.mean).max()) < EXACT
    assert np.array_equal(r.mask, ref.mask)


@pytest.mark.parametrize("frames", [2])
def test_frames_start_from_the_background(gpu, frames):
    """Two frames of one instance are equal (the targets are cleared every frame)."""
    from ldbench.core.effects import Effect
    from ldbench.methods.base import View, get_method

    sc = stack_scene()
    cls = get_method("alpha-blend")
    m = cls(cls.Params())
    m.setup(gpu, sc)
    try:
        imgs = [np.asarray(m.frame(View(sc.camera, W, H), Effect("oit")).resolve().image) for _ in range(frames)]
    finally:
        m.release()
    assert np.array_equal(imgs[0], imgs[1])
