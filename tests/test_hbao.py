"""hbao (Bavoil et al. 2008) on llvmpipe: the cosine integral against the Mitsuba reference and a closed
form, the 2008 integral's behaviour, the shader's quadratic falloff and d_max cut-off against closed
forms, checks that a broken horizon search, falloff or cut-off fails, and ``plane_fit`` on a slope (the flag
ignored, or the fit compiled out: ``test_plane_fit_removes_false_occlusion_on_a_slope`` fails).

Closed form used below (a floor point at distance a from a perpendicular wall, step falloff d_max,
wall and floor extending at least d_max around the point): the directions that hit the wall within
d_max are those with ω_x > c = a/d_max (x = towards the wall), and under cosine weighting the
projected directions are uniform on the unit disk (Nusselt), so the occluded fraction is the circular
segment's area over π:  A(a) = 1 − (acos c − c √(1 − c²)) / π  for c < 1, and 1 beyond. For d_max = ∞
and a wall of height H this becomes the familiar form factor A = 1 − ½(1 − a/√(a² + H²)).

With quadratic falloff the wall hit along a direction with projected coordinate x = ω_x lies at
t = a/x, weighted ρ = 1 − (t/d_max)² = 1 − c²/x²; integrating over the segment (chord 2√(1 − x²)):
A(a) = 1 − ((1 + 2c²) acos c − 3c √(1 − c²)) / π  (½ at the foot of the wall, 1 from c = 1 on).
"""
import math
from pathlib import Path

import numpy as np
import pytest

from ldbench.core import metrics as M
from ldbench.core.effects import Effect
from ldbench.core.errors import LdbenchError
from ldbench.core.scene import Camera, Mesh, Scene
from ldbench.methods.base import View, get_method, registry
import ldbench.methods.hbao
from ldbench.methods.hbao import HBAO, HBAOParams

REF_SPP = 256
HBAO_DIR = Path(ldbench.methods.hbao.__file__).resolve().parent


def quad(name, c, u, v, albedo=(0.8, 0.8, 0.8)):
    """Parallelogram with centre c and half-edge vectors u, v (two triangles)."""
    c, u, v = (np.asarray(x, float) for x in (c, u, v))
    verts = np.array([c - u - v, c + u - v, c + u + v, c - u + v])
    return Mesh(name, verts, np.array([[0, 1, 2], [0, 2, 3]]), albedo)


def floor_wall_scene():
    """Floor y = 0 (x ∈ [-4, 1], z ∈ [-3, 3]) meeting a wall x = 1 of height 2, seen obliquely from the
    floor side; with d_max = 1 the wall and floor act as infinite planes for every floor point."""
    floor = quad("floor", (-1.5, 0, 0), (2.5, 0, 0), (0, 0, 3))
    wall = quad("wall", (1, 1, 0), (0, 1, 0), (0, 0, 3))
    cam = Camera((-2.5, 2.2, 0.0), (0.6, 0.3, 0.0), (0, 1, 0), 50.0)
    return Scene("floor-wall", [floor, wall], cam)


def wall_ao(a, d_max):
    c = np.clip(np.asarray(a, float) / d_max, 0.0, 1.0)
    return 1.0 - (np.arccos(c) - c * np.sqrt(1.0 - c * c)) / np.pi


def wall_ao_quadratic(a, d_max):
    c = np.clip(np.asarray(a, float) / d_max, 0.0, 1.0)
    return 1.0 - ((1.0 + 2.0 * c * c) * np.arccos(c) - 3.0 * c * np.sqrt(1.0 - c * c)) / np.pi


def render(gpu, scene, effect, size, method_cls=HBAO, **params):
    m = method_cls(HBAOParams(**params))
    m.setup(gpu, scene)
    gpu.begin_frame()
    r = m.frame(View(scene.camera, size, size), effect).resolve()
    stages, _ = gpu.end_frame()
    pos = m.gbuf.read()[0]
    m.release()
    return r, stages, pos


