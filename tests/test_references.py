"""Tests of the Mitsuba 3 references (references/): analytic AO, spot light, indirect, cache, speed.

Everything runs on the CPU (llvm_ad_rgb) in well under a minute on 2 cores.
"""
from __future__ import annotations

import json
import math
import time

import numpy as np
import pytest

from testkit import H_DISK, R_DISK, box, cornell_like, disk, disk_ao_formula, plane, quad
from testkit import disk_occlusion as _disk_occlusion
from ldbench.core.effects import Effect
from ldbench.core.errors import LdbenchError
from ldbench.core.scene import Camera, Scene, SpotLight

references = pytest.importorskip("ldbench.references")
from ldbench.references import (choose_variant, primary_hits, read_exr, read_image, render_reference,
                                write_exr, write_image)
from ldbench.references import variant as ref_variant  # noqa: E402

try:
    VARIANT = choose_variant()
except LdbenchError as e:  # pragma: no cover - machine without a usable Mitsuba backend
    pytest.skip(f"no Mitsuba variant: {e}", allow_module_level=True)


# ---------------------------------------------------------------------------------------------------
# scene builders


def plane_disk_scene():
    """Plane y=0 (40×40) under a two-sided disk (r=1, 128 segments) at height 1; camera straight down."""
    cam = Camera(origin=(0, 8, 0), target=(0, 0, 0), up=(0, 0, -1), fov_y=2 * math.degrees(math.atan(0.4)))
    return Scene("plane_disk", [plane(), disk(R_DISK, H_DISK)], cam, [])


# ---------------------------------------------------------------------------------------------------
# analytic AO of a plane point under a disk


def disk_occlusion(a, h=H_DISK, r=R_DISK, **kw):
    return _disk_occlusion(a, h=h, r=r, **kw)


def test_disk_quadrature_matches_closed_form():
    a = np.linspace(0, 4, 41)
    assert np.allclose(1 - disk_occlusion(a), disk_ao_formula(a), atol=2e-5)


@pytest.fixture(scope="module")
def disk_scene():
    s = plane_disk_scene()
    W = H = 128
    hits = primary_hits(s, W, H)
    P = hits["position"]
    on_plane = hits["mask"] & (np.abs(P[..., 1]) < 1e-4)
    assert on_plane.sum() > 10000
    a = np.hypot(P[..., 0], P[..., 2])
    return s, W, H, on_plane, a


def _ao_z_stats(ref, on_plane, a, spp):
    """z-scores of the reference against the analytic AO, with the exact Bernoulli variance."""
    ao = disk_ao_formula(a)
    p_occ = 1 - ao
    sel = on_plane & (spp * np.minimum(p_occ, ao) >= 10)  # enough hits for a Gaussian z
    se = np.sqrt(ao * (1 - ao) / spp)
    z = ((ref.mean[..., 0] - ao) / se)[sel]
    mae = np.abs(ref.mean[..., 0] - ao)[on_plane].mean()
    var_ratio = ref.variance[..., 0][sel].mean() / (se[sel] ** 2).mean()
    return z, mae, var_ratio


def _ao_z_ok(z, mae, var_ratio):
    return (abs(z.mean()) < 0.1 and 0.9 < z.std() < 1.1 and np.mean(np.abs(z) > 4.5) < 1e-3
            and mae < 0.008 and 0.9 < var_ratio < 1.1)


def test_ao_analytic_disk(disk_scene):
    s, W, H, on_plane, a = disk_scene
    spp = 1024
    ref = render_reference(s, Effect("ao"), width=W, height=H, spp=spp, cache=False, progress=False)
    assert ref.mean.shape == (H, W, 1) and ref.variance.shape == (H, W, 1) and ref.mask.shape == (H, W)
    assert ref.mean.dtype == np.float32 and ref.mask.all()
    assert ref.meta["variant"] == VARIANT and ref.meta["cached"] is False and ref.meta["spp"] == spp
    z, mae, var_ratio = _ao_z_stats(ref, on_plane, a, spp)
    assert len(z) > 5000
    assert abs(z.mean()) < 0.1, z.mean()
    assert 0.9 < z.std() < 1.1, z.std()
    assert np.mean(np.abs(z) > 4.5) < 1e-3
    assert mae < 0.008
    assert 0.9 < var_ratio < 1.1, var_ratio  # the reference's own variance estimate is right
    # The disk top seen from above: unoccluded (the plane is below it, nothing above).
    top = ~on_plane & ref.mask
    assert np.allclose(ref.mean[..., 0][top], 1.0)


