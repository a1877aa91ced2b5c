"""Order-independent transparency (yang2010 §4.1): the exact reference against closed forms, the three
adapters (ll-oit, depth-peeling, dual-depth-peeling) against the reference to float precision on small
scenes with intersecting triangles, the tie rule, the first-n-layers variant, overflow, and every kernel
broken once on purpose."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from harness.effects import Effect
from harness.effects.oit import BACKGROUND, composite
from harness.scene import Camera, Mesh, Scene
from harness.scenes import load_scene
from methods.base import View, get_method
from references.oit import intersections, render_oit

METHODS = ("ll-oit", "depth-peeling", "dual-depth-peeling")
TOL = 1e-5  # float precision: measured ≤ 1.2e-7 on llvmpipe for every method and scene here


def tri(p, name, albedo, alpha):
    return Mesh(name, np.array(p, np.float32), np.array([[0, 1, 2]]), albedo, alpha)


def quad(z, x0, x1, y0, y1, name, albedo, alpha):
    v = np.array([[x0, y0, z], [x1, y0, z], [x1, y1, z], [x0, y1, z]], np.float32)
    return Mesh(name, v, np.array([[0, 1, 2], [0, 2, 3]]), albedo, alpha)


def intersecting_scene():
    """Three mutually intersecting semi-transparent triangles in front of an opaque one (no exact ties).
    The camera is placed so that no pixel centre of the W × H image lies within 0.01 px of an edge (the
    raster snaps vertices to 1/256 px; the reference does not)."""
    return Scene("intersecting", [
        tri([[-1, -1, -0.5], [1, -0.8, 0.6], [0, 1, 0.1]], "a", (0.9, 0.1, 0.1), 0.5),
        tri([[-1, 0.9, 0.5], [1, 0.7, -0.6], [0.1, -1, 0.0]], "b", (0.1, 0.8, 0.2), 0.6),
        tri([[-0.9, -0.2, -0.9], [0.9, -0.3, 0.9], [0.9, 0.4, -0.2]], "c", (0.2, 0.3, 0.9), 0.35),
        tri([[-1.2, -1.2, -1.0], [1.2, -1.2, -1.0], [0, 1.3, -1.0]], "back", (0.8, 0.8, 0.7), 1.0)],
        Camera((0.367, 0.2193, 4.0), (0.0, 0.0, 0.0), fov_y=40.0))


TIE_A, TIE_B = ((0.9, 0.2, 0.1), 0.25), ((0.1, 0.9, 0.1), 0.75)


def tie_scene():
    """Two coincident copies of one quad (meshes 1 and 2: different colour and opacity) between an opaque
    back quad and a front quad: the effect's tie rule puts mesh 1 in front."""
    return Scene("ties", [
        quad(0.0, -1.0, 1.0, -1.0, 1.0, "back", (0.2, 0.3, 0.9), 1.0),
        quad(0.5, -0.53, 0.71, -0.61, 0.43, "tie_a", *TIE_A),
        quad(0.5, -0.53, 0.71, -0.61, 0.43, "tie_b", *TIE_B),
        quad(1.0, -0.23, 0.37, -0.31, 0.83, "front", (0.9, 0.9, 0.2), 0.4)],
        Camera((0.11, 0.07, 4.0), (0.0, 0.0, 0.0), fov_y=40.0))


W, H = 40, 32


def stack_scene(n=12):
    """n overlapping quads at distinct depths, listed in shuffled depth order, with distinct colours and
    opacities: lists of 1 … n fragments (the first-n selection and the long-list paths). Their edges
    project onto pixel boundaries of the W × H image, half a pixel from every pixel centre."""
    rng = np.random.default_rng(7)
    zs = rng.permutation(np.linspace(-1.0, 1.0, n))
    t = np.tan(np.radians(35.0) / 2)
    ms = []
    for i, z in enumerate(zs):
        dist = 5.0 - z
        x0, x1, y0, y1 = 1 + 2 * i, W - 1 - (3 * i) % 7, 1 + i, H - 1 - (2 * i) % 5  # pixel boundaries
        X = lambda px: (px / W * 2 - 1) * t * (W / H) * dist  # noqa: E731
        Y = lambda py: (1 - py / H * 2) * t * dist  # noqa: E731
        ms.append(quad(z, X(x0), X(x1), Y(y1), Y(y0), f"q{i}", tuple(rng.uniform(0.05, 0.95, 3)),
                       float(rng.uniform(0.15, 0.6))))
    return Scene("stack", ms, Camera((0.0, 0.0, 5.0), (0.0, 0.0, 0.0), fov_y=35.0))