FLOOR_BINS = (0.0, 0.1, 0.2, 0.4, 0.6, 0.8, 1.2)  # distance a from the wall (bin width 0.05)


def floor_profile(img, pos, exact=lambda a: wall_ao(a, 1.0)):
    """Mean AO of floor pixels (|z| < 1) per distance bin from the wall, beside ``exact`` (the closed
    form; default: step falloff, d_max = 1)."""
    on_floor = (pos[..., 3] > 0.5) & (np.abs(pos[..., 1]) < 1e-4) & (np.abs(pos[..., 2]) < 1.0)
    a = 1.0 - pos[..., 0]
    out = []
    for lo in FLOOR_BINS:
        sel = on_floor & (a >= lo) & (a < lo + 0.05)
        assert sel.sum() > 50
        out.append((float(img[..., 0][sel].mean()), float(exact(a[sel]).mean())))
    return np.array(out)  # (bins, [ours, closed form])


def check_floor_wall(profile, tol=0.017):
    """What a working horizon search must give: darker towards the wall, and the closed form (default
    settings: measured max error 0.0148 on llvmpipe)."""
    ours, exact = profile[:, 0], profile[:, 1]
    assert ours[0] < ours[3] - 0.15 < ours[-1] - 0.3, f"no darkening towards the wall: {ours}"
    assert np.all(np.diff(ours) > -0.01), f"AO not increasing away from the wall: {ours}"
    err = np.abs(ours - exact)
    assert err.max() < tol, f"floor AO {np.round(ours, 3)} vs closed form {np.round(exact, 3)}"


# -------------------------------------------------------------------------------------------------


def test_registered_and_params():
    assert registry()["hbao"] is HBAO
    assert HBAO.paper == "bavoil2008" and HBAO.effects == frozenset({"ao"})
    p = HBAOParams()
    assert (p.directions, p.steps, p.integral, p.blur) == (8, 8, "hbao", True)
    assert p.bias_degrees() == 10.0 and HBAOParams(integral="cosine").bias_degrees() == 0.0
    assert HBAOParams(angle_bias=5, integral="cosine").bias_degrees() == 5.0
    with pytest.raises(LdbenchError, match="integral"):
        HBAOParams(integral="gtao")
    with pytest.raises(LdbenchError, match="directions"):
        HBAOParams.from_dict({"directions": 0}, method="hbao")
    with pytest.raises(LdbenchError, match="unknown parameter"):
        HBAOParams.from_dict({"radius": 3}, method="hbao")


def test_slice_integral_is_cosine_weighted_ao():
    """The GTAO inner integral F used by integral = "cosine": 1/π ∫₀^{2π} |n_p| F(γ + π/2) dφ = 1 for
    any normal facing the viewer (an unoccluded hemisphere), and dF/dθ = sin θ cos(θ − γ)."""
    def F(h, g):
        return 0.25 * (-np.cos(2 * h - g) + np.cos(g) + 2 * h * np.sin(g))

    v = np.array([0.0, 0.0, 1.0])
    phi = (np.arange(4096) + 0.5) / 4096 * 2 * np.pi
    d = np.stack([np.cos(phi), np.sin(phi), 0 * phi], -1)
    o = d - (d @ v)[:, None] * v
    o /= np.linalg.norm(o, axis=1, keepdims=True)
    for alpha in (0.0, 0.4, 1.0, 1.5):
        n = np.array([np.sin(alpha) * 0.6, np.sin(alpha) * 0.8, np.cos(alpha)])
        nv, no = n @ v, o @ n
        g = np.arctan2(no, nv)
        assert np.mean(2 * np.hypot(nv, no) * F(g + np.pi / 2, g)) == pytest.approx(1.0, abs=1e-6)
    th, g, eps = 0.7, 0.3, 1e-6
    assert (F(th + eps, g) - F(th - eps, g)) / (2 * eps) == pytest.approx(np.sin(th) * np.cos(th - g), abs=1e-6)