def test_ao_check_rejects_uniform_hemisphere(disk_scene, monkeypatch):
    """The analytic check has the power to catch a wrong (uniform) direction distribution."""
    import mitsuba as mi

    mi.set_variant(VARIANT)
    monkeypatch.setattr(mi.warp, "square_to_cosine_hemisphere", mi.warp.square_to_uniform_hemisphere)
    s, W, H, on_plane, a = disk_scene
    ref = render_reference(s, Effect("ao"), width=W, height=H, spp=1024, cache=False, progress=False)
    assert not _ao_z_ok(*_ao_z_stats(ref, on_plane, a, 1024))


def test_ao_finite_dmax_step_and_quadratic(disk_scene):
    s, W, H, on_plane, a = disk_scene
    spp, d_max = 512, 2.0
    kw = dict(width=W, height=H, spp=spp, cache=False, progress=False)
    inf = render_reference(s, Effect("ao"), **kw).mean[..., 0]
    step = render_reference(s, Effect("ao", d_max=d_max, falloff="step"), **kw)
    quad_ = render_reference(s, Effect("ao", d_max=d_max, falloff="quadratic"), **kw)
    # Same seed → same directions: per-pixel orderings hold sample by sample.
    assert np.all(quad_.mean[..., 0] >= step.mean[..., 0] - 1e-6)
    assert np.all(step.mean[..., 0] >= inf - 1e-6)
    assert (quad_.mean[..., 0] - step.mean[..., 0])[on_plane].max() > 0.1
    for ref, fo in ((step, "step"), (quad_, "quadratic")):
        grid = np.linspace(a[on_plane].min(), a[on_plane].max(), 801)  # smooth in a: interpolate
        exact = 1 - np.interp(a[on_plane], grid, disk_occlusion(grid, d_max=d_max, falloff=fo))
        m2 = exact if fo == "step" else 1 - np.interp(
            a[on_plane], grid, disk_occlusion(grid, d_max=d_max, falloff="quadratic-second-moment"))
        var_exact = (m2 - exact ** 2) / spp
        sel = (1 - exact) * spp > 10
        z = (ref.mean[..., 0][on_plane] - exact)[sel] / np.sqrt(var_exact[sel])
        ratio = ref.variance[..., 0][on_plane][sel].mean() / var_exact[sel].mean()
        assert sel.sum() > 1000, fo
        assert 0.9 < ratio < 1.1, (fo, ratio)
        assert abs(z.mean()) < 0.1, (fo, z.mean())
        assert 0.85 < z.std() < 1.15, (fo, z.std())
        assert np.mean(np.abs(z) > 5) < 2e-3, fo
    # Beyond d_max (horizontal distance > r + sqrt(d_max²−h²)) nothing is within reach.
    far = on_plane & (a > R_DISK + math.sqrt(d_max ** 2 - H_DISK ** 2) + 0.05)
    assert far.sum() > 100
    assert np.all(step.mean[..., 0][far] == 1.0) and np.all(quad_.mean[..., 0][far] == 1.0)


# ---------------------------------------------------------------------------------------------------
# spot light


@pytest.mark.parametrize("cutoff,beam", [(20.0, None), (40.0, 25.0), (60.0, 0.0), (30.0, 30.0)])
def test_spot_falloff_matches_mitsuba(cutoff, beam):
    import drjit as dr
    import mitsuba as mi

    from ldbench.references.integrators import build_scene

    light = SpotLight(position=(0.2, 3.0, -0.1), target=(0.5, 0.0, 0.4), intensity=(2.0, 3.0, 5.0),
                      cutoff_angle=cutoff, beam_width=beam, up=(0.3, 1.0, 0.0))
    s = Scene("spot", [plane()], Camera((0, 5, 5), (0, 0, 0)), [light])
    mi.set_variant(VARIANT)
    em = build_scene(s).emitters()[0]
    axis = light.direction()
    perp = np.cross(axis, [0.0, 0.0, 1.0])
    perp /= np.linalg.norm(perp)
    theta = np.radians(np.concatenate([np.linspace(0.0, cutoff + 5.0, 97), [light.beam_width + 0.5]]))
    theta = theta[np.abs(np.degrees(theta) - cutoff) > 1e-3]
    for rot in (0.0, 1.3, 2.9):  # a few azimuths about the axis (the fall-off is symmetric)
        q = perp * math.cos(rot) + np.cross(axis, perp) * math.sin(rot)
        dirs = np.cos(theta)[:, None] * axis + np.sin(theta)[:, None] * q
        dist = 1.7
        pts = np.array(light.position) + dist * dirs
        it = dr.zeros(mi.Interaction3f, len(pts))
        it.p = mi.Point3f(*[mi.Float(pts[:, i].astype(np.float32)) for i in range(3)])
        ds, spec = em.sample_direction(it, mi.Point2f(0.5, 0.5))
        got = np.stack([np.asarray(spec[i]) for i in range(3)], -1) * dist ** 2
        want = np.array(light.intensity) * light.falloff(np.cos(theta))[:, None]
        np.testing.assert_allclose(got, want, rtol=2e-4, atol=2e-4 * max(light.intensity))


