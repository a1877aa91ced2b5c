"""The LDM trace modes (``trace.query``, ``trace.walk``; ldbench/methods/ldm/ldm_trace.glsl): the full walk of
unsorted lists answers exactly like the early stop on pre-sorted lists (AO images and per-ray t, both
layouts); the AO of either query equals the sum over the maps it is meant to use, rebuilt from the
``rays`` effect's answers along the maps' axes (two_way: the N maps, each along the side of the normal;
one_way: the 2N maps along ±v, those whose axis faces the normal); the 2N one-way maps answer every ray
as the N two-way maps do, from twice the fragments. ``trace.prefetch`` (the AO pass loading several maps'
first nodes before walking them) and ``trace.map_batch`` (the AO pass in several dispatches, each pixel's
sums carried between them) give the same image bit for bit."""
from __future__ import annotations

import numpy as np
import pytest

from testkit import cornell_like as _cornell_like
from ldbench.core.effects import Effect
from ldbench.core.effects.rays import RayBatch, RaysParams
from ldbench.core.errors import LdbenchError
from ldbench.methods.base import View
from ldbench.methods.directions import ldm_axes
from ldbench.methods.ldm import Ldm, LdmParams

N, RES, SIZE = 24, 48, 40
EFFECT = Effect("ao", d_max=float("inf"), falloff="step")


def scene():
    return _cornell_like(light=False)


def run(gpu, sc, effect, batch=None, size=(SIZE, SIZE), **params):
    m = Ldm(LdmParams.from_dict({"directions": N, "resolution": RES, **params}))
    m.setup(gpu, sc)
    try:
        r = m.frame(View(sc.camera, *size), effect, batch).resolve()
        gb = m.gbuf.read() if batch is None else None
    finally:
        m.release()
    return r, gb


def rays_batch(sc, size=24, k=2):
    from ldbench.references.rays import make_batch

    return make_batch(sc, size, size, RaysParams(rays_per_pixel=k), 0)


def axis_batch(o, n, d) -> RayBatch:
    f4 = lambda a: np.ascontiguousarray(a, np.float32)  # noqa: E731
    return RayBatch(f4(o), f4(d), f4(np.full(len(o), np.inf)), f4(n), np.zeros(len(o), np.uint32), 1, 1,
                    "diffuse", False)


@pytest.mark.parametrize("layout", ["linked", "linear"])
def test_full_walk_equals_early_stop_on_sorted_lists(gpu, layout):
    sc = scene()
    eff = Effect("ao", d_max=0.8, falloff="quadratic")
    base, _ = run(gpu, sc, eff, **{"structure.layout": layout})
    full, _ = run(gpu, sc, eff, **{"structure.layout": layout, "trace.walk": "full"})
    assert base.counters["max_list_length"] >= 4
    assert np.array_equal(full.image, base.image)
    assert 0.2 < float(base.image[..., 0].mean()) < 0.99  # occlusion present: the test can tell
    batch = rays_batch(sc)
    tb = run(gpu, sc, Effect("rays"), batch, **{"structure.layout": layout})[0].arrays["t"]
    tf = run(gpu, sc, Effect("rays"), batch, **{"structure.layout": layout, "trace.walk": "full"})[0].arrays["t"]
    assert np.array_equal(tf, tb)
    assert np.isfinite(tb).mean() > 0.5


def test_full_walk_on_unsorted_insert_and_one_way(gpu):
    """The full walk with the one-way query too; and on lists built unsorted then sorted."""
    sc = scene()
    a, _ = run(gpu, sc, EFFECT, **{"trace.query": "one_way"})
    b, _ = run(gpu, sc, EFFECT, **{"trace.query": "one_way", "trace.walk": "full",
                                   "structure.sorted_insert": False})
    assert np.array_equal(a.image, b.image)


