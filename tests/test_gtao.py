"""gtao (Jimenez et al. 2016) on llvmpipe: the analytic slice integral against closed forms (an
unoccluded plane, a floor beside a wall), the d_max cut-off, the fall-off order, the denoise, the
Mitsuba reference on cornell, and checks that a broken slice integral, cut-off or denoise fails. Then the
weighted horizon (quadratic fall-off, GTAO's fade, thin_occluder) against the estimator's closed form on the
floor beside the wall, final_power, the step count at the radius clamp, and non-square images (a crop of
the same view; an unoccluded plane within its slice range).

The floor/wall closed form and its scene are those of tests/test_hbao.py (derived there)."""
import math
from pathlib import Path

import numpy as np
import pytest

import ldbench.methods.gtao
from ldbench.core import metrics as M
from ldbench.core.effects import Effect
from ldbench.core.errors import LdbenchError
from ldbench.core.scene import Camera, Scene
from ldbench.methods.base import View, get_method, registry
from ldbench.methods.gtao import GTAO, GTAOParams
from test_hbao import LOW_OVER_FLOOR, floor_profile, floor_wall_scene, quad, wall_ao, wall_ao_quadratic
import testkit

GTAO_DIR = Path(ldbench.methods.gtao.__file__).resolve().parent
# converged sampling and no fade, denoise or noise pattern, so that what remains is the integral
FINE = dict(slices=9, steps=32, falloff_range=0.0, denoise_passes=0)


def render(gpu, scene, effect, size, method_cls=GTAO, **params):
    m = method_cls(GTAOParams(**params))
    m.setup(gpu, scene)
    gpu.begin_frame()
    r = m.frame(View(scene.camera, size, size), effect).resolve()
    stages, _ = gpu.end_frame()
    pos = m.gbuf.read()[0]
    m.release()
    return r, stages, pos


def broken_gtao(tmp_path, shader, *edits):
    """An unregistered GTAO whose ``shader`` has each (old, new) text replaced (each must occur)."""
    src = (GTAO_DIR / shader).read_text()
    for old, new in edits:
        assert old in src, old
        src = src.replace(old, new)
    (tmp_path / shader).write_text(src)

    class Broken(GTAO):
        name = ""  # not registered

        def shader(self, name):
            return tmp_path / name if name == shader else GTAO_DIR / name

    return Broken


def test_registered_and_params():
    assert registry()["gtao"] is GTAO and get_method("gtao") is GTAO
    assert GTAO.effects == frozenset({"ao"})
    p = GTAOParams()
    # XeGTAO's "High" preset and defaults, but no fade: the ao effect's fall-off alone
    assert (p.slices, p.steps, p.distribution, p.falloff_range, p.thin_occluder, p.denoise_passes) == \
        (3, 3, 2.0, 0.0, 0.0, 1)
    assert (p.prefilter, p.depth_precision, p.mip_offset) == ("none", "32", 3.3)
    with pytest.raises(LdbenchError, match="slices"):
        GTAOParams.from_dict({"slices": 0}, method="gtao")
    with pytest.raises(LdbenchError, match="falloff_range"):
        GTAOParams(falloff_range=1.5)


def test_slice_visibility_of_an_unoccluded_hemisphere():
    """The analytic slice visibility between the tangent-plane horizons, nlen (cos γ + γ sin γ), averages
    to exactly 1 over the slice angle for any normal facing the viewer (the integral GTAO solves)."""
    v = np.array([0.0, 0.0, 1.0])
    phi = (np.arange(8192) + 0.5) / 8192 * np.pi
    d = np.stack([np.cos(phi), np.sin(phi), 0 * phi], -1)
    for alpha in (0.0, 0.5, 1.0, 1.45):
        n = np.array([np.sin(alpha) * 0.6, np.sin(alpha) * 0.8, np.cos(alpha)])
        no, nv = d @ n, n @ v
        g = np.arctan2(no, nv)
        nlen = np.hypot(nv, no)
        arc = lambda h: -np.cos(2 * h - g) + np.cos(g) + 2 * h * np.sin(g)
        vis = 0.25 * nlen * (arc(g - np.pi / 2) + arc(g + np.pi / 2))
        assert vis.mean() == pytest.approx(1.0, abs=1e-6)


def test_unoccluded_plane(gpu):
    """A plane seen head-on is exactly unoccluded (measured min 0.999998); seen obliquely, three slices
    per pixel estimate the hemisphere within 1.5 % at worst (measured min 0.9860, mean 0.99723 with the
    default denoise; clamping estimates above 1 is what keeps the mean below 1)."""
    pl = testkit.plane()
    head_on = Scene("plane", [pl], Camera((0, 50, 0.001), (0, 0, 0), (0, 0, -1), 5.0))
    r, stages, _ = render(gpu, head_on, Effect("ao", math.inf, "step"), 64)
    assert set(stages) == {"gbuffer", "gtao", "denoise"}
    assert r.image.shape == (64, 64, 1) and r.image.dtype == np.float32
    assert r.image[r.mask].min() > 0.99999
    oblique = Scene("plane", [pl], Camera((0, 5, 0.001), (0, 0, 0), (0, 0, -1), 50.0))
    r, _, _ = render(gpu, oblique, Effect("ao", math.inf, "step"), 128)
    ao = r.image[..., 0][r.mask]
    assert ao.min() > 0.985 and ao.mean() > 0.997, (ao.min(), ao.mean())