def test_cornell_small_dmax_cosine_matches_reference(gpu):
    """cornell, d_max = 5 % of the scene diagonal, 256², against Mitsuba (data range 1). Thresholds just
    below what llvmpipe measures: cosine integral 32.35 dB / SSIM 0.9733, 2008 integral 28.28 dB /
    SSIM 0.9577 (part of the error sits on reference pixels exactly on the box's creases)."""
    from ldbench.core.scenes import load_scene
    from ldbench.references import render_reference

    sc = load_scene("cornell")
    eff = Effect("ao", round(0.05 * sc.diagonal(), 4), "step")
    size = 256
    ref = render_reference(sc, eff, width=size, height=size, spp=REF_SPP, progress=False)
    scores = {}
    for integral in ("cosine", "hbao"):
        r, stages, _ = render(gpu, sc, eff, size, integral=integral)
        assert set(stages) == {"gbuffer", "deinterleave", "hbao", "blur"}
        img = r.image
        assert img.shape == (size, size, 1) and img.dtype == np.float32
        assert np.array_equal(r.mask, ref.mask)
        assert np.all(img[~r.mask] == 1.0)
        assert 0.0 <= img.min() and img.max() <= 1.0
        assert sum(r.memory_bytes.values()) > 0
        scores[integral] = (M.psnr(img, ref.mean, mask=ref.mask, data_range=1.0),
                            M.ssim(img, ref.mean, mask=ref.mask, data_range=1.0))
    print(f"\ncornell {eff.label()} {size}² ref spp {REF_SPP}: "
          + ", ".join(f"{k}: PSNR {p:.2f} dB SSIM {s:.4f}" for k, (p, s) in scores.items()))
    assert scores["cosine"][0] >= 32.0, scores
    assert scores["cosine"][1] >= 0.97, scores
    assert scores["hbao"][0] >= 28.0, scores
    assert scores["hbao"][1] >= 0.95, scores


def test_floor_near_wall_cosine_matches_closed_form_and_reference(gpu):
    from ldbench.references import render_reference

    sc = floor_wall_scene()
    eff = Effect("ao", 1.0, "step")
    size = 192
    r, _, pos = render(gpu, sc, eff, size, integral="cosine")
    prof = floor_profile(r.image, pos)
    check_floor_wall(prof)
    # the closed form is the reference's value too (checks the closed form, not only us)
    ref = render_reference(sc, eff, width=size, height=size, spp=REF_SPP, progress=False)
    ref_prof = floor_profile(ref.mean, pos)
    assert np.abs(ref_prof[:, 0] - ref_prof[:, 1]).max() < 0.006  # measured 0.0041
    assert M.psnr(r.image, ref.mean, mask=ref.mask, data_range=1.0) > 31.5  # measured 31.79 dB


def test_floor_near_wall_which_integral_matches(gpu):
    """Same floor, fine sampling (32 steps, no bias, no blur) so that what remains is the integral:
    the cosine integral converges to the closed form, the 2008 formula does not. At the foot of the
    wall both give ½ (a half-space occludes half the hemisphere in either measure), but farther out
    the 2008 formula (uniform solid-angle measure about the view vector) over-weights the low
    directions towards the wall and reads darker; seen from straight above it would give
    (1 + a/d_max)/2 instead of the cosine-weighted closed form."""
    sc = floor_wall_scene()
    eff = Effect("ao", 1.0, "step")
    fine = dict(steps=32, angle_bias=0.0, blur=False)
    r, _, pos = render(gpu, sc, eff, 192, integral="cosine", **fine)
    cos_prof = floor_profile(r.image, pos)
    r, _, pos = render(gpu, sc, eff, 192, integral="hbao", **fine)
    hb_prof = floor_profile(r.image, pos)
    exact = cos_prof[:, 1]
    # measured on llvmpipe: cosine within 0.0046 of the closed form, 2008 formula 0.0017 at the foot and
    # 0.029 or more below it at a = 0.4 .. 0.85
    assert np.abs(cos_prof[:, 0] - exact).max() < 0.006, cos_prof
    assert abs(hb_prof[0, 0] - exact[0]) < 0.005, hb_prof
    mid = slice(3, 6)  # a = 0.4 .. 0.85
    assert np.all(hb_prof[mid, 0] < exact[mid] - 0.025), (hb_prof, exact)
    assert hb_prof[0, 0] < hb_prof[3, 0] - 0.1 < hb_prof[-1, 0] - 0.2  # still darkens towards the wall