@pytest.mark.parametrize("query", ["two_way", "one_way"])
def test_ao_is_the_sum_over_the_maps_of_its_query(gpu, query):
    """AO (d_max = inf, step) = Σ_used cos·[miss] / Σ_used cos, with each map's answer from the rays
    effect along exactly that map's axis (two_way rays, scan: the map itself answers)."""
    sc = scene()
    img, (pos, nrm, _) = run(gpu, sc, EFFECT, **{"trace.query": query})
    sel = pos[..., 3] > 0.5
    x = pos[..., :3][sel]
    n = nrm[..., :3][sel]
    n = n / np.linalg.norm(n, axis=1, keepdims=True)
    v = ldm_axes(N).astype(np.float32)
    if query == "one_way":  # 2N one-directional maps along +v and -v
        v = np.concatenate([v, -v])
    c = n @ v.T  # (P, maps)
    use = np.abs(c) >= 1e-6
    if query == "one_way":
        use &= c >= 0
    sign = np.where(c > 0, 1.0, -1.0)
    p_i, k_i = np.nonzero(use)
    d = v[k_i] * sign[p_i, k_i, None]
    t = run(gpu, sc, Effect("rays"), axis_batch(x[p_i], n[p_i], d), **{"rays.map_lookup": "scan"})[0].arrays["t"]
    miss = ~np.isfinite(t)
    w = np.abs(c[p_i, k_i])
    num = np.bincount(p_i, w * miss, minlength=len(x))
    den = np.bincount(p_i, w, minlength=len(x))
    want = np.where(den > 0, num / np.maximum(den, 1e-30), 1.0)
    got = img.image[..., 0][sel]
    close = np.abs(got - want) < 1e-4
    assert close.mean() > 0.99, close.mean()
    assert (den > 0).all()  # every pixel has maps facing its normal (one-way: the -v maps for the ceiling)
    if query == "one_way":  # the same AO as the two-way maps, with either estimator (eq. 2's 2/N: N directions)
        for est in ("ratio", "paper"):
            one = run(gpu, sc, EFFECT, **{"trace.query": query, "trace.estimator": est})[0].image
            two = run(gpu, sc, EFFECT, **{"trace.estimator": est})[0].image
            assert np.abs(one - two).max() < 1e-5, est
        assert img.counters["maps"] == 2 * N


def test_one_way_maps_answer_as_the_two_way_maps(gpu):
    """The same 2N directions, so the same answers to float rounding (the -v maps store depths along -v),
    from twice the fragments; the table of the 2N axes answers as the scan."""
    sc = scene()
    batch = rays_batch(sc)
    one = run(gpu, sc, Effect("rays"), batch, **{"trace.query": "one_way", "rays.map_lookup": "scan"})[0]
    two = run(gpu, sc, Effect("rays"), batch, **{"rays.map_lookup": "scan"})[0]
    t1, t2 = one.arrays["t"], two.arrays["t"]
    assert np.array_equal(np.isinf(t1), np.isinf(t2)) and np.isfinite(t2).mean() > 0.5
    fin = np.isfinite(t2)
    np.testing.assert_allclose(t1[fin], t2[fin], rtol=2e-5, atol=2e-6)
    # twice the fragments but for texel centres on an edge, which the fill rule decides in the mirrored
    # maps the other way (measured: 18 of 117,040)
    f1, f2 = one.counters["fragments_stored"], 2 * two.counters["fragments_stored"]
    assert abs(f1 - f2) <= 1e-3 * f2, (f1, f2)
    assert (one.counters["maps"], two.counters["maps"]) == (2 * N, N)


