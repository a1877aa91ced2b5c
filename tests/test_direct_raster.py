"""direct-raster against a closed form (independent of Mitsuba): a floor under a spot light with a
square occluder. Camera rays are intersected with the floor analytically, so orientation, camera,
fall-off, albedo and shadows are all checked."""
import numpy as np
import pytest

from ldbench.core.effects import Effect
from ldbench.core.scene import Camera, Mesh, Scene, SpotLight
from ldbench.methods.base import View, get_method


def quad(name, y, half, albedo, flip=False):
    v = np.array([[-half, y, -half], [half, y, -half], [half, y, half], [-half, y, half]], float)
    f = np.array([[0, 2, 1], [0, 3, 2]]) if not flip else np.array([[0, 1, 2], [0, 2, 3]])
    return Mesh(name, v, f, albedo)


def scene(occluder_first=False):
    light = SpotLight((0, 3, 0), (0, 0, 0), (10, 8, 6), cutoff_angle=50, beam_width=30)
    cam = Camera((0.3, 7, 5), (0, 0, 0.2), (0, 1, 0), 50)
    # the occluder's winding faces down (away from the camera): two-sidedness is tested too
    meshes = [quad("floor", 0, 5, (0.6, 0.5, 0.4)), quad("occ", 1, 0.5, (0.9, 0.9, 0.9), True)]
    return Scene("plane", meshes[::-1] if occluder_first else meshes, cam, [light])


def closed_form(sc, w, h):
    o, d = sc.camera.primary_rays(w, h)
    light = sc.lights[0]
    t_floor = -o[:, 1] / d[:, 1]
    p = o + t_floor[:, None] * d
    t_occ = (1 - o[:, 1]) / d[:, 1]
    q = o + t_occ[:, None] * d
    hits_occ = (np.abs(q[:, 0]) < 0.5) & (np.abs(q[:, 2]) < 0.5)
    L = p - np.array(light.position)
    dist = np.linalg.norm(L, axis=1)
    cos_s = -L[:, 1] / dist
    fall = light.falloff((L / dist[:, None]) @ light.direction())
    shadow_pt = p * (2 / 3)  # where the segment light→p crosses y = 1
    lit = ~((np.abs(shadow_pt[:, 0]) < 0.5) & (np.abs(shadow_pt[:, 2]) < 0.5))
    rad = np.array([0.6, 0.5, 0.4]) / np.pi * np.array(light.intensity) * (fall * cos_s * lit / dist**2)[:, None]
    # pixels safe to compare: not on the occluder, not within 2 cm of a shadow edge / cone edge
    edge = np.minimum(np.abs(np.abs(shadow_pt[:, 0]) - 0.5), np.abs(np.abs(shadow_pt[:, 2]) - 0.5))
    on_floor = (np.abs(p[:, 0]) < 4.9) & (np.abs(p[:, 2]) < 4.9) & ~hits_occ
    safe = on_floor & (edge > 0.02)
    return rad.reshape(h, w, 3), safe.reshape(h, w), p.reshape(h, w, 3), on_floor.reshape(h, w)


@pytest.mark.parametrize("occluder_first", [False, True], ids=["floor-first", "occluder-first"])
def test_direct_raster_matches_closed_form(gpu, occluder_first):
    """Either draw order: the shadow atlas keeps the nearest surface by its depth test, not by the order."""
    sc = scene(occluder_first)
    w, h = 96, 80
    m = get_method("direct-raster")()
    m.setup(gpu, sc)
    gpu.begin_frame()
    r = m.frame(View(sc.camera, w, h), Effect("direct")).resolve()
    stages, _ = gpu.end_frame()
    assert set(stages) == {"gbuffer", "shadow", "shade"}
    pos = m.gbuf.read()[0]
    m.release()
    expect, safe, p, on_floor = closed_form(sc, w, h)
    assert safe.sum() > 0.5 * w * h
    # G-buffer positions equal the analytic camera-ray/floor hits: same camera, same orientation
    np.testing.assert_allclose(pos[on_floor][:, :3], p[on_floor], atol=2e-3)
    err = np.abs(r.image - expect)[safe]
    assert np.max(err) < 1e-3 * expect.max()
    # and the shadow is there: some safe floor pixels are dark, some lit
    assert (expect[safe][:, 0] == 0).sum() > 20 and (expect[safe][:, 0] > 0).sum() > 100
    assert r.memory_bytes["shadow.atlas"] == 6 * 1024 * 1024 * 4


def test_direct_raster_matches_mitsuba_on_cornell(gpu):
    """The calibration of direct-raster: cornell at 256², PSNR ≥ 30 dB and SSIM ≥ 0.95 against Mitsuba's
    `direct` (linear values, data range = reference maximum over unmasked pixels)."""
    from ldbench.core import metrics
    from ldbench.core.scenes import load_scene
    from ldbench.references import render_reference

    sc = load_scene("cornell")
    ref = render_reference(sc, Effect("direct"), width=256, height=256, spp=1, progress=False)
    m = get_method("direct-raster")()
    m.setup(gpu, sc)
    try:
        r = m.frame(View(sc.camera, 256, 256), Effect("direct")).resolve()
    finally:
        m.release()
    mask = ref.mask & r.mask
    assert (ref.mask == r.mask).mean() > 0.999  # same camera: same silhouette
    psnr = metrics.psnr(r.image, ref.mean, mask=mask)
    ssim = metrics.ssim(r.image, ref.mean, mask=mask)
    assert psnr >= 30 and ssim >= 0.95, (psnr, ssim)
    # a mirrored image (wrong orientation) would fail the same test
    assert metrics.psnr(r.image[:, ::-1], ref.mean, mask=mask) < 25