def broken_hbao(tmp_path, *edits):
    """An unregistered HBAO whose shaders (copied to ``tmp_path``, includes and all) have each (old, new) text
    replaced; each ``old`` must occur in exactly one of them."""
    src = {f.name: f.read_text() for f in HBAO_DIR.glob("*.glsl")}
    for old, new in edits:
        where = [k for k, text in src.items() if old in text]
        assert len(where) == 1, (old, where)
        src[where[0]] = src[where[0]].replace(old, new)
    for name, text in src.items():
        (tmp_path / name).write_text(text)

    class Broken(HBAO):
        name = ""  # not registered

        def shader(self, name):
            return tmp_path / name

    return Broken


def test_broken_horizon_search_fails(gpu, tmp_path):
    """The floor/wall check has teeth: with the horizon never updated it fails."""
    Broken = broken_hbao(tmp_path, ("theta_h = theta;", ""), ("f_h = f;", ""))
    sc = floor_wall_scene()
    r, _, pos = render(gpu, sc, Effect("ao", 1.0, "step"), 192, method_cls=Broken, integral="cosine")
    with pytest.raises(AssertionError):
        check_floor_wall(floor_profile(r.image, pos))


# The shader's falloff, checked on the floor/wall closed forms (module docstring): fine sampling and
# no blur or bias, so that what remains is the integral with its weights ρ(r) and its cut-off r < d_max.
FINE = dict(integral="cosine", steps=32, angle_bias=0.0, blur=False)
RHO_IS_ONE = ("if (falloff_mode == 1) return 1.0 - r2 / (d_max * d_max);", "return 1.0;")
NO_CUT_OFF = ("if (r2 >= d2max || r2 <= 0.0) continue;", "if (r2 <= 0.0) continue;")


def check_quadratic_falloff(gpu, method_cls=HBAO):
    """Quadratic falloff, d_max = 1: the floor profile matches the closed form to 0.006 (measured
    0.0038 on llvmpipe; ρ forced to 1 gives 0.11, the step profile)."""
    r, _, pos = render(gpu, floor_wall_scene(), Effect("ao", 1.0, "quadratic"), 192, method_cls=method_cls, **FINE)
    prof = floor_profile(r.image, pos, exact=lambda a: wall_ao_quadratic(a, 1.0))
    err = np.abs(prof[:, 0] - prof[:, 1])
    assert err.max() < 0.006, f"floor AO {np.round(prof[:, 0], 3)} vs closed form {np.round(prof[:, 1], 3)}"


# Seen from low over the floor the wall is foreshortened: floor points up to a few d_max from it still
# reach it within the screen radius (d_max projected at their depth), so only the shader's 3D test
# r < d_max keeps it out.
LOW_OVER_FLOOR = Camera((-2.5, 0.8, 0.0), (1.0, 0.6, 0.0), (0, 1, 0), 50.0)


