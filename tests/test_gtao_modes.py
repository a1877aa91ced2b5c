"""gtao's quality against hbao on a closed form, its presets, and its speed modes on llvmpipe: the thin disk over
a plane (tests/testkit.py's closed form, the scene of tests/test_ldm.py) beside hbao, with the sample march
clamped to the image border (the march that dropped off-screen samples fails it); XeGTAO's quality presets;
the depth MIP pre-filter (``prefilter = "mip"``) against a numpy twin of its filter, its levels read by the
horizon search, its accuracy on the closed forms; 16-bit MIP levels (``depth_precision = "16"``) against
the 32-bit ones. Each check also runs against a broken shader and fails there."""
import math

import numpy as np
import pytest

from ldbench.core import metrics as M
from ldbench.core.effects import Effect
from ldbench.core.errors import LdbenchError
from ldbench.core.scene import Camera, Scene
from ldbench.methods.base import View
from ldbench.methods.gtao import GTAO, GTAOParams, QUALITY
from ldbench.methods.hbao import HBAO, HBAOParams
from test_gtao import FINE, broken_gtao, check_cut_off, check_floor_wall, render
from test_hbao import floor_wall_scene
from test_ldm import LOW, OVERHEAD, plane_disk_scene, plane_errors
from testkit import disk_ao_formula, plane

MIP = dict(prefilter="mip")


def disk_error(gpu, cls, params_cls, camera, size=96, **params):
    """Mean |AO − closed form| on the plane pixels within 3 of the disk's axis (d_max = ∞)."""
    m = cls(params_cls(**params))
    m.setup(gpu, plane_disk_scene(camera))
    r = m.frame(View(camera, size, size), Effect("ao")).resolve()
    pos = m.gbuf.read()[0]
    m.release()
    err, n = plane_errors(r.image, pos, disk_ao_formula)
    assert n > 1000
    return float(np.abs(err).mean())


def check_disk_beside_hbao(gpu, method_cls=GTAO):
    """A thin disk (r = 1) at height 1 over a plane, d_max = ∞, 96², defaults of both methods. Seen from
    overhead (the plane around the disk): gtao's mean error 0.0123, hbao's 0.0235 (its 2008 integral, a uniform
    measure about the view vector, reads 0.023 too dark on average); bound: gtao below 0.015 and below hbao.
    Before the march was clamped to the image border, samples past it were dropped: with d_max = ∞ (radius
    256 px on a 96² image) the last of a side's three samples always, the second often; gtao read 0.0250.
    Seen from low (tests/test_ldm.py's LOW: the plane under the disk, between disk and plane): gtao 0.0775,
    hbao 0.0750, both bounded below by the screen-space limit: the disk's underside is in no pixel, and its top,
    a sliver a few rows high, is taken as infinitely thick (gtao with 9 slices × 32 steps reads 0.083: finer
    sampling finds the sliver more often). ldm, which sees the disk from all directions, reads 0.0119 there (0.0097
    overhead). Measured on llvmpipe."""
    g_over = disk_error(gpu, method_cls, GTAOParams, OVERHEAD)
    h_over = disk_error(gpu, HBAO, HBAOParams, OVERHEAD)
    assert g_over < 0.015 and g_over < h_over, f"overhead: gtao {g_over:.4f}, hbao {h_over:.4f}"
    g_low = disk_error(gpu, method_cls, GTAOParams, LOW)
    h_low = disk_error(gpu, HBAO, HBAOParams, LOW)
    assert 0.05 < g_low < 0.085 and 0.05 < h_low < 0.085, f"low: gtao {g_low:.4f}, hbao {h_low:.4f}"


def test_thin_disk_closed_form_beside_hbao(gpu):
    check_disk_beside_hbao(gpu)


def test_dropping_off_screen_samples_fails_the_disk(gpu, tmp_path):
    """The march as it was: the radius not clamped to the border, the first off-screen sample ends the side."""
    broken = broken_gtao(tmp_path, "gtao.glsl",
                         ("float radius_side = min(radius, min(room.x, room.y));", "float radius_side = radius;"),
                         ("ivec2 qi = clamp(ivec2(floor(q)), ivec2(0), size - 1);",
                          "ivec2 qi = ivec2(floor(q)); if (any(lessThan(qi, ivec2(0))) || "
                          "any(greaterThanEqual(qi, size))) break;"))
    with pytest.raises(AssertionError, match="overhead"):
        check_disk_beside_hbao(gpu, broken)


