"""The ``rays`` effect (harness/effects/rays.py, references/rays.py): the oracle against closed forms, the
ray batch's distributions and determinism, and the per-ray metrics."""
from __future__ import annotations

import math

import numpy as np
import pytest

from harness.effects import Effect
from harness.effects.rays import RayBatch, RaysParams, build_batch, is_hit, ray_metrics
from harness.errors import LdbenchError
from harness.scene import Camera, Mesh, Scene, SpotLight
from references.rays import make_batch, trace_oracle
from testkit import box, cornell_like


def icosphere(subdivisions: int, radius: float = 1.0) -> Mesh:
    """An icosphere with every vertex on the sphere (the triangles lie inside it)."""
    import trimesh

    s = trimesh.creation.icosphere(subdivisions=subdivisions, radius=radius)
    return Mesh("sphere", s.vertices.astype(np.float32), s.faces.astype(np.int32))


def batch_of(o, d, tmax=None, occlusion=False) -> RayBatch:
    o, d = np.asarray(o, np.float32), np.asarray(d, np.float32)
    n = len(o)
    t = np.full(n, np.inf, np.float32) if tmax is None else np.asarray(tmax, np.float32)
    return RayBatch(o, d, t, np.zeros_like(o), np.arange(n, dtype=np.uint32), n, 1, "diffuse", occlusion,
                    primary_mask=np.ones((1, n), bool))


def unit(rng, n):
    v = rng.normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def test_oracle_sphere_closed_form():
    """From inside a finely tessellated unit sphere (327 680 triangles, vertices on the sphere), every ray
    hits at the closed-form distance to 1e-4 relative (measured 3.9e-5: the facets' own sag)."""
    rng = np.random.default_rng(1)
    n = 4000
    o = unit(rng, n) * rng.uniform(0, 0.6, (n, 1))
    d = unit(rng, n)
    scene = Scene("sphere", [icosphere(7)], Camera((0, 0, 5), (0, 0, 0)))
    t = trace_oracle(scene, batch_of(o, d)).t.astype(np.float64)
    b = (o * d).sum(1)
    exact = -b + np.sqrt(b * b - ((o * o).sum(1) - 1.0))
    assert np.all(np.isfinite(t))
    assert np.max(np.abs(t - exact) / exact) < 1e-4, np.max(np.abs(t - exact) / exact)


@pytest.mark.parametrize("inside", [True, False], ids=["inside", "outside"])
def test_oracle_box_closed_form(inside):
    """An axis-aligned box (12 triangles) from inside and from outside: slab-test distances to 1e-4
    relative; misses from outside are misses; t_max and ray_test (occlusion) are honoured."""
    lo, hi = np.array([-1.0, -0.5, -2.0]), np.array([1.5, 0.5, 1.0])
    scene = Scene("box", [box(tuple(lo), tuple(hi), "box")], Camera((0, 0, 9), (0, 0, 0)))
    rng = np.random.default_rng(2 + inside)
    n = 3000
    if inside:
        o = rng.uniform(lo + 0.05, hi - 0.05, (n, 3))
        d = unit(rng, n)
    else:  # aimed at points around the box: hits and misses
        o = unit(rng, n) * 4.0
        d = rng.uniform(lo - 0.6, hi + 0.6, (n, 3)) - o
        d /= np.linalg.norm(d, axis=1, keepdims=True)
    with np.errstate(divide="ignore", invalid="ignore"):
        t1, t2 = (lo - o) / d, (hi - o) / d
    tn = np.max(np.minimum(t1, t2), 1)
    tf = np.min(np.maximum(t1, t2), 1)
    hit = (tf >= np.maximum(tn, 0))
    exact = np.where(tn > 0, tn, tf)
    t = trace_oracle(scene, batch_of(o, d)).t.astype(np.float64)
    assert np.array_equal(np.isfinite(t), hit)
    if not inside:
        assert 0.1 < hit.mean() < 0.9
    np.testing.assert_allclose(t[hit], exact[hit], rtol=1e-4)
    # t_max: a hit beyond it is a miss; shadow rays answer blocked (0) / unblocked (inf)
    tmax = np.where(hit, exact * 0.5, 1.0)
    t_half = trace_oracle(scene, batch_of(o, d, tmax)).t
    assert not np.isfinite(t_half[hit & (exact > 1e-3)]).any()
    occ = trace_oracle(scene, batch_of(o, d, np.where(hit, exact * 1.01, np.inf), occlusion=True)).t
    assert np.array_equal(occ == 0, hit)