def check_floor_wall(gpu, method_cls=GTAO):
    """Step fall-off, d_max = 1, converged sampling: the floor profile matches the closed form to 0.0105
    (measured max 0.0101 on llvmpipe, at a = 0.8 .. 1.2 where the few-slice estimate of the unoccluded
    part dominates)."""
    r, _, pos = render(gpu, floor_wall_scene(), Effect("ao", 1.0, "step"), 192, method_cls=method_cls, **FINE)
    prof = floor_profile(r.image, pos)
    err = np.abs(prof[:, 0] - prof[:, 1])
    assert err.max() < 0.0105, f"floor AO {np.round(prof[:, 0], 4)} vs closed form {np.round(prof[:, 1], 4)}"


def test_floor_near_wall_matches_closed_form(gpu):
    check_floor_wall(gpu)


@pytest.mark.parametrize("edit", [
    ("visibility += 0.25 * nlen * (arc(h0, gamma) + arc(h1, gamma));",
     "visibility += 0.25 * (arc(h0, gamma) + arc(h1, gamma));"),                  # projected-normal length lost
    ("return -cos(2.0 * h - gamma) + cos(gamma) + 2.0 * h * sin(gamma);",
     "return -cos(2.0 * h - gamma) + cos(gamma) + 2.0 * h * cos(gamma);"),        # wrong cosine term
    ("hc = max(hc, mix(low, dot(D, v) / len, w));", "hc = max(hc, mix(low, dot(D, v) / len, 0.5 * w));"),
], ids=["no-nlen", "sin-for-cos", "half-weight"])
def test_broken_slice_integral_fails(gpu, tmp_path, edit):
    with pytest.raises(AssertionError, match="closed form"):
        check_floor_wall(gpu, broken_gtao(tmp_path, "gtao.glsl", edit))


def check_cut_off(gpu, method_cls=GTAO):
    """Step fall-off, d_max = 0.3, seen from low over the floor (the wall foreshortened, so floor points
    up to a few d_max from it reach it on screen): every floor pixel farther than d_max from the wall is
    exactly what it is with no wall at all (measured: all 4864 equal); nearer ones are darker."""
    sc = floor_wall_scene()
    with_wall = Scene(sc.name, sc.meshes, LOW_OVER_FLOOR)
    no_wall = Scene(sc.name, sc.meshes[:1], LOW_OVER_FLOOR)
    eff = Effect("ao", 0.3, "step")
    r, _, pos = render(gpu, with_wall, eff, 128, method_cls=method_cls, **FINE)
    r0, _, _ = render(gpu, no_wall, eff, 128, method_cls=method_cls, **FINE)
    floor = (pos[..., 3] > 0.5) & (np.abs(pos[..., 1]) < 1e-4) & (np.abs(pos[..., 2]) < 1.5)
    a = 1.0 - pos[..., 0]
    beyond, near = floor & (a > 0.305), floor & (a < 0.24)
    assert beyond.sum() > 3000 and near.sum() > 200
    ao, ao0 = r.image[..., 0], r0.image[..., 0]
    diff = np.abs(ao - ao0)[beyond]
    assert diff.max() < 1e-6, f"{(diff > 1e-6).mean():.1%} of the pixels beyond d_max occluded by the wall"
    assert (ao0 - ao)[near].mean() > 0.2  # the wall does occlude within d_max (measured 0.31)


def test_nothing_beyond_d_max_occludes(gpu):
    check_cut_off(gpu)


def test_broken_cut_off_fails(gpu, tmp_path):
    broken = broken_gtao(tmp_path, "gtao.glsl", ("if (r >= d_max) return 0.0;", ""))
    with pytest.raises(AssertionError, match="beyond d_max"):
        check_cut_off(gpu, broken)


def test_falloff_order(gpu):
    """Weights ρ ≤ 1 only lower horizons: quadratic ≥ step pointwise, GTAO's fade ≥ none; larger d_max is
    darker and d_max = ∞ (the pixel-radius clamp) darkest."""
    sc = floor_wall_scene()
    imgs = {}
    for d, fo, fr in ((0.3, "step", 0.0), (0.3, "quadratic", 0.0), (0.3, "step", 0.615), (1.0, "step", 0.0),
                      (math.inf, "step", 0.0)):
        r, _, _ = render(gpu, sc, Effect("ao", d, fo), 96, falloff_range=fr, denoise_passes=0)
        imgs[(d, fo, fr)] = r.image
    assert np.all(imgs[(0.3, "quadratic", 0.0)] >= imgs[(0.3, "step", 0.0)] - 1e-6)
    assert np.all(imgs[(0.3, "step", 0.615)] >= imgs[(0.3, "step", 0.0)] - 1e-6)
    assert not np.allclose(imgs[(0.3, "quadratic", 0.0)], imgs[(0.3, "step", 0.0)])
    means = [imgs[k].mean() for k in ((0.3, "step", 0.0), (1.0, "step", 0.0), (math.inf, "step", 0.0))]
    assert means[0] > means[1] > means[2], means


