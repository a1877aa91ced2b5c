"""The approximate OIT baselines on llvmpipe: ``wboit`` (McGuire & Bavoil 2013) exact where its weighted
average is (one colour and one opacity per pixel) and within its measured error elsewhere; ``mlab`` (Salvi
& Vaidyanathan 2014) exact while k ≥ the depth complexity and, below it, equal to an independent numpy model
of its merge rule fed the fragments in primitive order (the order llvmpipe's raster keeps per pixel); every
weight function and sync mode; each kernel broken once on purpose."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import ldbench.methods.mlab
import ldbench.methods.wboit
from ldbench.core.effects.oit import BACKGROUND
from ldbench.core.errors import LdbenchError
from ldbench.core.scene import Camera, Scene
from ldbench.core.scenes import load_scene
from ldbench.methods.base import registry
from ldbench.references.oit import intersections, render_oit
from test_oit import W, H, intersecting_scene, quad, run, stack_scene, tie_scene

EXACT = 1e-5  # float precision (measured ≤ 1.2e-7)


def uniform_stack(n=6, albedo=(0.3, 0.6, 0.9), alpha=0.35):
    """n overlapping quads of one colour and one opacity at distinct depths (wboit is exact here)."""
    sc = stack_scene(n)
    meshes = [type(m)(m.name, m.vertices, m.faces, albedo, alpha) for m in sc.meshes]
    return Scene("uniform-stack", meshes, sc.camera)


def max_err(result, ref):
    return float(np.abs(np.asarray(result.image) - ref.mean).max())


def broken(cls, folder: Path, tmp_path: Path, file: str, old: str, new: str):
    src = (folder / file).read_text()
    assert old in src, old
    (tmp_path / file).write_text(src.replace(old, new))

    class Broken(cls):
        name = ""  # not registered

        def shader(self, name):
            return tmp_path / name if name == file else folder / name

    return Broken


WB_DIR = Path(ldbench.methods.wboit.__file__).resolve().parent
ML_DIR = Path(ldbench.methods.mlab.__file__).resolve().parent


def test_registered():
    reg = registry()
    assert reg["wboit"].effects == reg["mlab"].effects == frozenset({"oit"})
    with pytest.raises(LdbenchError, match="weight"):
        reg["wboit"].Params(weight="eq11")
    with pytest.raises(LdbenchError, match="k"):
        reg["mlab"].Params(k=0)


# ---- wboit -------------------------------------------------------------------------------------------

@pytest.mark.parametrize("weight", ["eq7", "eq8", "eq9", "eq10", "constant"])
def test_wboit_exact_for_one_colour_and_opacity(gpu, weight):
    sc = uniform_stack()
    ref = render_oit(sc, W, H)
    r = run(gpu, sc, "wboit", weight=weight)
    assert np.array_equal(r.mask, ref.mask)
    assert max_err(r, ref) < EXACT
    assert r.counters["depth_complexity_max"] == 6 and r.counters["weight"] == weight


def check_wboit_bound(gpu, method_cls=None):
    """Distinct colours and opacities: the weights stand in for the order, within the error measured on
    llvmpipe (max abs error: intersecting 0.260, stack 0.167; PSNR 19.10 / 25.05 dB for eq7) — and not
    exactly: the weights do matter (eq7 and constant differ)."""
    from ldbench.core import metrics as M

    got = {}
    for name, sc, bound, db in (("intersecting", intersecting_scene(), 0.27, 19.0),
                                ("stack", stack_scene(), 0.175, 24.9)):
        ref = render_oit(sc, W, H)
        r = run(gpu, sc, "wboit", method_cls=method_cls)
        psnr = M.psnr(r.image, ref.mean, mask=ref.mask, data_range=1.0)
        assert max_err(r, ref) < bound and psnr > db, (name, max_err(r, ref), psnr)
        got[name] = r.image
    return got


def test_wboit_within_its_measured_error(gpu):
    eq7 = check_wboit_bound(gpu)
    const = run(gpu, stack_scene(), "wboit", weight="constant").image
    assert np.abs(const - eq7["stack"]).max() > 0.01


def wboit_model(scene, weight: str) -> np.ndarray:
    """Weighted blended OIT in numpy from the exact intersections: z = the linear view depth of each hit
    (distance × cos of the ray to the view axis), w = the paper's eq. 7 or 1, then the resolve."""
    hits = intersections(scene, W, H)
    _, d = scene.camera.primary_rays(W, H)
    fwd = scene.camera.basis()[2]
    z = hits.depth * (d[hits.pixel] @ fwd)
    albedo = np.array([m.albedo for m in scene.meshes], np.float64)[hits.mesh]
    a = np.array([m.opacity for m in scene.meshes], np.float64)[hits.mesh]
    w = a * np.clip(10.0 / (1e-5 + (z / 5) ** 2 + (z / 200) ** 6), 1e-2, 3e3) if weight == "eq7" else np.ones_like(a)
    n = W * H
    acc = np.stack([np.bincount(hits.pixel, albedo[:, c] * a * w, n) for c in range(3)], -1)
    acc_a = np.bincount(hits.pixel, a * w, n)
    with np.errstate(divide="ignore"):  # an opaque fragment: log 0 = -inf, its revealage 0
        R = np.exp(np.bincount(hits.pixel, np.log1p(-a), n))
    C = acc / np.clip(acc_a, 1e-4, 5e4)[:, None] * (1 - R)[:, None] + R[:, None] * np.asarray(BACKGROUND)
    C[np.bincount(hits.pixel, minlength=n) == 0] = BACKGROUND
    return C.reshape(H, W, 3)