# ---- presets --------------------------------------------------------------------------------------------

def test_presets_are_xegtaos_quality_levels(gpu):
    """preset = low | medium | high | ultra sets XeGTAO's slices × steps (its vaGTAO.hlsl: 1 × 2, 2 × 2, 3 × 3,
    9 × 3); the defaults are "high"; a value given beside the preset wins; the image is that of the same
    parameters given one by one."""
    assert QUALITY == {"low": (1, 2), "medium": (2, 2), "high": (3, 3), "ultra": (9, 3)}
    for name, (n, k) in QUALITY.items():
        p = GTAOParams.from_dict({"preset": name})
        assert (p.slices, p.steps) == (n, k)
    d = GTAOParams()
    assert (d.slices, d.steps) == QUALITY["high"]
    assert GTAOParams.from_dict({"preset": "ultra", "steps": 8}).steps == 8
    with pytest.raises(LdbenchError, match="preset"):
        GTAOParams.from_dict({"preset": "epic"})
    sc, eff = floor_wall_scene(), Effect("ao", 1.0, "step")
    m = GTAO(GTAOParams.from_dict({"preset": "low"}))
    m.setup(gpu, sc)
    low = m.frame(View(sc.camera, 64, 64), eff).resolve().image
    m.release()
    same, _, _ = render(gpu, sc, eff, 64, slices=1, steps=2)
    assert np.array_equal(low, same.image)
    ultra, _, _ = render(gpu, sc, eff, 64, slices=9, steps=3)
    assert not np.array_equal(low, ultra.image)


# ---- the depth MIP pre-filter ----------------------------------------------------------------------------

def mip_chain(depth, radius, levels=5):
    """numpy twin of prefilter.glsl: ``depth`` (GL row order, padded, 0 = background) and its 2×2 reductions
    by XeGTAO's weighted average (``radius`` = 0.75 d_max; 0 = d_max = ∞, the plain mean)."""
    out = [depth.astype(np.float64)]
    for _ in range(levels - 1):
        d = out[-1]
        q = np.stack([d[0::2, 0::2], d[0::2, 1::2], d[1::2, 0::2], d[1::2, 1::2]])
        far = q.max(0)
        w = (q > 0).astype(np.float64)
        if radius > 0:
            rng = 0.615 * radius
            w *= np.clip(1.0 - ((far - q) - (radius - rng)) / rng, 0.0, 1.0)
        s = w.sum(0)
        out.append(np.where(far > 0, (w * q).sum(0) / np.where(s > 0, s, 1.0), 0.0))
    return out


def gl_depth(method, view):
    """The view-space depth of the method's G-buffer in GL row order, padded to a multiple of 16 with 0."""
    pos = method.gbuf.read()[0][::-1].astype(np.float64)
    vm = view.camera.view_matrix()
    z = -(pos[..., :3] @ vm[2, :3] + vm[2, 3])
    z = np.where(pos[..., 3] > 0.5, z, 0.0)
    h, w = z.shape
    return np.pad(z, ((0, -h % 16), (0, -w % 16)))


def cornell_prefilter(gpu, d_max, size=(100, 84), method_cls=GTAO, **params):
    """(the method's MIP levels 0..4 in GL row order, numpy's): cornell at a size no multiple of 16."""
    from ldbench.core.scenes import load_scene

    sc = load_scene("cornell")
    view = View(sc.camera, *size)
    m = method_cls(GTAOParams(**{**MIP, **params}))
    m.setup(gpu, sc)
    m.frame(view, Effect("ao", d_max, "step"))
    got = [a[::-1] for a in m.read_mips()]
    want = mip_chain(gl_depth(m, view), 0.0 if math.isinf(d_max) else 0.75 * d_max)
    m.release()
    return got, want