def pixel_noise(r):
    """Mean absolute difference of horizontally adjacent pixels that both hit: the noise pattern,
    not the image's slow variation."""
    ao, m = r.image[..., 0], r.mask
    both = m[:, 1:] & m[:, :-1]
    return float(np.abs(ao[:, 1:] - ao[:, :-1])[both].mean())


def check_denoise(gpu, method_cls=GTAO):
    """Beside the wall, where the noise pattern of three slices shows, one denoise pass cuts the pixel
    noise by more than half (measured 0.0186 -> 0.0026) and keeps the floor profile within 0.02 (measured
    0.0068, in the bin at the wall's foot, where the plane-distance edge test lets the wall blend in)."""
    sc, eff = floor_wall_scene(), Effect("ao", 1.0, "step")
    raw = render(gpu, sc, eff, 192, method_cls=method_cls, denoise_passes=0)
    den = render(gpu, sc, eff, 192, method_cls=method_cls, denoise_passes=1)
    n_raw, n_den = pixel_noise(raw[0]), pixel_noise(den[0])
    assert n_den < 0.5 * n_raw, f"denoise: pixel noise {n_raw:.5f} -> {n_den:.5f}"
    p_raw, p_den = floor_profile(raw[0].image, raw[2]), floor_profile(den[0].image, den[2])
    assert np.abs(p_raw[:, 0] - p_den[:, 0]).max() < 0.02


def test_denoise_reduces_noise(gpu):
    check_denoise(gpu)


def test_broken_denoise_fails(gpu, tmp_path):
    broken = broken_gtao(tmp_path, "denoise.glsl", ("sum += w * tile_ao[j];", "sum += w * c;"))
    with pytest.raises(AssertionError, match="denoise"):
        check_denoise(gpu, broken)


def denoise_numpy(ao, pos, nrm, eye, beta):
    """The denoise's definition (denoise.glsl's header), one pass, in float64: an independent check."""
    from ldbench.methods.gtao import DENOISE_SHARPNESS

    h, w = ao.shape
    hit = pos[..., 3] > 0.5
    out = ao.astype(np.float64).copy()
    inv_tol = DENOISE_SHARPNESS / np.maximum(np.linalg.norm(pos[..., :3] - eye, axis=-1), 1e-20)
    ys, xs = np.nonzero(hit)
    wsum = np.full(len(ys), beta)
    acc = beta * ao[ys, xs].astype(np.float64)
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            if dx == dy == 0:
                continue
            qy, qx = ys + dy, xs + dx
            ok = (qy >= 0) & (qy < h) & (qx >= 0) & (qx < w)
            ok[ok] &= hit[qy[ok], qx[ok]]
            e = np.einsum("ij,ij->i", pos[qy[ok], qx[ok], :3] - pos[ys[ok], xs[ok], :3], nrm[ys[ok], xs[ok], :3])
            wt = (0.5 if dx and dy else 1.0) * np.exp(-(e * inv_tol[ys[ok], xs[ok]]) ** 2)
            acc[ok] += wt * ao[qy[ok], qx[ok]]
            wsum[ok] += wt
    out[ys, xs] = np.clip(acc / wsum, 0.0, 1.0)
    return out


def check_denoise_definition(gpu, method_cls=GTAO):
    """One denoise pass on cornell (100 × 77: partial workgroups at two borders) is the numpy pass over the
    undenoised image and the G-buffer within 1e-5 (float32 against float64 arithmetic, exp of arguments of a
    few units; measured 1.7e-7 on llvmpipe). Rows are read top-down for both, so the check is symmetric."""
    from ldbench.core.scenes import load_scene

    sc, eff = load_scene("cornell"), Effect("ao", 0.35, "step")
    out = {}
    for passes in (0, 1):
        m = method_cls(GTAOParams(denoise_passes=passes))
        m.setup(gpu, sc)
        out[passes] = m.frame(View(sc.camera, 100, 77), eff).resolve().image[..., 0]
        pos, nrm, _ = m.gbuf.read()
        m.release()
    want = denoise_numpy(out[0], pos, nrm, np.array(sc.camera.origin, np.float64), GTAOParams().denoise_beta)
    d = np.abs(out[1] - want).max()
    assert d < 1e-5, f"the denoise differs from its definition by {d:.3g}"


def test_denoise_is_its_definition(gpu):
    check_denoise_definition(gpu)


@pytest.mark.parametrize("edit", [("ivec2 origin = ivec2(gl_WorkGroupID.xy) * 8 - 1;",
                                   "ivec2 origin = ivec2(gl_WorkGroupID.xy) * 8;"),
                                  ("for (int i = int(gl_LocalInvocationIndex); i < APRON * APRON; i += 64)",
                                   "for (int i = int(gl_LocalInvocationIndex); i < 64; i += 64)"),
                                  ("    barrier();\n", "")], ids=["apron-offset", "apron-part", "no-barrier"])