def check_wboit_model(gpu, method_cls=None):
    """The GPU result equals the numpy model of the paper's formula (measured max difference 2.4e-7)."""
    for weight in ("eq7", "constant"):
        for sc in (intersecting_scene(), stack_scene()):
            r = run(gpu, sc, "wboit", method_cls=method_cls, weight=weight)
            err = np.abs(np.asarray(r.image) - wboit_model(sc, weight)).max()
            assert err < EXACT, f"{weight} on {sc.name}: GPU differs from the WBOIT model by {err:.3g}"


def test_wboit_equals_the_model(gpu):
    check_wboit_model(gpu)


@pytest.mark.parametrize("old, new", [
    ("out_reveal = vec4(-log(max(1.0 - a, 1e-30)), 1.0, 0.0, 0.0);",
     "out_reveal = vec4(a, 1.0, 0.0, 0.0);"),                                        # revealage not a product
    ("out_accum = vec4(m.rgb * a * w, a * w);", "out_accum = vec4(m.rgb * w, w);"),  # colour weighted twice by a
    ("pow(z / 5.0, 2.0)", "pow(z / 5.0, 3.0)"),                                      # eq. 7 mistyped
])
def test_wboit_broken_accumulation_fails(gpu, tmp_path, old, new):
    from ldbench.methods.wboit import WBOIT

    with pytest.raises(AssertionError, match="model"):
        check_wboit_model(gpu, broken(WBOIT, WB_DIR, tmp_path, "accumulate.glsl", old, new))


def test_wboit_broken_resolve_fails(gpu, tmp_path):
    from ldbench.methods.wboit import WBOIT

    Broken = broken(WBOIT, WB_DIR, tmp_path, "resolve.glsl", "float R = exp(-rv.r);", "float R = exp(-0.5 * rv.r);")
    ref = render_oit(uniform_stack(), W, H)
    assert max_err(run(gpu, uniform_stack(), "wboit", method_cls=Broken), ref) > EXACT


# ---- mlab --------------------------------------------------------------------------------------------