def _plane_direct_closed_form(scene, light, W, H, albedo):
    o, d = scene.camera.primary_rays(W, H)
    t = -o[:, 1] / d[:, 1]
    x = o + t[:, None] * d
    v = np.array(light.position) - x
    dist = np.linalg.norm(v, axis=1)
    cos_s = v[:, 1] / dist  # plane normal facing the camera (camera above): +y
    cos_l = (-v / dist[:, None]) @ light.direction()
    fall = light.falloff(cos_l)
    L = (np.array(albedo) / np.pi)[None] * np.array(light.intensity)[None] * (fall * np.maximum(cos_s, 0) / dist ** 2)[:, None]
    return L.reshape(H, W, 3), fall.reshape(H, W)


@pytest.mark.parametrize("light", [
    SpotLight(position=(0.7, 3.0, -0.4), target=(-0.5, 0.0, 0.6), intensity=(10.0, 20.0, 5.0),
              cutoff_angle=35.0, beam_width=20.0),
    SpotLight(position=(0.0, 2.5, 0.0), target=(0.0, 0.0, 0.0), intensity=(7.0, 7.0, 7.0),
              cutoff_angle=40.0),  # axis parallel to the default up vector
    SpotLight(position=(0.3, 1.5, 0.2), target=(0.3, 0.0, 0.2), intensity=(3.0, 2.0, 1.0),
              cutoff_angle=180.0),  # point light
], ids=["tilted-spot", "vertical-spot", "point"])
def test_direct_plane_matches_closed_form(light):
    albedo = (0.7, 0.5, 0.3)
    cam = Camera(origin=(0.0, 5.0, 4.0), target=(0.0, 0.0, 0.0), up=(0, 1, 0), fov_y=50.0)
    s = Scene("plane_spot", [plane(albedo=albedo)], cam, [light])
    W, H = 96, 80
    ref = render_reference(s, Effect("direct"), width=W, height=H, spp=64, cache=False, progress=False)
    assert ref.mean.shape == (H, W, 3) and ref.mask.all()
    assert np.all(ref.variance == 0) and ref.meta["spp"] == 1 and ref.meta["spp_requested"] == 64
    want, fall = _plane_direct_closed_form(s, light, W, H, albedo)
    lit = fall > 0.02
    assert lit.sum() > 200
    rel = np.abs(ref.mean - want)[lit] / want[lit]
    assert rel.max() < 1e-3, rel.max()
    assert np.all(ref.mean[fall == 0] == 0)


def test_direct_two_sided_and_shadow():
    albedo = (0.6, 0.6, 0.6)
    cam = Camera(origin=(0.0, 5.0, 4.0), target=(0.0, 0.0, 0.0), up=(0, 1, 0), fov_y=50.0)
    below = SpotLight(position=(0.0, -2.0, 0.0), target=(0.0, 0.0, 0.0), cutoff_angle=60.0)
    s = Scene("below", [plane(albedo=albedo)], cam, [below])
    ref = render_reference(s, Effect("direct"), width=48, height=40, cache=False, progress=False)
    assert np.all(ref.mean == 0)  # the light shines on the side the camera does not see
    # An occluder between a spot and the plane casts a hard shadow at the axis.
    above = SpotLight(position=(0.0, 3.0, 0.0), target=(0.0, 0.0, 0.0), cutoff_angle=60.0)
    blocker = quad((-0.3, 1.5, -0.3), (-0.3, 1.5, 0.3), (0.3, 1.5, 0.3), (0.3, 1.5, -0.3), "blocker")
    cam2 = Camera(origin=(0.0, 8.0, 0.0), target=(0.0, 0.0, 0.0), up=(0, 0, -1), fov_y=40.0)
    s2 = Scene("shadow", [plane(albedo=albedo), blocker], cam2, [above])
    W = 64
    ref2 = render_reference(s2, Effect("direct"), width=W, height=W, cache=False, progress=False)
    hits = primary_hits(s2, W, W)
    P = hits["position"]
    on_plane = np.abs(P[..., 1]) < 1e-4
    r = np.hypot(P[..., 0], P[..., 2])
    # Points on the plane hidden by the blocker (as seen from the light at height 3, blocker at 1.5):
    # |x|, |z| < 0.6; the camera sees them around the blocker only in a thin ring, far from the axis.
    shadow = on_plane & (np.maximum(np.abs(P[..., 0]), np.abs(P[..., 2])) < 0.55)
    lit = on_plane & (np.maximum(np.abs(P[..., 0]), np.abs(P[..., 2])) > 0.65) & (r < 1.2)
    assert shadow.sum() > 0 and lit.sum() > 50
    assert np.all(ref2.mean[shadow] == 0)
    assert np.all(ref2.mean[lit] > 0)