def check_cut_off(gpu, method_cls=HBAO):
    """Step falloff, d_max = 0.3: every floor point farther than d_max from the wall is unoccluded,
    exactly (measured: all 4864 such pixels at 1.0; without the cut-off 28 % of them drop to 0.95)."""
    sc = floor_wall_scene()
    sc = Scene(sc.name, sc.meshes, LOW_OVER_FLOOR)
    d_max = 0.3
    r, _, pos = render(gpu, sc, Effect("ao", d_max, "step"), 128, method_cls=method_cls, **FINE)
    floor = (pos[..., 3] > 0.5) & (np.abs(pos[..., 1]) < 1e-4) & (np.abs(pos[..., 2]) < 1.5)
    a = 1.0 - pos[..., 0]
    beyond, near = floor & (a > d_max + 0.005), floor & (a < 0.8 * d_max)
    assert beyond.sum() > 3000 and near.sum() > 200
    ao = r.image[..., 0]
    assert ao[beyond].min() >= 1.0 - 1e-5, f"{(ao[beyond] < 1 - 1e-5).mean():.1%} occluded beyond d_max"
    assert ao[near].mean() < 0.85  # the wall does occlude within d_max (measured 0.78)


def test_quadratic_falloff_in_the_shader(gpu):
    check_quadratic_falloff(gpu)


def test_nothing_beyond_d_max_occludes(gpu):
    check_cut_off(gpu)


@pytest.mark.parametrize("edit, check", [(RHO_IS_ONE, check_quadratic_falloff), (NO_CUT_OFF, check_cut_off)],
                         ids=["rho-forced-to-1", "no-d_max-cut-off"])
def test_broken_falloff_fails(gpu, tmp_path, edit, check):
    """The two falloff checks have teeth: ρ forced to 1, or samples beyond d_max accepted, fail them."""
    broken = broken_hbao(tmp_path, edit)
    with pytest.raises(AssertionError, match="closed form|beyond d_max"):
        check(gpu, broken)


def test_falloff_semantics(gpu):
    """quadratic ≥ step pointwise (ρ_quad ≤ ρ_step on the same horizons); larger d_max → darker;
    d_max = ∞ uses the pixel-radius clamp and is the darkest."""
    sc = floor_wall_scene()
    size = 96
    imgs = {}
    for d, fo in ((0.3, "step"), (0.3, "quadratic"), (1.0, "step"), (math.inf, "step")):
        r, _, _ = render(gpu, sc, Effect("ao", d, fo), size, integral="cosine")
        imgs[(d, fo)] = r.image
    assert np.all(imgs[(0.3, "quadratic")] >= imgs[(0.3, "step")] - 1e-5)
    means = [imgs[k].mean() for k in ((0.3, "step"), (1.0, "step"), (math.inf, "step"))]
    assert means[0] > means[1] > means[2], means


def test_rejects_other_effects(gpu):
    sc = floor_wall_scene()
    m = get_method("hbao")()
    m.setup(gpu, sc)
    with pytest.raises(LdbenchError, match="effect"):
        m.frame(View(sc.camera, 16, 16), Effect("direct"))
    m.release()


def test_suite_file_parses():
    from ldbench.harness.suite import load_suite

    s = load_suite(Path(__file__).resolve().parents[1] / "suites" / "aalund2015-ao.toml")
    methods = {get_method(j.method).name for j in s.jobs}  # registered names (the suite may use aliases)
    assert {"hbao", get_method("ldm-ao").name} <= methods
    assert {j.scene for j in s.jobs} == {"cornell", "atrium"}
    assert any(math.isinf(j.effect.d_max) for j in s.jobs)


def test_plane_fit_removes_false_occlusion_on_a_slope(gpu):
    """A lone plane sloped 35° (nothing occludes it; AO = 1 everywhere), the 2008 integral without angle bias
    or blur: with ``plane_fit`` the samples sit on their tangent planes at the exact sample positions, and
    18 % of the pixels still read below 0.99 (measured: the marching's own residue); without it a
    sample's point off the marching line reads as occlusion on 49 % of them."""
    a = math.radians(35.0)
    plane = quad("slope", (0, 0, 0), (3, 0, 0), (0, 3 * math.sin(a), 3 * math.cos(a)))
    sc = Scene("slope", [plane], Camera((0.3, 2.5, 4.0), (0, 0, 0), (0, 1, 0), 45.0))
    dark = {}
    for fit in (True, False):
        r, _, _ = render(gpu, sc, Effect("ao", 1.0, "step"), 96, integral="hbao", angle_bias=0.0, blur=False,
                         plane_fit=fit)
        ao = np.asarray(r.image)[..., 0][r.mask]
        dark[fit] = float(np.mean(ao < 0.99))
    assert dark[True] < 0.19 and dark[False] > 0.45, dark