def test_batch_definition_and_determinism():
    scene = cornell_like()
    a = make_batch(scene, 16, 12, RaysParams(rays_per_pixel=8), 0)
    b = make_batch(scene, 16, 12, RaysParams(rays_per_pixel=8), 0)
    c = make_batch(scene, 16, 12, RaysParams(rays_per_pixel=8), 1)
    assert np.array_equal(a.direction, b.direction) and not np.array_equal(a.direction, c.direction)
    assert len(a) == 8 * a.primary_mask.sum() and np.all(np.diff(a.pixel.astype(np.int64)) >= 0)
    assert np.allclose(np.linalg.norm(a.direction, axis=1), 1, atol=1e-6)
    cos = (a.direction * a.normal).sum(1)
    assert cos.min() > 0 and abs(cos.mean() - 2 / 3) < 0.02  # cosine-distributed: E[cos] = 2/3
    assert np.all(np.isinf(a.tmax))
    ao = make_batch(scene, 16, 12, RaysParams(ray_kind="ao", d_max=0.3), 0)
    assert np.all(ao.tmax == np.float32(0.3))


def test_glossy_and_shadow_batches():
    H = W = 40
    hits = {"mask": np.ones((H, W), bool), "position": np.zeros((H, W, 3), np.float32),
            "normal": np.tile(np.float32([0, 1, 0]), (H, W, 1))}
    cam = np.tile(np.float32([0.6, -0.8, 0]), (H * W, 1))
    g = build_batch(hits, cam, RaysParams(ray_kind="glossy", exponent=50, rays_per_pixel=16), 0,
                    ray_epsilon=1e-6, shadow_epsilon=1e-5)
    mirror = np.array([0.6, 0.8, 0.0])
    c = g.direction @ mirror
    assert abs(c.mean() - (51 / 52)) < 0.003  # E[cos α] = (e+1)/(e+2) for the normalized Phong lobe
    assert (g.direction[:, 1] > 0).all()
    light = SpotLight(position=(0, 2, 0), target=(0, 0, 0))
    s = build_batch(hits, cam, RaysParams(ray_kind="shadow", light_radius=0.25, rays_per_pixel=4), 0,
                    light=light, ray_epsilon=1e-6, shadow_epsilon=1e-5)
    end = s.origin + s.direction * (s.tmax / (1 - 1e-5))[:, None]
    r = np.linalg.norm(end - np.array([0, 2, 0]), axis=1)
    assert np.allclose(r, 0.25, atol=1e-4) and s.occlusion
    with pytest.raises(LdbenchError, match="light"):
        build_batch(hits, cam, RaysParams(ray_kind="shadow"), 0, ray_epsilon=1e-6, shadow_epsilon=1e-5)


def test_ray_metrics():
    inf = np.inf
    t_ref = np.array([1.0, 2.0, inf, inf, 0.001, 5.0, 1.0, 3.0])
    t = np.array([1.0, 2.2, inf, 4.0, 0.001, inf, np.nan, 0.001])
    m = ray_metrics(t, t_ref, tmax=np.full(8, inf), occlusion=False, diagonal=10.0)
    assert m["false_hit_rate"] == 1 / 8 and m["false_miss_rate"] == 1 / 8
    assert m["coverage"] == 7 / 8 and m["hit_agreement"] == pytest.approx(1 - 3 / 8)
    assert m["self_hit_rate"] == 1 / 8  # the 0.001 against 3.0; the 0.001 against 0.001 is right
    e = np.array([0, 0.2, 0, 2.999]) / 10.0
    assert m["dist_err_p50"] == pytest.approx(np.percentile(e, 50))
    assert is_hit(np.array([1.0, inf, np.nan]), 2.0).tolist() == [True, False, False]
    occ = ray_metrics(np.array([0.0, inf]), np.array([0.0, 0.0]), tmax=np.ones(2), occlusion=True, diagonal=1)
    assert occ["hit_agreement"] == 0.5 and math.isnan(occ["dist_err_p95"]) and math.isnan(occ["self_hit_rate"])


def test_effect_parameters_and_labels():
    e = Effect("rays", ray_kind="glossy", exponent=8)
    assert e.key() == {"effect": "rays", "ray_kind": "glossy", "rays_per_pixel": 4, "exponent": 8.0}
    assert e.label() == "rays-glossy-e8-4" and not e.needs_light()
    assert Effect("rays", ray_kind="shadow").needs_light()
    with pytest.raises(LdbenchError, match="ray_kind"):
        Effect("rays", ray_kind="bogus")
    with pytest.raises(LdbenchError, match="rays_per_pixel"):
        Effect("rays", rays_per_pixel=0)
    with pytest.raises(LdbenchError, match="no spot or point light"):
        Effect("rays", ray_kind="shadow").check_scene(cornell_like(light=False))