def test_a_broken_denoise_tile_fails(gpu, tmp_path, edit):
    with pytest.raises(AssertionError, match="definition"):
        check_denoise_definition(gpu, broken_gtao(tmp_path, "denoise.glsl", edit))


def test_cornell_small_dmax_against_reference(gpu):
    """cornell, d_max = 5 % of the diagonal, 256², against Mitsuba (256 spp): the defaults (XeGTAO's "High":
    3 × 3 samples per side, one denoise; no fade) 24.33 dB; with XeGTAO's fade 20.68 dB; 9 slices × 32 steps
    33.99 dB (measured on llvmpipe): sampling, not the integral, limits the preset."""
    from ldbench.core.scenes import load_scene
    from ldbench.references import render_reference

    sc = load_scene("cornell")
    eff = Effect("ao", round(0.05 * sc.diagonal(), 4), "step")
    size = 256
    ref = render_reference(sc, eff, width=size, height=size, spp=256, progress=False)
    got = {}
    for key, kw in (("high", {}), ("fade", dict(falloff_range=0.615)), ("fine", dict(slices=9, steps=32))):
        r, _, _ = render(gpu, sc, eff, size, **kw)
        assert np.array_equal(r.mask, ref.mask) and np.all(r.image[~r.mask] == 1.0)
        got[key] = M.psnr(r.image, ref.mean, mask=ref.mask, data_range=1.0)
    assert got["high"] > 24.25 and got["fade"] > 20.6 and got["fine"] > 33.95, got


def test_rejects_other_effects(gpu):
    sc = floor_wall_scene()
    m = get_method("gtao")()
    m.setup(gpu, sc)
    with pytest.raises(LdbenchError, match="effect"):
        m.frame(View(sc.camera, 16, 16), Effect("direct"))
    m.release()


# ---- the fall-off, GTAO's fade and the thin-occluder heuristic against the estimator's limit ----------
#
# On the floor beside the wall (tests/test_hbao.py) GTAO's weighted horizon has a closed form per slice: a
# slice's plane meets the wall in a line, floor samples sit exactly on the low (tangent-plane) horizon, and
# the side's horizon cosine is the supremum over that line of mix(low, cos θ, w(r)) (r the 3D distance with
# its view-z part stretched by 1 + thin_occluder; the line limited to the wall, the screen and the projected
# radius). ``wall_estimator`` evaluates that supremum on 256 points of the line (the steps → ∞ limit) and the
# slice integral on 48 slice angles (the slices → ∞ limit; the screen-space slice directions of the shader),
# so it is the estimator's limit for any weight w. For w = 1 (step) it is hbao's closed form
# (``test_wall_estimator_is_the_closed_form_for_step``); for the quadratic ρ and the fade it is not the
# obscurance integral (docs/reference/methods/gtao.md), and the shader must match this limit instead.

WALL_BINS = (0.0, 0.1, 0.2, 0.4, 0.6, 0.8, 1.0, 1.2)  # distance a from the wall (bin width 0.05)
WALL_SIZE, WALL_D = 160, 1.5  # d_max 1.5 (not 1, so that d_max and d_max² differ); the wall still spans it


def wall_pixels(pos, per_bin=40):
    """Per WALL_BINS bin, a fixed random subset of floor pixels (|z| < 1) at that distance from the wall."""
    on_floor = (pos[..., 3] > 0.5) & (np.abs(pos[..., 1]) < 1e-4) & (np.abs(pos[..., 2]) < 1.0)
    a = 1.0 - pos[..., 0]
    rng = np.random.default_rng(0)
    sels = []
    for lo in WALL_BINS:
        idx = np.flatnonzero(on_floor & (a >= lo) & (a < lo + 0.05))
        assert len(idx) >= per_bin
        sel = np.zeros(a.shape, bool)
        sel.flat[rng.choice(idx, per_bin, replace=False)] = True
        sels.append(sel)
    return sels