def mlab_model(scene, k: int) -> np.ndarray:
    """MLAB in numpy, independent of the shader: per pixel, the fragments (from the exact intersections) in
    primitive order (mesh order; within a mesh a pixel has at most one fragment here), each inserted in
    (depth, material) order into a list of at most k layers (C, T), the two farthest merged when it holds
    k + 1; then composited over the background."""
    hits = intersections(scene, W, H)
    albedo = np.array([m.albedo for m in scene.meshes], np.float64)
    alpha = np.array([m.opacity for m in scene.meshes], np.float64)
    out = np.tile(np.asarray(BACKGROUND, np.float64), (H * W, 1))
    for px in np.unique(hits.pixel):
        sel = np.flatnonzero(hits.pixel == px)
        sel = sel[np.argsort(hits.mesh[sel], kind="stable")]  # arrival: primitive (mesh) order
        layers = []  # (depth, material, C, T)
        for i in sel:
            m = int(hits.mesh[i])
            f = (float(hits.depth[i]), m, albedo[m] * alpha[m], 1.0 - alpha[m])
            j = len(layers)
            while j > 0 and (f[0], f[1]) < (layers[j - 1][0], layers[j - 1][1]):
                j -= 1
            layers.insert(j, f)
            if len(layers) > k:
                a, b = layers[k - 1], layers[k]
                layers[k - 1:] = [(a[0], a[1], a[2] + a[3] * b[2], a[3] * b[3])]
        C, T = np.zeros(3), 1.0
        for _, _, c, t in layers:
            C, T = C + T * c, T * t
        out[px] = C + T * np.asarray(BACKGROUND)
    return out.reshape(H, W, 3)


@pytest.mark.parametrize("name", ["intersecting", "stack", "ties"])
def test_mlab_exact_when_k_covers_the_depth_complexity(gpu, name):
    sc = {"intersecting": intersecting_scene(), "stack": stack_scene(), "ties": tie_scene()}[name]
    ref = render_oit(sc, W, H)
    r = run(gpu, sc, "mlab", k=16)
    assert np.array_equal(r.mask, ref.mask)
    assert max_err(r, ref) < EXACT
    assert r.counters["merges"] == 0 and r.counters["lost"] == 0
    assert r.counters["layers_stored"] == r.counters["fragments"]


def check_mlab_model(gpu, method_cls=None, ks=(1, 2, 3)):
    """Fewer layers than fragments: the GPU result is the model's, to float precision (measured ≤ 1.2e-7)
    — and the merges really happen (the exact composite differs)."""
    sc = stack_scene()
    ref = render_oit(sc, W, H)
    for k in ks:
        r = run(gpu, sc, "mlab", method_cls=method_cls, k=k)
        model = mlab_model(sc, k)
        err = np.abs(np.asarray(r.image) - model).max()
        assert err < EXACT, f"k={k}: GPU differs from the MLAB model by {err:.3g}"
        assert r.counters["merges"] > 0 and max_err(r, ref) > 0.01
        assert r.counters["depth_complexity_max"] == k


def test_mlab_compression_follows_the_merge_rule(gpu):
    check_mlab_model(gpu)


@pytest.mark.parametrize("old, new", [
    ("L[K - 1] = vec4(a.rgb + a.a * b.rgb, a.a * b.a);", "L[K - 1] = vec4(a.rgb + b.rgb, a.a * b.a);"),
    ("L[K - 1] = vec4(a.rgb + a.a * b.rgb, a.a * b.a);", "L[K - 1] = vec4(a.rgb + a.a * b.rgb, a.a);"),
    ("while (j > 0u && oit_before(", "while (false && oit_before("),
])
def test_mlab_broken_insert_fails(gpu, tmp_path, old, new):
    from ldbench.methods.mlab import MLAB

    Broken = broken(MLAB, ML_DIR, tmp_path, "insert.glsl", old, new)
    with pytest.raises(AssertionError):
        check_mlab_model(gpu, Broken, ks=(2,))
        r = run(gpu, stack_scene(), "mlab", method_cls=Broken, k=16)
        assert max_err(r, render_oit(stack_scene(), W, H)) < EXACT