def test_one_way_table_finds_the_nearest_plus_axis():
    """The full-cube one-way table's best candidate is the nearest axis (largest signed d·v) of the 2N
    one-way maps for all but a sliver of directions, those of the lower hemisphere (the -v maps) included."""
    from ldbench.methods.ldm import LUT_RES, one_way_axis_table

    v = np.concatenate([ldm_axes(128), -ldm_axes(128)])
    table = one_way_axis_table(v, LUT_RES)
    d = np.random.default_rng(3).normal(size=(20000, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    ad = np.abs(d)
    a = np.where((ad[:, 0] >= ad[:, 1]) & (ad[:, 0] >= ad[:, 2]), 0, np.where(ad[:, 1] >= ad[:, 2], 1, 2))
    i = np.arange(len(d))
    uv = np.stack([d[i, (a + 1) % 3], d[i, (a + 2) % 3]], 1) / ad[i, a][:, None]
    ij = np.clip(np.floor((uv + 1.0) * 0.5 * LUT_RES).astype(int), 0, LUT_RES - 1)
    row = ((2 * a + (d[i, a] < 0)) * LUT_RES + ij[:, 0]) * LUT_RES + ij[:, 1]
    cand = table[row].astype(np.int64)
    dots = np.where(cand != 0xFFFFFFFF, np.einsum("nk,nsk->ns", d, v[np.minimum(cand, len(v) - 1)]), -np.inf)
    got = cand[i, dots.argmax(1)]
    want = (d @ v.T).argmax(1)
    assert (got == want).mean() > 0.999, (got == want).mean()
    assert (d[:, 1] < -0.5).sum() > 1000  # directions of the lower hemisphere were among them


def test_one_way_rays_table_equals_the_scan_and_indirect_refuses_the_modes(gpu):
    sc = scene()
    batch = rays_batch(sc)
    t = {lk: run(gpu, sc, Effect("rays"), batch, **{"trace.query": "one_way", "rays.map_lookup": lk})[0].arrays["t"]
         for lk in ("table", "scan")}
    same = (t["table"] == t["scan"]) | (np.isinf(t["table"]) & np.isinf(t["scan"]))
    assert same.mean() > 0.999, same.mean()
    with pytest.raises(LdbenchError, match="ao and rays effects only"):
        run(gpu, sc, Effect("indirect"), **{"trace.walk": "full"})


@pytest.mark.parametrize("layout, query", [("linked", "two_way"), ("linear", "two_way"), ("linked", "one_way")])
def test_prefetch_gives_the_same_ao(gpu, layout, query):
    """AO with the first nodes of 5 and 16 maps loaded before their walks (24 maps: a partial last batch for
    5) equals one map at a time, bit for bit."""
    sc = scene()
    eff = Effect("ao", d_max=0.8, falloff="quadratic")
    kw = {"structure.layout": layout, "trace.query": query}
    base, _ = run(gpu, sc, eff, **kw)
    assert 0.2 < float(base.image[..., 0].mean()) < 0.99
    for k in (5, 16):
        got, _ = run(gpu, sc, eff, **kw, **{"trace.prefetch": k})
        assert np.array_equal(got.image, base.image), k
    for other in (Effect("rays"), Effect("indirect")):
        with pytest.raises(LdbenchError, match="trace.prefetch applies to the ao effect only"):
            run(gpu, sc, other, rays_batch(sc) if other.name == "rays" else None, **{"trace.prefetch": 4})


@pytest.mark.parametrize("layout, query", [("linked", "two_way"), ("linear", "one_way")])
def test_map_batches_give_the_same_ao(gpu, layout, query):
    """AO over dispatches (trace.map_schedule) of 1, 7 (a partial last batch), 12, 24 and 64 maps (the adapter's 24 two-way or 48
    one-way maps), alone and with prefetch 5, equals one dispatch over all maps, bit for bit; and a larger
    second image reallocates the sums."""
    sc = scene()
    eff = Effect("ao", d_max=0.8, falloff="quadratic")
    kw = {"structure.layout": layout, "trace.query": query, "trace.map_schedule": "dispatches"}
    base, _ = run(gpu, sc, eff, **kw, **{"trace.map_batch": 0})
    for m, k in ((1, 1), (7, 1), (12, 1), (7, 5), (24, 1), (64, 1)):
        got, _ = run(gpu, sc, eff, **kw, **{"trace.map_batch": m, "trace.prefetch": k})
        assert np.array_equal(got.image, base.image), (m, k)
    small, _ = run(gpu, sc, eff, size=(20, 12), **kw, **{"trace.map_batch": 0})
    m = Ldm(LdmParams.from_dict({"directions": N, "resolution": RES, **kw, "trace.map_batch": 7}))
    m.setup(gpu, sc)
    try:  # one instance, the small image first: the sums must grow with the image
        for size, want in (((20, 12), small), ((SIZE, SIZE), base)):
            got = m.frame(View(sc.camera, *size), eff).resolve()
            assert np.array_equal(got.image, want.image), size
    finally:
        m.release()


@pytest.mark.parametrize("layout, query, estimator", [("linked", "two_way", "ratio"), ("linear", "one_way", "paper")])
def test_map_grid_gives_the_ao_of_one_dispatch(gpu, layout, query, estimator):
    """All batches in one dispatch (trace.map_schedule = grid: 1, 7 with a partial last batch, 12 maps), their
    partial sums added by a pass over the pixels, give one dispatch's image to float rounding (background
    pixels included); a larger second image reallocates the partial sums."""
    sc = scene()
    eff = Effect("ao", d_max=0.8, falloff="quadratic")
    kw = {"structure.layout": layout, "trace.query": query, "trace.estimator": estimator}
    base, _ = run(gpu, sc, eff, **kw, **{"trace.map_batch": 0})
    assert (base.image == 1.0).any() and (base.image < 0.5).any()
    for m in (1, 7, 12):
        got, _ = run(gpu, sc, eff, **kw, **{"trace.map_batch": m, "trace.map_schedule": "grid"})
        np.testing.assert_allclose(got.image, base.image, rtol=0, atol=1e-6, err_msg=str(m))
    small, _ = run(gpu, sc, eff, size=(20, 12), **kw, **{"trace.map_batch": 0})
    m = Ldm(LdmParams.from_dict({"directions": N, "resolution": RES, **kw, "trace.map_batch": 7,
                                 "trace.map_schedule": "grid"}))
    m.setup(gpu, sc)
    try:
        for size, want in (((20, 12), small), ((SIZE, SIZE), base)):
            got = m.frame(View(sc.camera, *size), eff).resolve()
            np.testing.assert_allclose(got.image, want.image, rtol=0, atol=1e-6, err_msg=str(size))
        # partial sums past the driver's largest buffer: the dispatches' schedule, bit for bit
        m.ls.ssbo_limit = 8 * SIZE * SIZE * 2
        got = m.frame(View(sc.camera, SIZE, SIZE), eff).resolve()
        want, _ = run(gpu, sc, eff, **kw, **{"trace.map_batch": 7, "trace.map_schedule": "dispatches"})
        assert np.array_equal(got.image, want.image)
    finally:
        m.release()


def test_map_batches_cover_every_map_once():
    for n, m in ((24, 7), (24, 24), (24, 0), (24, 100), (5, 1)):
        b = LdmParams.from_dict({"trace.map_batch": m}).trace.map_batches(n)
        assert [k for k0, k1 in b for k in range(k0, k1)] == list(range(n)), (n, m)
    assert LdmParams().trace.map_batches(512) == [(k, k + 64) for k in range(0, 512, 64)]


def test_defaults_are_the_papers_and_unchanged():
    p = LdmParams()
    assert (p.trace.query, p.trace.walk) == ("two_way", "early_stop") and p.trace.defines() == {}
    assert LdmParams.from_dict({"trace.query": "one_way", "trace.walk": "full"}).trace.defines() == {
        "LDM_ONE_WAY": 1, "LDM_FULL_WALK": 1}
    assert LdmParams.from_dict({"trace.prefetch": 4}).trace.defines() == {"LDM_PREFETCH": 4}
    with pytest.raises(LdbenchError):
        LdmParams.from_dict({"trace.walk": "sometimes"})