# ---------------------------------------------------------------------------------------------------
# indirect


def closed_box_scene():
    ms = [quad((-1, 0, -1), (-1, 0, 1), (1, 0, 1), (1, 0, -1), "floor", (0.8, 0.8, 0.8)),
          quad((-1, 2, -1), (1, 2, -1), (1, 2, 1), (-1, 2, 1), "ceiling", (0.7, 0.7, 0.7)),
          quad((-1, 0, -1), (1, 0, -1), (1, 2, -1), (-1, 2, -1), "back", (0.6, 0.6, 0.9)),
          quad((-1, 0, 1), (-1, 2, 1), (1, 2, 1), (1, 0, 1), "front", (0.5, 0.5, 0.5)),
          quad((-1, 0, -1), (-1, 2, -1), (-1, 2, 1), (-1, 0, 1), "left", (0.8, 0.1, 0.1)),
          quad((1, 0, -1), (1, 0, 1), (1, 2, 1), (1, 2, -1), "right", (0.1, 0.7, 0.1))]
    # Camera inside the box looking down: only the (smooth) floor is visible, no silhouettes, so
    # pixel-centre sampling and Mitsuba's pixel-area sampling agree on image and quadrant means.
    cam = Camera(origin=(0, 1.8, 0), target=(0, 0, 0), up=(0, 0, -1), fov_y=50)
    light = SpotLight(position=(0.5, 1.9, 0.5), target=(-0.6, 0.8, -0.6), intensity=(4, 4, 4),
                      cutoff_angle=50, beam_width=30)
    return Scene("closed_box", ms, cam, [light])