def _mean_samples(gpu, d_max, method_cls=HBAO, size=96, **params):
    """Mean samples marched per floor/wall pixel (the kernel's COUNT_STEPS output) at one d_max."""
    sc = floor_wall_scene()
    m = method_cls(HBAOParams(blur=False, **params))
    m.setup(gpu, sc)
    counts = m.sample_counts(View(sc.camera, size, size), Effect("ao", d_max, "quadratic"))
    pos = m.gbuf.read()[0]
    m.release()
    return float(counts[pos[..., 3] > 0.5].mean())


PIXEL_STEP = dict(sampling="pixel_step", step_px=2.0, steps=4096, max_radius_px=4096.0)


def check_pixel_step_follows_d_max(gpu, method_cls=HBAO):
    """pixel_step: the samples follow the projected radius (one per 2 px), so they grow with d_max
    (measured 8.3 / 51.1 / 152.4 samples per pixel at d_max 0.1 / 0.5 / 2 on a 96² image, 8 directions);
    fixed: min(8, radius) per direction, flat once the radius passes 8 px (measured 20.1 / 60.2 / 60.2)."""
    px = [_mean_samples(gpu, d, method_cls, **PIXEL_STEP) for d in (0.1, 0.5, 2.0)]
    assert px[0] * 5 < px[1] and px[1] * 2.5 < px[2], px
    fixed = [_mean_samples(gpu, d, method_cls) for d in (0.5, 2.0)]
    assert fixed[1] <= 64.0 and fixed[1] - fixed[0] < 1.0, fixed
    assert px[2] > 2 * fixed[1], (px, fixed)


def test_pixel_step_sample_count_grows_with_d_max(gpu):
    check_pixel_step_follows_d_max(gpu)


def test_pixel_step_sampling_mutation_fails(gpu, tmp_path):
    """With the step count not following the radius (pixel_step ignored), the check fails."""
    broken = broken_hbao(tmp_path, ("min(steps, int(radius_i / step_px))", "min(8, int(radius_i))"))
    with pytest.raises(AssertionError):
        check_pixel_step_follows_d_max(gpu, broken)


def test_pixel_step_ao_matches_the_closed_form(gpu):
    """The pixel-step marcher still computes the same integral: the floor/wall profile matches the closed
    form (step falloff, d_max = 1, cosine integral; measured max error 0.0092 on llvmpipe)."""
    r, _, pos = render(gpu, floor_wall_scene(), Effect("ao", 1.0, "step"), 192, integral="cosine",
                       **{**PIXEL_STEP, "steps": 64})
    check_floor_wall(floor_profile(r.image, pos), tol=0.012)


def check_bias_only_removes_occlusion(gpu, method_cls=HBAO):
    """The 2008 integral starts each direction's horizon at sin(min(t + bias, pi/2)), which never falls as the
    bias grows, and a higher start only shrinks the running-max increments: AO is non-decreasing in
    angle_bias at every pixel (same noise, no blur). Past t + bias = pi/2 the start must stay at 1: without
    that clamp it falls again and the largest bias darkens sloped surfaces (cornell's floor and boxes seen
    from its camera reach t > 30 degrees). Tolerance 1e-5: float rounding."""
    from ldbench.core.scenes import load_scene

    sc = load_scene("cornell")
    eff = Effect("ao", 0.5, "step")
    imgs = [render(gpu, sc, eff, 96, method_cls, integral="hbao", angle_bias=b, blur=False)[0].image[..., 0]
            for b in (0.0, 20.0, 40.0, 60.0)]
    for lo, hi in zip(imgs, imgs[1:]):
        assert np.all(hi >= lo - 1e-5), f"a larger angle bias darkens {(hi < lo - 1e-5).sum()} pixels"