def wall_estimator(pos, sel, camera, width, height, d_max, weight, thin_occluder=0.0, max_radius_px=256.0,
                   n_phi=48, n_line=256, screen=True):
    """GTAO's limit (slices, steps → ∞) at the floor pixels ``sel`` of the floor/wall scene, from their
    G-buffer positions ``pos`` (H×W×4, world): see the comment above. ``weight(r, d_max)`` is w within d_max."""
    vm = camera.view_matrix()
    rot, tr = vm[:3, :3], vm[:3, 3]
    focal = 0.5 * height / math.tan(math.radians(camera.fov_y) / 2)
    half = np.array([0.5 * width, 0.5 * height])
    P = pos[..., :3][sel].astype(np.float64) @ rot.T + tr          # view space
    v = -P / np.linalg.norm(P, axis=1, keepdims=True)
    n = np.broadcast_to(rot[:, 1], P.shape)                         # the floor's normal (world +y)
    radius = np.minimum(d_max * focal / -P[:, 2], max_radius_px)
    pc = half + focal * P[:, :2] / -P[:, 2:3]
    ex = rot[:, 0]                                                  # the wall plane x = 1: ex · X = wall_c
    wall_c = 1.0 + ex @ tr
    s = np.linspace(-1.0, 1.0, n_line)
    vis = np.zeros(len(P))
    for j in range(n_phi):
        phi = math.pi * (j + 0.5) / n_phi
        d3 = np.array([math.cos(phi), math.sin(phi), 0.0])
        o = d3 - (v @ d3)[:, None] * v
        o /= np.linalg.norm(o, axis=1, keepdims=True)
        nv, no = np.sum(n * v, 1), np.sum(n * o, 1)
        nlen, g = np.hypot(nv, no), np.arctan2(no, np.maximum(nv, 1e-6))
        # the slice plane (normal m through P) meets the wall in the line X0 + t L, X0 its point nearest P
        m = np.cross(v, o)
        c = m @ ex
        X0 = P + ((wall_c - P @ ex) / (1.0 - c * c))[:, None] * (ex - c[:, None] * m)
        L = np.cross(m, ex)
        L /= np.linalg.norm(L, axis=1, keepdims=True)
        half_chord = np.sqrt(np.maximum(d_max ** 2 - np.sum((X0 - P) ** 2, 1), 0.0))  # the part within d_max
        X = X0[:, None] + (half_chord[:, None] * s)[..., None] * L[:, None]
        D = X - P[:, None]
        Xw = (X - tr) @ rot                                         # world, to clip to the wall's extent
        q = half + focal * X[..., :2] / -X[..., 2:3]                # pixel coordinates (as the shader's)
        sd = np.linalg.norm(q - pc[:, None], axis=-1)
        ok = ((Xw[..., 1] >= 0) & (Xw[..., 1] <= 2) & (np.abs(Xw[..., 2]) <= 3) & (half_chord[:, None] > 0)
              & (~screen | (np.all((q >= 0) & (q < [width, height]), -1) & (sd >= 1.0) & (sd <= radius[:, None]))))
        r = np.linalg.norm(D, axis=-1)
        r_w = np.sqrt(D[..., 0] ** 2 + D[..., 1] ** 2 + (D[..., 2] * (1.0 + thin_occluder)) ** 2)
        w = np.where(r_w < d_max, weight(r_w, d_max), 0.0)
        cos_s = np.sum(D * v[:, None], -1) / np.maximum(r, 1e-30)
        side = np.sum(D * o[:, None], -1)
        hc = {}
        for sg, low in ((1, -np.sin(g)), (-1, np.sin(g))):         # cos(γ ± π/2): the tangent plane
            f = low[:, None] + w * (cos_s - low[:, None])
            hc[sg] = np.maximum(low, np.where(ok & (side * sg > 0), f, -2.0).max(1))
        h1 = g + np.clip(np.arccos(np.clip(hc[1], -1, 1)) - g, -np.pi / 2, np.pi / 2)
        h0 = g + np.clip(-np.arccos(np.clip(hc[-1], -1, 1)) - g, -np.pi / 2, np.pi / 2)
        arc = lambda h: -np.cos(2 * h - g) + np.cos(g) + 2 * h * np.sin(g)  # noqa: E731
        vis += 0.25 * nlen * (arc(h0) + arc(h1))
    return np.clip(vis / n_phi, 0.0, 1.0)


STEP_W = lambda r, d: np.ones_like(r)  # noqa: E731
QUADRATIC_W = lambda r, d: 1.0 - (r / d) ** 2  # noqa: E731


def fade_w(falloff_range):
    """GTAO's fade (step ρ): 1, then linearly to 0 over the last ``falloff_range`` of d_max."""
    return lambda r, d: np.clip((d - r) / (falloff_range * d), 0.0, 1.0)


def wall_profiles(gpu, effect, weight, method_cls=GTAO, thin_occluder=0.0, **params):
    """(GPU profile, the estimator's limit) per WALL_BINS bin, converged sampling (FINE) plus ``params``."""
    r, _, pos = render(gpu, floor_wall_scene(), effect, WALL_SIZE, method_cls=method_cls,
                       **{**FINE, "thin_occluder": thin_occluder, **params})
    sels = wall_pixels(pos)
    both = np.any(sels, axis=0)
    limit = np.ones(pos.shape[:2])
    limit[both] = wall_estimator(pos, both, floor_wall_scene().camera, WALL_SIZE, WALL_SIZE, effect.d_max, weight,
                                 thin_occluder=thin_occluder)
    ao = r.image[..., 0]
    return (np.array([ao[s].mean() for s in sels]), np.array([limit[s].mean() for s in sels]), r.image)


def check_wall_limit(gpu, effect, weight, tol, method_cls=GTAO, **params):
    ours, limit, img = wall_profiles(gpu, effect, weight, method_cls=method_cls, **params)
    err = np.abs(ours - limit)
    assert err.max() < tol, f"floor AO {np.round(ours, 4)} vs the estimator's closed form {np.round(limit, 4)}"
    return ours, img


