"""``alpha-blend`` (ldbench/methods/alpha_blend): plain over blending in submission order on llvmpipe. It equals a
numpy fold of each pixel's fragments in mesh order (the order the rasterizer keeps per pixel); it equals
the exact composite when the meshes are submitted back to front, and the exact reference exposes it when
they are not; coverage is every pixel a fragment reached. ``opaque_first``: an opaque surface submitted
last no longer covers the transparent ones in front of it, and fragments of one colour and opacity in any
order are exact; ``target = rgba8``: every value a multiple of 1/255, within one 8-bit step (RMS) of the
exact composite in depth order, the shuffled order far outside it."""
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
    assert cls.effects == frozenset({"oit"}) and cls.paper == "yang2010"
    assert cls.Params().to_dict() == {"opaque_first": False, "target": "rgba32f"}


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


def one_colour_stack(opaque_z):
    """stack_scene's quads with one colour and opacity (any order composites alike) and an opaque quad at
    depth ``opaque_z`` over the whole image, submitted last (after every transparent quad)."""
    sc = stack_scene()
    t = np.tan(np.radians(35.0) / 2) * (5.0 - opaque_z) * 1.5
    quads = [dataclasses.replace(m, albedo=(0.2, 0.5, 0.9), opacity=0.35) for m in sc.meshes]
    opaque = dataclasses.replace(sc.meshes[0], name="opaque", albedo=(0.7, 0.3, 0.2), opacity=1.0,
                                 vertices=np.array([[-t, -t, opaque_z], [t, -t, opaque_z], [t, t, opaque_z],
                                                    [-t, t, opaque_z]], np.float32))
    return Scene("stack-one-colour", quads + [opaque], sc.camera)


@pytest.mark.parametrize("opaque_z", [-3.0, 0.05])  # behind every quad; between them (hides those behind it)
def test_opaque_first_blends_over_the_opaque_surfaces(gpu, opaque_z):
    sc = one_colour_stack(opaque_z)
    ref = render_oit(sc, W, H)
    one_pass = run(gpu, sc, "alpha-blend")
    first = run(gpu, sc, "alpha-blend", opaque_first=True)
    assert float(np.abs(np.asarray(first.image) - ref.mean).max()) < EXACT
    assert np.array_equal(first.mask, ref.mask) and first.mask.all()
    wrong = np.abs(np.asarray(one_pass.image) - ref.mean).max(axis=2)
    assert wrong.max() > 0.05 and (wrong > 0.01).sum() > 50  # submitted last, the opaque quad covers the rest


def _psnr(img, ref):
    from ldbench.core.metrics import psnr

    return psnr(np.asarray(img), ref.mean, mask=ref.mask)


def test_rgba8_rounds_every_blend_within_one_step(gpu):
    """Back to front: the 8-bit composite is within one 8-bit step RMS of the exact one (PSNR ≥ 20 log10 255,
    yang2010-costs' rule for a correct image), the float one exact; shuffled: far below the rule."""
    sc = stack_scene()
    eye = np.array(sc.camera.origin)
    sorted_sc = Scene("stack-sorted", sorted(sc.meshes, key=lambda m: -float(np.linalg.norm(m.vertices.mean(0) - eye))),
                      sc.camera)
    ref = render_oit(sorted_sc, W, H)
    r8 = run(gpu, sorted_sc, "alpha-blend", target="rgba8")
    img = np.asarray(r8.image)
    assert np.abs(img * 255 - np.round(img * 255)).max() < 1e-4  # every value on the 8-bit grid
    err = np.abs(img - ref.mean)
    assert 0 < err.max() <= 3 / 255 and np.sqrt((err ** 2).mean()) <= 1 / 255
    assert _psnr(img, ref) >= 20 * np.log10(255)
    assert np.array_equal(r8.mask, ref.mask)
    assert float(np.abs(np.asarray(run(gpu, sorted_sc, "alpha-blend").image) - ref.mean).max()) < EXACT
    shuffled = run(gpu, sc, "alpha-blend", target="rgba8")
    assert _psnr(shuffled.image, render_oit(sc, W, H)) < 40.0
    mem = shuffled.memory_bytes
    assert mem["oit.alpha.colour8"] == 4 * W * H and mem["oit.alpha.cover"] == W * H and "oit.output" not in mem