def test_angle_bias_only_removes_occlusion(gpu):
    check_bias_only_removes_occlusion(gpu)


def test_an_unclamped_horizon_start_fails(gpu, tmp_path):
    broken = broken_hbao(tmp_path, ("sin_t >= cos_bias ? 1.0 : ", ""))
    with pytest.raises(AssertionError, match="darkens"):
        check_bias_only_removes_occlusion(gpu, broken)


def blur_numpy(ao, pos, nrm, eye, radius, sharpness):
    """The blur's definition (blur.glsl's header), both axes (x then y, rows top-down), in float64: an
    independent check."""
    h, w = ao.shape
    hit = pos[..., 3] > 0.5
    ys, xs = np.nonzero(hit)
    inv_tol = sharpness / np.maximum(np.linalg.norm(pos[ys, xs, :3] - eye, axis=-1), 1e-20)
    k = 1.0 / (2.0 * (0.5 * (radius + 1)) ** 2)
    img = ao.astype(np.float64)
    for ax, ay in ((1, 0), (0, -1)):  # the second pass runs along GL's +y, which is up: -1 in top-down rows
        acc, wsum = img[ys, xs].copy(), np.ones(len(ys))
        for i in range(-radius, radius + 1):
            if i == 0:
                continue
            qy, qx = ys + ay * i, xs + ax * i
            ok = (qy >= 0) & (qy < h) & (qx >= 0) & (qx < w)
            ok[ok] &= hit[qy[ok], qx[ok]]
            e = np.einsum("ij,ij->i", pos[qy[ok], qx[ok], :3] - pos[ys[ok], xs[ok], :3], nrm[ys[ok], xs[ok], :3])
            wt = np.exp(-i * i * k - (e * inv_tol[ok]) ** 2)
            acc[ok] += wt * img[qy[ok], qx[ok]]
            wsum[ok] += wt
        img = img.copy()
        img[ys, xs] = np.clip(acc / wsum, 0.0, 1.0)
    return img


def check_blur_definition(gpu, method_cls=HBAO):
    """The blurred image is the numpy blur of the unblurred one over the G-buffer, on cornell at 100 × 77
    (partial workgroups at two borders) for blur radii 2 (the default) and 11: within 1e-5 (float32 against float64, exp of arguments of a few units; measured
    3.2e-7 on llvmpipe)."""
    from ldbench.core.scenes import load_scene

    sc, eff = load_scene("cornell"), Effect("ao", 0.35, "step")
    for radius in (2, 11):
        out = {}
        for blur in (False, True):
            m = method_cls(HBAOParams(blur=blur, blur_radius=radius))
            m.setup(gpu, sc)
            out[blur] = m.frame(View(sc.camera, 100, 77), eff).resolve().image[..., 0]
            pos, nrm, _ = m.gbuf.read()
            m.release()
        want = blur_numpy(out[False], pos, nrm, np.array(sc.camera.origin, np.float64), radius,
                          HBAOParams().blur_sharpness)
        d = np.abs(out[True] - want).max()
        assert d < 1e-5, f"radius {radius}: the blur differs from its definition by {d:.3g}"


def test_blur_is_its_definition(gpu):
    check_blur_definition(gpu)


@pytest.mark.parametrize("edit", [("ivec2 q = p + axis * i;", "ivec2 q = p + axis * (i + 1);"),
                                  ("float w = exp(-float(i * i) * k - e * e);", "float w = exp(-float(i * i) * k);")],
                         ids=["shifted-taps", "no-edge-term"])
def test_a_broken_blur_fails(gpu, tmp_path, edit):
    with pytest.raises(AssertionError, match="definition"):
        check_blur_definition(gpu, broken_hbao(tmp_path, edit))