def test_indirect_matches_mitsuba_path_tracer():
    """Our one-bounce estimator vs Mitsuba's own ``path`` (max_depth 3 minus max_depth 2)."""
    import mitsuba as mi

    from ldbench.references.integrators import build_scene

    s = closed_box_scene()
    W = H = 32
    spp = 1024
    ref = render_reference(s, Effect("indirect"), width=W, height=H, spp=spp, cache=False, progress=False)
    assert ref.mask.all() and np.all(ref.mean > 0) and np.all(ref.variance > 0)
    mi.set_variant(VARIANT)
    cam = s.camera

    def path(depth, seed):
        sensor = mi.load_dict({
            "type": "perspective", "fov": cam.fov_y, "fov_axis": "y",
            "to_world": mi.ScalarTransform4f().look_at(origin=list(cam.origin), target=list(cam.target),
                                                      up=list(cam.up)),
            "film": {"type": "hdrfilm", "width": W, "height": H, "rfilter": {"type": "box"},
                     "pixel_format": "rgb"},
            "sampler": {"type": "independent", "sample_count": spp}})
        integ = mi.load_dict({"type": "path", "max_depth": depth})
        return np.asarray(mi.render(build_scene(s), sensor=sensor, integrator=integ, seed=seed, spp=spp))

    runs = np.stack([path(3, k) - path(2, 100 + k) for k in range(4)])  # 4 × H × W × 3

    def regions(img):  # whole image and the four quadrants, per channel
        h, w = H // 2, W // 2
        parts = [img, img[..., :h, :w, :], img[..., :h, w:, :], img[..., h:, :w, :], img[..., h:, w:, :]]
        return np.stack([p.mean(axis=(-3, -2)) for p in parts], -2)

    ours = regions(ref.mean)
    ours_se = np.sqrt(np.stack([v.sum(axis=(0, 1)) / v.shape[0] ** 2 / v.shape[1] ** 2 for v in (
        ref.variance, ref.variance[:H // 2, :W // 2], ref.variance[:H // 2, W // 2:],
        ref.variance[H // 2:, :W // 2], ref.variance[H // 2:, W // 2:])]))
    r = regions(runs)
    theirs, theirs_se = r.mean(0), r.std(0, ddof=1) / math.sqrt(len(r))
    z = (ours - theirs) / np.sqrt(ours_se ** 2 + theirs_se ** 2)
    assert np.all(np.abs(z) < 4.5), z
    assert np.all(np.abs(ours / theirs - 1) < 0.02), ours / theirs


def test_indirect_background_zero_and_ao_background_one():
    cam = Camera(origin=(0, 1, 6), target=(0, 1, 0), fov_y=60)  # sees past the box: background pixels
    s = Scene("open", [box((-0.5, 0, -0.5), (0.5, 1, 0.5), "b"), plane(size=4)], cam,
              [SpotLight(position=(1, 3, 1), target=(0, 0, 0), cutoff_angle=45)])
    ind = render_reference(s, Effect("indirect"), width=40, height=30, spp=16, cache=False, progress=False)
    ao = render_reference(s, Effect("ao"), width=40, height=30, spp=16, cache=False, progress=False)
    assert (~ind.mask).sum() > 50 and ind.mask.sum() > 50
    assert np.array_equal(ind.mask, ao.mask)
    assert np.all(ind.mean[~ind.mask] == 0) and np.all(ind.variance[~ind.mask] == 0)
    assert np.all(ao.mean[~ao.mask] == 1) and np.all(ao.variance[~ao.mask] == 0)
    assert ind.mean[ind.mask].max() > 0


# ---------------------------------------------------------------------------------------------------
# determinism, cache, errors, timing


def test_deterministic_and_batch_independent():
    s = cornell_like()
    kw = dict(width=24, height=20, spp=64, cache=False, progress=False)
    a = render_reference(s, Effect("ao"), **kw)
    b = render_reference(s, Effect("ao"), batch_rays=1000, **kw)  # many small wavefronts
    c = render_reference(s, Effect("ao"), seed=1, **kw)
    assert np.array_equal(a.mean, b.mean) and np.allclose(a.variance, b.variance, rtol=1e-5, atol=1e-12)
    assert not np.array_equal(a.mean, c.mean)
    i1 = render_reference(s, Effect("indirect"), **kw)
    i2 = render_reference(s, Effect("indirect"), batch_rays=777, **kw)
    np.testing.assert_allclose(i1.mean, i2.mean, rtol=1e-5, atol=1e-7)


def test_cache(tmp_path, monkeypatch):
    s = cornell_like()
    kw = dict(width=20, height=16, cache_dir=tmp_path, progress=False)
    r1 = render_reference(s, Effect("ao"), spp=8, **kw)
    r2 = render_reference(s, Effect("ao"), spp=8, **kw)
    assert r1.meta["cached"] is False and r2.meta["cached"] is True
    assert r1.meta["key"] == r2.meta["key"]
    assert np.array_equal(r1.mean, r2.mean) and np.array_equal(r1.variance, r2.variance)
    assert np.array_equal(r1.mask, r2.mask) and r2.mask.dtype == bool
    assert r2.meta["variant"] == r1.meta["variant"] and r2.meta["spp"] == 8
    key = r1.meta["key"]
    assert (tmp_path / f"{key}.exr").is_file() and (tmp_path / f"{key}.json").is_file()
    doc = json.loads((tmp_path / f"{key}.json").read_text())
    assert doc["fields"]["spp"] == 8 and doc["fields"]["effect"]["effect"] == "ao"
    assert not list(tmp_path.glob("*.tmp*"))  # atomic writes leave no temporaries

    keys = {key}
    for eff, spp, seed in ((Effect("ao"), 16, 0), (Effect("ao", d_max=0.5), 8, 0),
                           (Effect("ao", d_max=0.5, falloff="quadratic"), 8, 0), (Effect("ao"), 8, 3),
                           (Effect("indirect"), 8, 0), (Effect("direct"), 8, 0)):
        r = render_reference(s, eff, spp=spp, seed=seed, **kw)
        assert r.meta["cached"] is False
        keys.add(r.meta["key"])
    assert len(keys) == 7
    # direct is exact: its key does not depend on spp
    assert render_reference(s, Effect("direct"), spp=99, **kw).meta["cached"] is True
    # cache=False neither reads nor writes
    r3 = render_reference(s, Effect("ao"), spp=8, width=20, height=16, cache=False, cache_dir=tmp_path,
                          progress=False)
    assert r3.meta["cached"] is False and np.array_equal(r3.mean, r1.mean)
    # a damaged entry is a miss, then rewritten
    (tmp_path / f"{key}.json").write_text("{not json")
    r4 = render_reference(s, Effect("ao"), spp=8, **kw)
    assert r4.meta["cached"] is False
    assert render_reference(s, Effect("ao"), spp=8, **kw).meta["cached"] is True
    # LDBENCH_CACHE is the default folder
    monkeypatch.setenv("LDBENCH_CACHE", str(tmp_path / "envcache"))
    r5 = render_reference(s, Effect("ao"), spp=8, width=20, height=16, progress=False)
    assert (tmp_path / "envcache" / f"{r5.meta['key']}.exr").is_file()
    # the scene is part of the key
    s2 = cornell_like(light=False)
    assert render_reference(s2, Effect("ao"), spp=8, **kw).meta["key"] != key
    # an unusable cache folder is a warning, not a lost render
    blocker = tmp_path / "not-a-folder"
    blocker.write_text("x")
    with pytest.warns(RuntimeWarning, match="not cached"):
        r6 = render_reference(s, Effect("ao"), spp=8, width=20, height=16, cache_dir=blocker / "sub",
                              progress=False)
    assert np.array_equal(r6.mean, r1.mean)


def test_errors():
    s = cornell_like(light=False)
    kw = dict(width=8, height=8, spp=4, cache=False, progress=False)
    with pytest.raises(LdbenchError, match="does not render effect rays"):  # rays: ldbench.references.rays
        render_reference(s, Effect("rays"), **kw)
    with pytest.raises(LdbenchError, match="unknown effect 'caustics'"):
        Effect("caustics")
    with pytest.raises(LdbenchError, match="no spot or point light"):
        render_reference(s, Effect("direct"), **kw)
    with pytest.raises(LdbenchError, match="spp"):
        render_reference(s, Effect("ao"), width=8, height=8, spp=0, cache=False)
    with pytest.raises(LdbenchError, match="width"):
        render_reference(s, Effect("ao"), width=-1, height=8, spp=4, cache=False)


def test_variant_helpers(monkeypatch):
    assert VARIANT in ("cuda_ad_rgb", "llvm_ad_rgb")
    v = ref_variant.llvm_version_of
    assert v("/usr/lib/x86_64-linux-gnu/libLLVM-19.so") == 19
    assert v("/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1") == 19
    assert v("/usr/lib/llvm-17/lib/libLLVM.so") == 17
    assert v("/usr/lib/x86_64-linux-gnu/libLLVM-14.0.6.so.1") == 14
    monkeypatch.setenv("DRJIT_LIBLLVM_PATH", "/nonexistent/libLLVM-19.so")
    with pytest.raises(LdbenchError, match="does not exist"):
        ref_variant.setup_llvm_env()
    monkeypatch.setenv("LDBENCH_MITSUBA_VARIANT", "scalar_rgb")
    monkeypatch.setattr(ref_variant, "_chosen", None)
    with pytest.raises(LdbenchError, match="LDBENCH_MITSUBA_VARIANT"):
        ref_variant.choose_variant()


def test_exr_roundtrip(tmp_path):
    rng = np.random.default_rng(0)
    ch = {"Y": rng.random((5, 7), dtype=np.float32), "mask": (rng.random((5, 7)) > 0.5).astype(np.float32)}
    p = write_exr(tmp_path / "a.exr", ch)
    back = read_exr(p)
    assert set(back) == set(ch) and all(np.array_equal(back[k], ch[k]) for k in ch)
    img = rng.random((6, 4, 3), dtype=np.float32)
    write_image(tmp_path / "b.exr", img)
    assert np.array_equal(read_image(tmp_path / "b.exr"), img)
    with pytest.raises(LdbenchError):
        write_exr(tmp_path / "c.exr", {"Y": np.zeros((2, 2)), "Z": np.zeros((3, 2))})
    with pytest.raises(LdbenchError):
        read_exr(tmp_path / "missing.exr")


def test_ao_timing_1k_triangles():
    s = cornell_like()
    assert 800 <= s.triangle_count <= 1500
    t0 = time.perf_counter()
    ref = render_reference(s, Effect("ao"), width=128, height=128, spp=256, cache=False, progress=False)
    dt = time.perf_counter() - t0
    assert ref.mask.mean() > 0.9
    assert dt < 10.0, f"128×128×256 AO took {dt:.1f} s"