def test_mlab_sync_modes(gpu):
    """spinlock runs on any GL 4.3; interlock needs GL_ARB_fragment_shader_interlock and otherwise is one
    clear error; auto picks interlock where it exists."""
    sc = intersecting_scene()
    has = "GL_ARB_fragment_shader_interlock" in gpu.ctx.extensions
    assert run(gpu, sc, "mlab", k=2, sync="spinlock").counters["sync"] == "spinlock"
    assert run(gpu, sc, "mlab", k=2).counters["sync"] == ("interlock" if has else "spinlock")
    if has:
        ref = render_oit(sc, W, H)
        assert max_err(run(gpu, sc, "mlab", k=16, sync="interlock"), ref) < EXACT
    else:
        with pytest.raises(LdbenchError, match="interlock"):
            run(gpu, sc, "mlab", sync="interlock")


INTERLOCK = "GL_ARB_fragment_shader_interlock"


def mlab_frames(gpu, cls, k: int, sync: str, n: int = 3):
    """n frames of one instance on the 12-quad stack: [(image, per-pixel stored layers (H·W, k, 4) with
    row 0 at the bottom, per-pixel counts)]; the runner's warm-up and measured frames reuse one instance."""
    from ldbench.core.effects import Effect
    from ldbench.methods.base import View

    sc = stack_scene()
    m = cls(cls.Params(k=k, sync=sync))
    m.setup(gpu, sc)
    out = []
    try:
        for _ in range(n):
            r = m.frame(View(sc.camera, W, H), Effect("oit")).resolve()
            layers = np.frombuffer(gpu.read(m.layers), np.float32).reshape(H * W, k, 4)
            counts = np.frombuffer(gpu.read(m.counts), np.uint32)
            out.append((np.asarray(r.image), layers.copy(), counts.copy(), r.counters))
    finally:
        m.release()
    return out


def check_mlab_frames_repeat(gpu, method_cls=None, k=16, sync="spinlock"):
    """Each frame starts from empty k-buffers: the second and third frames of one instance equal the first,
    bit for bit, wherever the merge order cannot matter: k ≥ the depth complexity (12 here) under the spin
    lock, any k under the ordered interlock."""
    from ldbench.methods.mlab import MLAB

    imgs = [f[0] for f in mlab_frames(gpu, method_cls or MLAB, k, sync)]
    for i, img in enumerate(imgs[1:], 2):
        assert np.array_equal(img, imgs[0]), f"frame {i} differs from frame 1 by {np.abs(img - imgs[0]).max():.3g}"


def test_mlab_frames_start_empty(gpu):
    check_mlab_frames_repeat(gpu)


def test_mlab_interlock_frames_repeat_with_merges(gpu):
    """Under the ordered interlock fragments merge in primitive order: frames repeat bit for bit at k = 3
    (9 merges a pixel at most). Needs GL_ARB_fragment_shader_interlock (NVIDIA has it, llvmpipe not)."""
    if INTERLOCK not in gpu.ctx.extensions:
        pytest.skip(f"{INTERLOCK} missing on {gpu.info['GL_RENDERER']}")
    check_mlab_frames_repeat(gpu, k=3, sync="interlock")


def test_mlab_broken_clear_fails(gpu, tmp_path):
    from ldbench.methods.mlab import MLAB

    with pytest.raises(AssertionError, match="frame 2 differs"):
        check_mlab_frames_repeat(gpu, broken(MLAB, ML_DIR, tmp_path, "count.glsl", "    count[i] = 0u;\n", ""))