@pytest.fixture(scope="module")
def scenes():
    return {"intersecting": intersecting_scene(), "teapot": load_scene("teapot", segments=12), "ties": tie_scene(),
            "stack": stack_scene()}


@pytest.fixture(scope="module")
def refs(scenes):
    return {k: render_oit(sc, W, H) for k, sc in scenes.items()}


def run(gpu, scene, method, size=(W, H), method_cls=None, **params):
    cls = method_cls or get_method(method)
    m = cls(cls.Params(**params))
    m.setup(gpu, scene)
    try:
        return m.frame(View(scene.camera, *size), Effect("oit")).resolve()
    finally:
        m.release()


def assert_matches(result, ref, what=""):
    err = np.abs(np.asarray(result.image) - ref.mean).max(axis=2)
    assert err.max() < TOL, f"{what}: max error {err.max():.3g} at {np.unravel_index(err.argmax(), err.shape)}"
    assert np.array_equal(result.mask, ref.mask), f"{what}: coverage differs"


# ---- the reference -----------------------------------------------------------------------------------

def pixel_of(scene, p, w=W, h=H):
    """(row, col) of the pixel whose centre ray passes closest to world point p."""
    o, d = scene.camera.primary_rays(w, h)
    v = np.asarray(p, float) - o[0]
    v /= np.linalg.norm(v)
    return np.unravel_index(int(np.argmax(d @ v)), (h, w))


def test_reference_is_the_closed_form_composite(refs, scenes):
    """Pixels of the tie scene against the formula: front quad, the coincident pair in mesh order (the tie
    rule: both are found, one Mitsuba scene per mesh), the opaque back; background = 1; depth counts."""
    sc, ref = scenes["ties"], refs["ties"]
    col = lambda i: (sc.meshes[i].albedo, sc.meshes[i].opacity)  # noqa: E731
    cases = {(0.0, 0.2, 1.0): [3, 1, 2, 0], (0.5, -0.45, 0.5): [1, 2, 0], (-0.8, 0.8, 0.0): [0]}
    for p, order in cases.items():
        y, x = pixel_of(sc, p)
        want = composite([col(i)[0] for i in order], [col(i)[1] for i in order])
        np.testing.assert_allclose(ref.mean[y, x], want, atol=1e-6, err_msg=str(p))
    y, x = pixel_of(sc, (3.0, 3.0, 0.0))
    assert not ref.mask[y, x] and np.all(ref.mean[y, x] == np.float32(BACKGROUND))
    assert ref.variance.max() == 0 and ref.meta["layers_max"] == 4
    hits = intersections(sc, W, H)
    assert hits.counts()[ref.mask].min() >= 1 and hits.counts().max() == 4


def test_reference_first_n_layers_and_tie_order(scenes):
    """max_layers = n composites the first n; swapping the tied meshes changes the image (order matters)."""
    sc = scenes["ties"]
    y, x = pixel_of(sc, (0.0, 0.2, 1.0))
    one = render_oit(sc, W, H, max_layers=2).mean[y, x]
    m = sc.meshes
    np.testing.assert_allclose(one, composite([m[3].albedo, m[1].albedo], [m[3].opacity, m[1].opacity]), atol=1e-6)
    swapped = Scene("ties", [m[0], m[2], m[1], m[3]], sc.camera)
    assert np.abs(render_oit(swapped, W, H).mean[y, x] - render_oit(sc, W, H).mean[y, x]).max() > 0.05


# ---- the methods against the reference ---------------------------------------------------------------