def check_prefilter(gpu, method_cls=GTAO):
    """Levels 0..4 of the pre-filter are numpy's twin to float rounding (relative 2e-6; measured 1.5e-7), with
    d_max = 0.35 (the weights fade the nearer texels: the depths span 2.9 .. 4.9 in cornell) and d_max = ∞ (the
    plain mean); every level is exactly half the one before."""
    for d_max in (0.35, math.inf):
        got, want = cornell_prefilter(gpu, d_max, method_cls=method_cls)
        for i, (g, w) in enumerate(zip(got, want)):
            assert g.shape == w.shape == (96 >> i, 112 >> i)
            err = np.abs(g - w).max() / np.abs(w).max()
            assert err < 2e-6, f"MIP level {i} (d_max {d_max}): relative error {err:.2e}"


def test_prefilter_is_xegtaos_depth_mip_filter(gpu):
    check_prefilter(gpu)


@pytest.mark.parametrize("edit", [
    ("w *= clamp(1.0 - ((far - d) - from) / range, 0.0, 1.0);", ""),                         # the plain mean
    ("vec4 valid = vec4(greaterThan(d, vec4(0.0)));", "vec4 valid = vec4(1.0);"),            # background counted
    ("scratch[l.x + s][l.y + s]));", "scratch[l.x][l.y]));"),                                # a texel, not four
], ids=["plain-mean", "background-averaged", "one-texel"])
def test_broken_prefilter_fails(gpu, tmp_path, edit):
    with pytest.raises(AssertionError, match="MIP level"):
        check_prefilter(gpu, broken_gtao(tmp_path, "prefilter.glsl", edit))


def check_levels_read(gpu, method_cls=GTAO):
    """The horizon search reads the level its sample distance selects: cornell at d_max = ∞ (radius 256 px on
    a 128² image, levels up to 4), mip_offset 3.3 against 16 (level 0 only): 88 % of the pixels differ by more
    than 1e-3 (measured), and the default 3.3 scores no worse than level 0 alone against the reference, within
    0.3 dB (measured 12.05 against 11.51 dB, 64-spp reference: the filtered levels cost no accuracy here)."""
    from ldbench.core.scenes import load_scene
    from ldbench.references import render_reference

    sc, eff = load_scene("cornell"), Effect("ao", math.inf, "step")
    ref = render_reference(sc, eff, width=128, height=128, spp=64, progress=False)
    img = {}
    for off in (3.3, 16.0):
        r, _, _ = render(gpu, sc, eff, 128, method_cls=method_cls, mip_offset=off, **MIP)
        img[off] = r.image
    frac = float(np.mean(np.abs(img[3.3] - img[16.0]) > 1e-3))
    assert frac > 0.3, f"mip_offset changes {frac:.1%} of the pixels: the MIP levels are not read"
    psnr = {k: M.psnr(v, ref.mean, mask=ref.mask, data_range=1.0) for k, v in img.items()}
    assert psnr[3.3] > psnr[16.0] - 0.3, psnr


def test_mip_levels_are_read(gpu):
    check_levels_read(gpu)


def test_level_zero_only_fails(gpu, tmp_path):
    broken = broken_gtao(tmp_path, "gtao.glsl", ("int lod = int(clamp(", "int lod = 0 * int(clamp("))
    with pytest.raises(AssertionError, match="not read"):
        check_levels_read(gpu, broken)


