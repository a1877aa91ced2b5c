"""gtao (Jimenez et al. 2016) on llvmpipe: the analytic slice integral against closed forms (an
unoccluded plane, a floor beside a wall), the d_max cut-off, the fall-off order, the denoise, the
Mitsuba reference on cornell, and checks that a broken slice integral, cut-off or denoise fails.

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
from test_hbao import LOW_OVER_FLOOR, floor_profile, floor_wall_scene
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
    assert (p.slices, p.steps, p.distribution, p.falloff_range, p.thin_occluder, p.denoise_passes) == \
        (3, 3, 2.0, 0.615, 0.0, 1)  # XeGTAO's "High" preset and defaults
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
    noise by more than half (measured 0.00808 -> 0.00103) and keeps the floor profile within 0.02 (measured
    0.0180, in the bin at the wall's foot, where the plane-distance edge test lets the wall blend in)."""
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
    broken = broken_gtao(tmp_path, "denoise.glsl", ("sum += w * texelFetch(in_ao, q, 0).r;", "sum += w * c;"))
    with pytest.raises(AssertionError, match="denoise"):
        check_denoise(gpu, broken)


def test_cornell_small_dmax_against_reference(gpu):
    """cornell, d_max = 5 % of the diagonal, 256², against Mitsuba (256 spp): the published "High" preset
    (3 × 3 samples per side, fade, one denoise) 20.66 dB; without the fade 24.30 dB; 9 slices × 32 steps
    without the fade 34.00 dB (measured on llvmpipe): sampling, not the integral, limits the preset."""
    from ldbench.core.scenes import load_scene
    from ldbench.references import render_reference

    sc = load_scene("cornell")
    eff = Effect("ao", round(0.05 * sc.diagonal(), 4), "step")
    size = 256
    ref = render_reference(sc, eff, width=size, height=size, spp=256, progress=False)
    got = {}
    for key, kw in (("high", {}), ("no-fade", dict(falloff_range=0.0)),
                    ("fine", dict(falloff_range=0.0, slices=9, steps=32))):
        r, _, _ = render(gpu, sc, eff, size, **kw)
        assert np.array_equal(r.mask, ref.mask) and np.all(r.image[~r.mask] == 1.0)
        got[key] = M.psnr(r.image, ref.mean, mask=ref.mask, data_range=1.0)
    assert got["high"] > 20.6 and got["no-fade"] > 24.25 and got["fine"] > 33.95, got


def test_rejects_other_effects(gpu):
    sc = floor_wall_scene()
    m = get_method("gtao")()
    m.setup(gpu, sc)
    with pytest.raises(LdbenchError, match="effect"):
        m.frame(View(sc.camera, 16, 16), Effect("direct"))
    m.release()