def check_mlab_lock_keeps_every_fragment(gpu, method_cls=None, sync="spinlock", k=3):
    """No update of a pixel's k-buffer is lost, whatever the order the lock grants: over three frames, per
    pixel the stored layers number min(n, k) (n: the pixel's fragments), are in depth order, and the product
    of their transmittances is ∏(1 − α) over the pixel's fragments, which no merge order changes (float
    rounding of ≤ 12 products: 1e-6); the merges add up to Σ max(0, n − k). A lost update drops a factor
    1 − α ≤ 0.85. Under the spin lock the colour itself depends on the order the GPU grants the lock (MLAB's
    compression is order-dependent), which is why only the interlock repeats frames bit for bit with merges."""
    from ldbench.methods.mlab import MLAB

    sc = stack_scene()
    hits = intersections(sc, W, H)
    alpha = np.array([m.opacity for m in sc.meshes], np.float64)
    row, col = np.divmod(hits.pixel, W)
    gl_px = (H - 1 - row) * W + col  # row 0 at the bottom, as gl_FragCoord
    n = np.bincount(gl_px, minlength=W * H)
    t_want = np.ones(W * H)
    np.multiply.at(t_want, gl_px, 1.0 - alpha[hits.mesh])
    for img, layers, counts, c in mlab_frames(gpu, method_cls or MLAB, k, sync):
        assert np.array_equal(counts, np.minimum(n, k)), "stored layers != min(fragments, k)"
        assert c["merges"] == int(np.maximum(n - k, 0).sum()) and c["lost"] == 0
        live = np.arange(k)[None, :] < counts[:, None]
        t_got = np.prod(np.where(live, layers[..., 3], 1.0), axis=1)
        err = np.abs(t_got - t_want).max()
        assert err < 1e-6, f"transmittance off by {err:.3g}: an update was lost"
        assert np.all(np.isfinite(img))


def test_mlab_spinlock_keeps_every_fragment(gpu):
    check_mlab_lock_keeps_every_fragment(gpu)


def test_mlab_interlock_keeps_every_fragment(gpu):
    if INTERLOCK not in gpu.ctx.extensions:
        pytest.skip(f"{INTERLOCK} missing on {gpu.info['GL_RENDERER']}")
    check_mlab_lock_keeps_every_fragment(gpu, sync="interlock")


def test_mlab_broken_merge_transmittance_fails(gpu, tmp_path):
    """The transmittance check bites: a merge that keeps only the nearer layer's T loses fragments' T."""
    from ldbench.methods.mlab import MLAB

    Broken = broken(MLAB, ML_DIR, tmp_path, "insert.glsl", "a.a * b.a);", "a.a);")
    with pytest.raises(AssertionError, match="transmittance"):
        check_mlab_lock_keeps_every_fragment(gpu, Broken)


def test_mlab_lost_fragments_degrade(gpu, tmp_path):
    """A lock that is never released (the spin bound reached) loses fragments: counted, an invariant."""
    from ldbench.methods.mlab import MLAB

    Broken = broken(MLAB, ML_DIR, tmp_path, "insert.glsl", "atomicExchange(lock_word[px], 0u);", "")
    m = Broken(Broken.Params(k=4, sync="spinlock"))
    sc = intersecting_scene()
    from ldbench.core.effects import Effect
    from ldbench.methods.base import View

    m.setup(gpu, sc)
    try:
        r = m.frame(View(sc.camera, W, H), Effect("oit")).resolve()
    finally:
        m.release()
    assert r.counters["lost"] > 0 and any("lock" in s for s in r.invariants)


def test_teapot_all_methods_agree(gpu):
    """One mesh, one colour and opacity: both approximations are exact on yang2010's teapot."""
    sc = load_scene("teapot", segments=12)
    ref = render_oit(sc, W, H)
    for method, kw in (("wboit", {}), ("mlab", {"k": 2})):
        assert max_err(run(gpu, sc, method, **kw), ref) < EXACT, method


def test_mlab_without_the_lock_loses_updates(gpu, tmp_path):
    """The lock-soundness check bites on a GPU that shades a pixel's fragments concurrently: with the lock
    taken unconditionally (a plain entry for the compare-and-swap), updates race and transmittance is lost.
    llvmpipe shades one pixel's fragments one after another, so there the race cannot show."""
    from ldbench.methods.mlab import MLAB

    if gpu.device == "cpu-software":
        pytest.skip(f"{gpu.info['GL_RENDERER']} shades a pixel's fragments in order: no race can show")
    Broken = broken(MLAB, ML_DIR, tmp_path, "insert.glsl", "if (atomicCompSwap(lock_word[px], 0u, 1u) == 0u) {",
                    "if (true) {")
    with pytest.raises(AssertionError):
        check_mlab_lock_keeps_every_fragment(gpu, Broken)