def test_wall_estimator_is_the_closed_form_for_step(gpu):
    """The limit's own check: with w = 1 (step) the weighted horizon is the exact horizon, and without the
    screen's limits (the projected radius, the image) the limit is hbao's closed form A(a) (measured within
    0.0026 per bin, bound 0.004: the screen-space slice directions are not uniform about v); with the
    quadratic ρ it is not the obscurance integral wall_ao_quadratic (off by more than 0.1)."""
    _, _, pos = render(gpu, floor_wall_scene(), Effect("ao", WALL_D, "step"), WALL_SIZE, **FINE)
    cam, a = floor_wall_scene().camera, 1.0 - pos[..., 0]
    sels = wall_pixels(pos)
    both = np.any(sels, axis=0)
    for w, exact, far in ((STEP_W, wall_ao, False), (QUADRATIC_W, wall_ao_quadratic, True)):
        lim = np.ones(a.shape)
        lim[both] = wall_estimator(pos, both, cam, WALL_SIZE, WALL_SIZE, WALL_D, w, screen=False)
        err = np.array([abs(lim[s].mean() - exact(a[s], WALL_D).mean()) for s in sels])
        assert (err.max() > 0.1) if far else (err.max() < 0.004), err


# Tolerances against the limit. The GPU's error is the estimator's sampling error (9 stratified slices, 32
# steps per side), deterministic: every GPU takes the same samples, only float32 rounding (< 1e-5 in AO here)
# differs, so what llvmpipe measures is what an NVIDIA GPU measures. Where w is smooth along the wall line
# (quadratic ρ) the horizon's supremum sits at a smooth maximum and 32 steps miss it by second order: measured
# ≤ 0.00027 per bin, bound 0.002. Where w has a kink (the fade's start at (1 − falloff_range) d_max) the miss
# is first order in the step spacing: measured 0.0024, bound 0.006.
SMOOTH_TOL, KINK_TOL = 0.002, 0.006


def check_quadratic_falloff(gpu, method_cls=GTAO):
    """Quadratic fall-off, d_max 1.5, no fade: the floor profile is the estimator's closed form (ρ forced to
    1 is off by 0.2; ρ = 1 − r/d_max by 0.1; the obscurance integral wall_ao_quadratic by 0.13)."""
    check_wall_limit(gpu, Effect("ao", WALL_D, "quadratic"), QUADRATIC_W, SMOOTH_TOL, method_cls=method_cls)


def test_quadratic_falloff_matches_the_closed_form(gpu):
    check_quadratic_falloff(gpu)


@pytest.mark.parametrize("edit", [
    ("float rho = (falloff_mode == 1) ? 1.0 - (r * r) / (d_max * d_max) : 1.0;", "float rho = 1.0;"),
    ("1.0 - (r * r) / (d_max * d_max)", "1.0 - r / d_max"),
], ids=["rho-forced-to-1", "rho-linear"])
def test_broken_quadratic_falloff_fails(gpu, tmp_path, edit):
    with pytest.raises(AssertionError, match="closed form"):
        check_quadratic_falloff(gpu, broken_gtao(tmp_path, "gtao.glsl", edit))


def wall_profile(gpu, effect, **params):
    """(GPU floor profile per WALL_BINS bin, image), converged sampling (FINE) plus ``params``."""
    r, _, pos = render(gpu, floor_wall_scene(), effect, WALL_SIZE, **{**FINE, **params})
    return np.array([r.image[..., 0][s].mean() for s in wall_pixels(pos)]), r.image


def test_fade_applies_and_changes_the_image(gpu):
    """falloff_range = 0.615 (XeGTAO's): the weight is GTAO's fade, 1 up to (1 − 0.615) d_max and then
    linearly 0 at d_max (the limit with that w), and the image is not the one without the fade: as bright
    or brighter everywhere (w ≤ 1 only lowers horizons; 1e-6 = float rounding of the same samples), and by
    more than 0.05 in the bins a = 0.4 .. 0.8 (measured +0.143 .. +0.197 there)."""
    eff = Effect("ao", WALL_D, "step")
    faded, img = check_wall_limit(gpu, eff, fade_w(0.615), KINK_TOL, falloff_range=0.615)
    plain, img_plain = wall_profile(gpu, eff)
    assert np.all(img >= img_plain - 1e-6)
    gain = faded - plain
    assert np.all(gain[3:6] > 0.05), f"the fade changes the floor profile by {np.round(gain, 4)} only"


def test_thin_occluder_brightens(gpu):
    """thin_occluder stretches the view-z part of r, so r only grows and w(r) only falls: every pixel is as
    bright or brighter (1e-6: float rounding of the same samples), and where wall samples near d_max lie
    along the view axis much brighter (step: measured +0.089 and +0.038 in the bins a = 1.0, 1.2; asserted
    > 0.01 there). With the quadratic fall-off and t = 1 the profile is the estimator's closed
    form with that stretched r."""
    eff = Effect("ao", WALL_D, "step")
    plain, img = wall_profile(gpu, eff)
    thin, img_thin = wall_profile(gpu, eff, thin_occluder=1.0)
    assert np.all(img_thin >= img - 1e-6), f"thin_occluder darkened {np.mean(img_thin < img - 1e-6):.1%}"
    assert np.all(thin[-2:] - plain[-2:] > 0.01), (np.round(plain, 4), np.round(thin, 4))
    check_wall_limit(gpu, Effect("ao", WALL_D, "quadratic"), QUADRATIC_W, SMOOTH_TOL, thin_occluder=1.0)