@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("name", ["intersecting", "teapot", "stack"])
def test_methods_equal_the_exact_reference(gpu, scenes, refs, method, name):
    r = run(gpu, scenes[name], method)
    assert_matches(r, refs[name], f"{method} on {name}")
    c = r.counters
    assert c["depth_complexity_max"] == refs[name].meta["layers_max"]
    assert c["fragments"] == refs[name].meta["fragments"]
    assert c["depth_complexity_mean"] == pytest.approx(refs[name].meta["layers_mean"], rel=1e-6)
    assert r.invariants == []
    if method == "depth-peeling":
        assert c["peel_passes"] == c["layers"] + 1 == refs[name].meta["layers_max"] + 1
        assert c["samples_per_pass"][-1] == 0
    if method == "dual-depth-peeling":  # ⌈L/2⌉ passes peel L layers, and one more finds nothing left
        assert c["peel_passes"] in (-(-c["depth_complexity_max"] // 2), -(-c["depth_complexity_max"] // 2) + 1)


def test_ll_oit_follows_the_tie_rule(gpu, scenes, refs):
    r = run(gpu, scenes["ties"], "ll-oit")
    assert_matches(r, refs["ties"], "ll-oit on coincident surfaces")


def test_peeling_keeps_one_of_coincident_surfaces(gpu, scenes, refs):
    """Documented limitation: to depth peeling coincident surfaces are one layer (the first to arrive, mesh 1
    on llvmpipe), so the result is the reference of the scene without mesh 2; dual peeling merges them."""
    sc = scenes["ties"]
    without = Scene("ties", [m for i, m in enumerate(sc.meshes) if i != 2], sc.camera)
    assert_matches(run(gpu, sc, "depth-peeling"), render_oit(without, W, H), "depth-peeling on ties")
    r = run(gpu, sc, "dual-depth-peeling")
    assert np.abs(r.image - refs["ties"].mean).max() > 0.05


def test_long_lists_take_the_exact_slow_path(gpu, scenes, refs):
    r = run(gpu, scenes["intersecting"], "ll-oit", max_list=1)
    assert_matches(r, refs["intersecting"], "ll-oit max_list=1")
    assert r.counters["slow_path_lists"] > 0
    r = run(gpu, scenes["ties"], "ll-oit", max_list=2)
    assert_matches(r, refs["ties"], "ll-oit max_list=2 on ties")


@pytest.mark.parametrize("method,params", [("ll-oit", {}), ("ll-oit", {"max_list": 4}), ("depth-peeling", {})])
def test_first_n_layers(gpu, scenes, method, params):
    """The first n layers (n = 2: the resolve selects 2 places of lists longer than 8; n = 5: insertion
    sort; max_list = 4: lists longer than 4 take n minimum searches) against the reference's first n."""
    sc = scenes["stack"]
    assert render_oit(sc, W, H).meta["layers_max"] == 12
    for n in (1, 2, 5):
        r = run(gpu, sc, method, max_layers=n, **params)
        assert_matches(r, render_oit(sc, W, H, max_layers=n), f"{method} max_layers={n} {params}")
        assert r.invariants == []


def test_overflow_is_a_degraded_row(tmp_path):
    """A pool too small for the fragments: the row is degraded (the image lacks fragments)."""
    from harness.executors import run_jobs
    from harness.suite import suite_from_dict

    suite = suite_from_dict({"suite": {"size": "24x24", "warmup": 0, "frames": 1},
                             "run": [{"scene": "teapot", "scene_params": {"segments": 8}, "effect": "oit",
                                      "methods": ["ll-oit"],
                                      "params": {"ll-oit": {"pool": "fixed", "pool_capacity": 40}}}]}, name="t")
    df = run_jobs(suite, tmp_path / "run", progress=False, report=False)
    status = df["status"].iloc[0]
    assert status.startswith("degraded") and "not stored (pool overflow)" in status, status
    assert df["psnr"].iloc[0] < 40


def test_effect_declaration():
    e = Effect("oit")
    assert e.key() == {"effect": "oit"} and not e.spec.stochastic(e.params) and not e.needs_light()
    assert {get_method(m).name for m in METHODS} == set(METHODS)
    assert all("oit" in get_method(m).effects for m in METHODS)


# ---- every kernel broken once ------------------------------------------------------------------------

def broken(method: str, tmp_path: Path, file: str, old: str, new: str):
    """An unregistered copy of ``method`` whose ``file`` (its own, or the shared oit.glsl placed beside its
    shaders, which #include finds first) has ``old`` replaced by ``new``."""
    cls = get_method(method)
    folder = Path(__import__(cls.__module__, fromlist=["x"]).__file__).parent
    src_file = folder / file if (folder / file).exists() else Path(__file__).parents[1] / "methods/glsl" / file
    src = src_file.read_text()
    assert old in src, old
    tmp_path.mkdir(parents=True, exist_ok=True)
    (tmp_path / file).write_text(src.replace(old, new))
    for f in folder.glob("*.glsl"):
        if not (tmp_path / f.name).exists():
            (tmp_path / f.name).write_text(f.read_text())

    class Broken(cls):
        name = ""

        def shader(self, name):
            return tmp_path / name

    return Broken


BREAKS = [
    # (method, file, old, new, scene, params)
    ("ll-oit", "oit.glsl", "return za < zb || (za == zb && ma < mb);", "return za < zb;", "ties", {}),
    ("ll-oit", "resolve.glsl", "while (b > 0u && oit_before(za, ma, z[b - 1u], m[b - 1u]))", "while (false)",
     "intersecting", {}),
    ("ll-oit", "resolve.glsl", "T *= 1.0 - a.a;", "T *= a.a;", "intersecting", {}),
    ("ll-oit", "resolve.glsl", "(zi == lz && mi == lm && i > li)", "(zi == lz && mi == lm && i >= li)",
     "ties", {"max_list": 1}),
    ("ll-oit", "resolve.glsl", "if (oit_before(z[b], m[b], z[s], m[s])) s = b;",
     "if (oit_before(z[s], m[s], z[b], m[b])) s = b;", "stack", {"max_layers": 2}),
    ("ll-oit", "resolve.glsl", "for (uint k = 0u; k < layers; ++k) {", "for (uint k = 0u; k < n; ++k) {",
     "stack", {"max_layers": 2, "max_list": 4}),
    ("depth-peeling", "peel.glsl", "k <= depth_step(", "k >= depth_step(", "intersecting", {}),
    ("depth-peeling", "composite.glsl", "out_accum = vec4(c.rgb * c.a, c.a);", "out_accum = vec4(c.rgb, c.a);",
     "intersecting", {}),
    ("depth-peeling", "composite.glsl", "a.rgb + a.a * background", "a.rgb + background", "intersecting", {}),
    ("dual-depth-peeling", "peel.glsl", "front.rgb + T * c.a * c.rgb", "front.rgb + c.a * c.rgb", "intersecting", {}),
    ("dual-depth-peeling", "peel.glsl", "out_back = vec4(c.rgb, c.a + 1.0);", "out_back = vec4(c.rgb, c.a);",
     "intersecting", {}),
    ("dual-depth-peeling", "blend.glsl", "f.rgb + (1.0 - f.a) * b", "f.rgb + b", "intersecting", {}),
    ("dual-depth-peeling", "blend.glsl", "out_color = vec4(c.rgb, c.a - 1.0);", "out_color = vec4(c.rgb, c.a);",
     "intersecting", {}),
]


@pytest.mark.parametrize("method,file,old,new,scene,params", BREAKS,
                         ids=[f"{b[0]}-{b[1]}-{i}" for i, b in enumerate(BREAKS)])
def test_a_broken_kernel_fails(gpu, scenes, refs, tmp_path, method, file, old, new, scene, params):
    ref = refs[scene] if not params.get("max_layers") else render_oit(scenes[scene], W, H, params["max_layers"])
    intact = broken(method, tmp_path / "intact", file, old, old)  # the copying itself changes nothing
    assert_matches(run(gpu, scenes[scene], method, method_cls=intact, **params), ref, f"copied {method}")
    cls = broken(method, tmp_path, file, old, new)
    r = run(gpu, scenes[scene], method, method_cls=cls, **params)
    with pytest.raises(AssertionError):
        assert_matches(r, ref, f"broken {method}")


def test_a_broken_fragment_count_fails(gpu, scenes, refs, tmp_path):
    """dual-depth-peeling's depth-complexity counters come from count.glsl: counting 2 per fragment shows."""
    cls = broken("dual-depth-peeling", tmp_path, "count.glsl", "out_count = 1.0;", "out_count = 2.0;")
    c = run(gpu, scenes["intersecting"], "dual-depth-peeling", method_cls=cls).counters
    assert c["fragments"] == 2 * refs["intersecting"].meta["fragments"]