def test_mip_mode_closed_forms(gpu):
    """prefilter = mip on the closed forms, converged sampling: the floor beside the wall within 0.0150 (measured
    0.0144; 0.0101 reading the G-buffer: a sample's point is its pixel centre's, up to 0.7 px off the slice, as
    in XeGTAO, where the G-buffer path moves it onto the slice along its normal); nothing beyond d_max
    occludes (all 4864 pixels equal to the wall-less scene); the disk beside hbao as with the G-buffer
    (overhead 0.0124, low 0.0773); an oblique unoccluded plane at defaults reads ≥ 0.979 (measured min 0.9800,
    mean 0.9961: the off-slice points again; 0.9860 / 0.9972 reading the G-buffer)."""
    class Mip(GTAO):
        name = ""

        def __init__(self, params=None):
            super().__init__(GTAOParams(**{**(params or GTAOParams()).to_dict(), **MIP}))

    r, _, pos = render(gpu, floor_wall_scene(), Effect("ao", 1.0, "step"), 192, **FINE, **MIP)
    from test_hbao import floor_profile
    prof = floor_profile(r.image, pos)
    assert np.abs(prof[:, 0] - prof[:, 1]).max() < 0.015, prof
    check_cut_off(gpu, Mip)
    check_disk_beside_hbao(gpu, Mip)
    oblique = Scene("plane", [plane()], Camera((0, 5, 0.001), (0, 0, 0), (0, 0, -1), 50.0))
    r, _, _ = render(gpu, oblique, Effect("ao", math.inf, "step"), 128, **MIP)
    ao = r.image[..., 0][r.mask]
    assert ao.min() > 0.979 and ao.mean() > 0.996, (ao.min(), ao.mean())


# ---- 16-bit MIP levels -----------------------------------------------------------------------------------

def check_depth16(gpu, method_cls=GTAO):
    """depth_precision = 16: levels 1..4 are the 32-bit levels in float16, within one float16 ulp (relative
    2^-10: GL lets the conversion truncate, and llvmpipe does: measured 8.4e-4), in a 16-bit texture (levels 1..4
    take half the bytes); level 0 stays 32-bit and exact. On cornell (d_max 0.35, 128²) the image differs from the 32-bit one by 4.1e-5
    in the mean and 0.0035 at the 99.9th percentile (measured; bounds 5e-4 and 0.01; the largest difference,
    0.024, is a sample whose distance crosses d_max)."""
    from ldbench.core.scenes import load_scene

    g32, _ = cornell_prefilter(gpu, 0.35)
    g16, _ = cornell_prefilter(gpu, 0.35, method_cls=method_cls, depth_precision="16")
    assert np.array_equal(g16[0], g32[0]), "MIP level 0 is not the 32-bit depth"
    for i in range(1, 5):
        rel = np.abs(g16[i] - g32[i]) / np.maximum(np.abs(g32[i]), 1e-30)
        assert rel.max() <= 2.0 ** -10, f"MIP level {i}: 16-bit level off by {rel.max():.2e} relative"
        assert np.array_equal(g16[i], g16[i].astype(np.float16).astype(np.float32)), f"MIP level {i} is not 16-bit"
    sc, eff = load_scene("cornell"), Effect("ao", 0.35, "step")
    images, memory = {}, {}
    for bits in ("32", "16"):
        m = method_cls(GTAOParams(depth_precision=bits, **MIP))
        m.setup(gpu, sc)
        r = m.frame(View(sc.camera, 128, 128), eff).resolve()
        images[bits] = r.image
        memory[bits] = sum(v for k, v in r.memory_bytes.items() if "depth_mips" in k)
        m.release()
    d = np.abs(images["16"] - images["32"])
    assert d.mean() < 5e-4 and np.percentile(d, 99.9) < 0.01, \
        f"16-bit levels change the image by {d.mean():.2e} in the mean, {np.percentile(d, 99.9):.4f} at 99.9 %"
    level0 = 128 * 128 * 4
    assert memory["16"] - level0 == (memory["32"] - level0) / 2, memory


def test_depth16(gpu):
    check_depth16(gpu)


def test_depth16_misread_fails(gpu, tmp_path):
    """The horizon search reading the 16-bit levels at level-0 coordinates."""
    broken = broken_gtao(tmp_path, "gtao.glsl", ("texelFetch(depth_mips16, qi >> lod, lod - 1)",
                                                 "texelFetch(depth_mips16, qi >> (lod - 1), lod - 1)"))
    with pytest.raises(AssertionError, match="16-bit levels change the image"):
        check_depth16(gpu, broken)


def test_depth16_needs_the_prefilter():
    with pytest.raises(LdbenchError, match="depth_precision='16' needs prefilter = 'mip'"):
        GTAOParams(depth_precision="16")
    assert GTAOParams(depth_precision="16", prefilter="mip").depth_precision == "16"