def test_final_power_is_applied(gpu):
    """final_power p: the image is the p = 1 image to the power p, pixel by pixel (no denoise after it).
    Bound: GLSL's pow is exp2(p log2 x), log2 within 2^-21 absolute and exp2 within 3 ulp, so both images
    carry a relative error ≤ (p + 1)(2^-21 + 3·2^-23) ≈ 2.2e-6 at p = 2.2; 2e-5 absolute is 9× that."""
    sc, eff = floor_wall_scene(), Effect("ao", 1.0, "step")
    one, _, _ = render(gpu, sc, eff, 96, denoise_passes=0)
    powered, _, _ = render(gpu, sc, eff, 96, denoise_passes=0, final_power=2.2)
    a, b = one.image[..., 0], powered.image[..., 0]
    assert a[one.mask].min() < 0.6  # real occlusion, so that the power shows
    assert np.abs(b - a ** 2.2).max() < 2e-5, np.abs(b - a ** 2.2).max()
    assert np.abs(b - a).max() > 0.1


def test_steps_respected_at_the_radius_clamp(gpu):
    """A floor seen head-on (depth 4, 64², fov 40°) and a plate 2 nearer over its right half (its edge the
    screen line x = 32, a pixel boundary). With the screen radius clamped to R = 16 px (d_max = ∞, and
    d_max = 1000 where the projected radius is larger), 4 slices, 6 steps, distribution 1, a side's samples
    sit at 1 + (R − 1)(k + ρ)/6 px, k = 0 .. 5, ρ ∈ [0, 1): the farthest at ≥ 13.5 px, all at < R.
    Some slice lies within π/8 of the x axis, so every floor pixel whose centre is within 13.5 cos(π/8) =
    12.47 px of the edge has a sample on the plate (occluded: darker than without the plate by more than
    0.02: the plate's points within 16 px rise above 50° over the floor, so that slice's side loses
    ½ sin² 50° of its ½, 0.29, a quarter of it over four slices, > 0.07; measured ≥ 0.088), and none farther than R = 16 px does (the same as without the plate: the same
    samples at the same pixels, so only rounding of the G-buffer's positions, ~1e-7, may differ; bound 1e-5;
    measured bit-identical). Fewer steps fall short of the first, more reach past the second."""
    from ldbench.core.scene import Camera, Scene

    cam = Camera((0.0, 0.0, 4.0), (0.0, 0.0, 0.0), (0.0, 1.0, 0.0), 40.0)
    floor = quad("floor", (0, 0, 0), (40, 0, 0), (0, 40, 0))
    plate = quad("plate", (20, 0, 2), (20, 0, 0), (0, 40, 0))
    params = dict(slices=4, steps=6, distribution=1.0, falloff_range=0.0, denoise_passes=0, max_radius_px=16.0)
    e = 32 - (np.arange(32) + 0.5)  # floor columns 0 .. 31: distance of the pixel centre from the edge
    rows = slice(8, 56)  # samples up to π/8 off the x axis stay on screen up to the plate
    for eff in (Effect("ao", math.inf, "step"), Effect("ao", 1000.0, "step")):
        with_plate, _, pos = render(gpu, Scene("plate", [floor, plate], cam), eff, 64, **params)
        bare, _, _ = render(gpu, Scene("floor", [floor], cam), eff, 64, **params)
        assert np.all(np.abs(pos[:, :32, 2]) < 1e-5) and np.all(np.abs(pos[:, 32:, 2] - 2) < 1e-5)
        drop = (bare.image - with_plate.image)[..., 0]
        assert np.all(np.abs(drop[:, :32][:, e >= 16.0]) < 1e-5), \
            f"{eff.label()}: samples beyond the clamped radius: {np.round(drop[rows, :20].max(0), 3)}"
        near = drop[rows, :32][:, e < 13.5 * math.cos(math.pi / 8)]
        assert near.min() > 0.02, f"{eff.label()}: the samples fall short: {np.round(drop[rows, :32].min(0), 3)}"


def render_wh(gpu, scene, effect, width, height, **params):
    m = GTAO(GTAOParams(**params))
    m.setup(gpu, scene)
    gpu.begin_frame()
    r = m.frame(View(scene.camera, width, height), effect).resolve()
    gpu.end_frame()
    pos = m.gbuf.read()[0]
    m.release()
    return r, pos


@pytest.mark.parametrize("crop, full", [((128, 64), (128, 192)), ((64, 128), (192, 128))], ids=["128x64", "64x128"])
def test_non_square_image_is_the_crop_of_the_same_view(gpu, crop, full):
    """A W×H image whose vertical field of view covers the middle H rows of a taller (or the middle W
    columns of a wider) image of the same camera has the same focal length in pixels, the same pixel rays
    and — the crop being 64 px off, a multiple of the 64×64 noise tile — the same noise: away from the crop's
    border by more than the clamped radius (16 px) plus the denoise (1 px), GTAO must be the same there.
    Bound: rounding of the two projections moves positions by ~1e-6 (measured max AO difference 8e-7); a
    sample whose texel flips under that is rare (≪ 1 % of the pixels), so ≤ 1 % of the pixels may differ
    by more than 1e-4. A focal length taken from the width, or a dispatch whose rows come from the width
    (or columns from the height), changes most of them. Background is 1 and every hit is written (> 0)."""
    from ldbench.core.scene import Camera, Scene

    sc, eff = floor_wall_scene(), Effect("ao", 1.0, "step")
    (wc, hc), (wf, hf) = crop, full
    fov = math.degrees(2 * math.atan(math.tan(math.radians(sc.camera.fov_y) / 2) * hc / hf))
    cropped = Scene(sc.name, sc.meshes, Camera(sc.camera.origin, sc.camera.target, sc.camera.up, fov))
    params = dict(max_radius_px=16.0)
    r, pos = render_wh(gpu, cropped, eff, wc, hc, **params)
    rf, pos_f = render_wh(gpu, sc, eff, wf, hf, **params)
    assert r.image.shape == (hc, wc, 1) and rf.image.shape == (hf, wf, 1)
    for img, mask in ((r.image, r.mask), (rf.image, rf.mask)):
        assert np.all(img[~mask] == 1.0) and img[mask].min() > 0.0 and mask.mean() > 0.5
    oy, ox = (hf - hc) // 2, (wf - wc) // 2
    assert oy % 64 == 0 and ox % 64 == 0
    assert np.abs(pos_f[oy:oy + hc, ox:ox + wc] - pos).max() < 1e-4  # the same view (measured 1e-6)
    diff = np.abs(rf.image[oy:oy + hc, ox:ox + wc, 0] - r.image[..., 0])
    b = 18
    inner = diff[b:hc - b] if hc < hf else diff[:, b:wc - b]
    assert (inner > 1e-4).mean() <= 0.01, f"{(inner > 1e-4).mean():.1%} of the pixels differ (max {inner.max():.3g})"


def unoccluded_slice_range(pos, camera, n_phi=720):
    """Per pixel of an unoccluded plane (normal world +y), the range over the slice's screen angle φ of
    the slice visibility between tangent-plane horizons, |n_p| (cos γ + γ sin γ), the upper end clamped to 1:
    the mean over any slices lies in it."""
    vm = camera.view_matrix()
    rot, tr = vm[:3, :3], vm[:3, 3]
    P = pos[..., :3].reshape(-1, 3).astype(np.float64) @ rot.T + tr
    v = -P / np.linalg.norm(P, axis=1, keepdims=True)
    n = rot[:, 1]
    lo, hi = np.full(len(P), np.inf), np.full(len(P), -np.inf)
    for j in range(n_phi):
        phi = math.pi * j / n_phi
        d3 = np.array([math.cos(phi), math.sin(phi), 0.0])
        o = d3 - (v @ d3)[:, None] * v
        o /= np.linalg.norm(o, axis=1, keepdims=True)
        nv, no = v @ n, o @ n
        g = np.arctan2(no, np.maximum(nv, 1e-6))
        V = np.hypot(nv, no) * (np.cos(g) + g * np.sin(g))
        lo, hi = np.minimum(lo, V), np.maximum(hi, V)
    return lo.reshape(pos.shape[:2]), np.minimum(hi, 1.0).reshape(pos.shape[:2])


@pytest.mark.parametrize("size", [(128, 64), (64, 128)], ids=["128x64", "64x128"])
def test_non_square_unoccluded_plane_within_the_slice_range(gpu, size):
    """A plane seen from above with a 50° vertical field of view (oblique towards the sides of a wide image):
    with every sample reconstructed on the plane (the plane fit, which needs the principal point and the
    focal length in pixels) the horizons are the tangent plane and each pixel's AO, a mean over its slices,
    lies within the range of the unoccluded slice visibility over the slice angle (no denoise). Bound 1e-4:
    float32 rounding of the samples' plane distance (~1e-6, through acos at |cos γ| > 0.6) and the 720-angle
    grid of the range (≤ 1e-5). Measured: no pixel below its range (closest 1.3e-5 above it); with the
    principal point's coordinates swapped 0.19 below it."""
    from ldbench.core.scene import Camera, Scene

    sc = Scene("plane", [testkit.plane()], Camera((0, 5, 0.001), (0, 0, 0), (0, 0, -1), 50.0))
    r, pos = render_wh(gpu, sc, Effect("ao", math.inf, "step"), *size, denoise_passes=0)
    assert r.image.shape == (size[1], size[0], 1) and r.mask.all()
    lo, hi = unoccluded_slice_range(pos, sc.camera)
    ao = r.image[..., 0]
    assert np.all(ao >= lo - 1e-4) and np.all(ao <= hi + 1e-4), \
        f"AO below the unoccluded range by {np.max(lo - ao):.3g}, above it by {np.max(ao - hi):.3g}"
