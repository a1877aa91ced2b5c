"""Layered per-pixel linked lists (methods/linked_list.py) against an exact CPU rasterization."""
from __future__ import annotations

import numpy as np
import pytest

from harness.errors import LdbenchError
from harness.scene import Camera, Mesh, Scene
from methods.gbuffer import SceneGeometry
from methods.linked_list import EOL, LayeredLinkedLists

W = H = 16


def quad(corners, name):
    return Mesh(name, np.array(corners, np.float32), np.array([[0, 1, 2], [0, 2, 3]], np.int32))


def flat(z, x0, x1, y0, y1, name):
    return quad([[x0, y0, z], [x1, y0, z], [x1, y1, z], [x0, y1, z]], name)


# Overlapping quads in [-1, 1]² (edges off the texel centres of a 16² map): three parallel to the
# map, one tilted (depth varies across it), one quad listed twice at the same depth (a tie).
MESHES = [
    flat(0.30, -0.97, 0.97, -0.97, 0.97, "big"),
    flat(-0.50, -0.53, 0.91, -0.21, 0.81, "a"),
    flat(0.70, -0.91, 0.13, -0.89, 0.33, "b"),
    quad([[-0.33, -0.71, -0.40], [0.61, -0.71, 0.20], [0.61, 0.23, 0.20], [-0.33, 0.23, -0.40]], "tilted"),
    flat(-0.10, -0.27, 0.58, -0.66, 0.19, "c"),
    flat(-0.10, 0.05, 0.44, 0.02, 0.52, "tie"),
]


def scene():
    return Scene("quads", MESHES, Camera((0, 0, 5), (0, 0, 0)))


def layer_transforms():
    """Layer 0: orthographic along z, depth = z. Layer 1: the same raster mirrored in x, depth = -2z + 1."""
    c0 = np.eye(4)
    c0[2, 2] = 0.5
    c1 = c0.copy()
    c1[0, 0] = -1.0
    rows = np.array([[0, 0, 1, 0], [0, 0, -2, 1]], float)
    return np.stack([c0, c1]), rows


def _inside(p, tri):
    a, b, c = tri
    def s(p, q, r):
        return (p[0] - r[0]) * (q[1] - r[1]) - (q[0] - r[0]) * (p[1] - r[1])
    d1, d2, d3 = s(p, a, b), s(p, b, c), s(p, c, a)
    return not ((min(d1, d2, d3) < 0) and (max(d1, d2, d3) > 0))


def expected_lists():
    """Per layer and texel, the sorted depths of every triangle covering the texel centre (CPU)."""
    clip, rows = layer_transforms()
    out = np.empty((2, H, W), object)
    for k in range(2):
        for y in range(H):
            for x in range(W):
                px = ((x + 0.5) / W * 2 - 1, (y + 0.5) / H * 2 - 1)
                ds = []
                for m in MESHES:  # each quad is planar: covered = inside either triangle, counted once
                    for f in m.faces:
                        v = m.vertices[f].astype(np.float64)
                        ndc = (clip[k][:2, :3] @ v.T).T
                        if _inside(px, ndc):
                            # depth at the texel centre: barycentric interpolation in the raster plane
                            T = np.array([[ndc[0, 0] - ndc[2, 0], ndc[1, 0] - ndc[2, 0]],
                                          [ndc[0, 1] - ndc[2, 1], ndc[1, 1] - ndc[2, 1]]])
                            l0, l1 = np.linalg.solve(T, np.array(px) - ndc[2])
                            p = l0 * v[0] + l1 * v[1] + (1 - l0 - l1) * v[2]
                            ds.append(rows[k][:3] @ p + rows[k][3])
                            break
                out[k, y, x] = sorted(ds)
    return out


@pytest.fixture(scope="module")
def setup(gpu):
    res = gpu.resources()
    geo = SceneGeometry(gpu, scene(), res)
    yield gpu, geo, res
    res.release()


@pytest.fixture(scope="module")
def expected():
    return expected_lists()


def _build(setup, **kw):
    gpu, geo, res = setup
    ll = LayeredLinkedLists(gpu, geo, res, layers=2, width=W, height=H, **kw)
    ll.set_layers(*layer_transforms())
    ll.build()
    return ll


def _compare(ll, expected, *, exact_sort=True):
    lists = ll.lists()
    for k in range(2):
        for y in range(H):
            for x in range(W):
                got, exp = lists[k][y][x], expected[k, y, x]
                assert len(got) == len(exp), (k, y, x, got, exp)
                assert np.allclose(got, exp, atol=1e-5), (k, y, x, got, exp)
                if exact_sort:
                    assert got == sorted(got), (k, y, x, got)


def _total(expected):
    return sum(len(v) for v in expected.ravel())


@pytest.mark.parametrize("sorted_insert", [True, False])
@pytest.mark.parametrize("instanced", [True, False])
@pytest.mark.parametrize("indexed", [True, False])
@pytest.mark.parametrize("pool", ["grow", "count"])
@pytest.mark.parametrize("aggregate", [False, True])
def test_lists_sorted_and_exact(setup, expected, sorted_insert, instanced, indexed, pool, aggregate):
    if aggregate and "GL_ARB_shader_ballot" not in setup[0].ctx.extensions:
        pytest.skip("no ARB_shader_ballot")
    ll = _build(setup, sorted_insert=sorted_insert, instanced=instanced, indexed=indexed, pool=pool,
                aggregate=aggregate)
    _compare(ll, expected)
    st = ll.stats()
    n = _total(expected)
    assert n > 200 and max(len(v) for v in expected.ravel()) >= 5
    assert st["fragments"] == st["fragments_stored"] == st["linked_nodes"] == n
    assert st["overflow"] == 0 and not st["overflowed"]
    assert st["unsorted_lists"] == 0 and st["insert_failures"] == 0
    assert st["max_list_length"] == max(len(v) for v in expected.ravel())
    assert st["lists_nonempty"] == sum(1 for v in expected.ravel() if v)
    assert st["mean_list_length"] == pytest.approx(n / st["lists_nonempty"])
    if pool == "count":
        assert st["pool_capacity"] == n and st["build_passes"] == 1


def test_grow_policy_redoes_once_then_fits(setup, expected):
    ll = _build(setup, pool="grow", pool_capacity=7)
    assert ll.build_passes == 2 and ll.capacity == _total(expected)
    _compare(ll, expected)
    ll.build()
    assert ll.build_passes == 1 and not ll.stats()["overflowed"]


def test_unsorted_build_is_unsorted_before_the_sort_pass(setup, expected):
    gpu, geo, res = setup
    ll = LayeredLinkedLists(gpu, geo, res, layers=2, width=W, height=H, sorted_insert=False,
                            pool="fixed", pool_capacity=4000)
    ll.set_layers(*layer_transforms())
    ll._build_once()  # raster only, no sort pass
    assert ll.stats()["unsorted_lists"] > 0
    ll.sort()
    assert ll.stats()["unsorted_lists"] == 0
    _compare(ll, expected)


def test_sort_pass_long_lists_take_the_exact_slow_path(setup, expected):
    ll = _build(setup, sorted_insert=False, max_list=2)
    st = ll.stats()
    assert st["sort_overflow_lists"] == sum(1 for v in expected.ravel() if len(v) > 2) > 0
    _compare(ll, expected)


def test_paged_pool(setup, expected):
    """The pool split over SSBO pages of 512 nodes (the path taken above the SSBO size limit)."""
    n = _total(expected)
    ll = _build(setup, page_nodes=512, pool="count")
    assert ll.pages == -(-n // 512) == 3
    _compare(ll, expected)
    ll2 = _build(setup, page_nodes=512, sorted_insert=False)
    _compare(ll2, expected)


def test_overflow_is_reported(setup, expected):
    n = _total(expected)
    ll = _build(setup, pool="fixed", pool_capacity=50)
    st = ll.stats()
    assert st["fragments"] == n
    assert st["fragments_stored"] == st["linked_nodes"] == 50
    assert st["overflow"] == n - 50 and st["overflowed"]
    assert st["unsorted_lists"] == 0
    # what was stored is a sub-multiset of the true lists, still sorted
    lists = ll.lists()
    for k in range(2):
        for y in range(H):
            for x in range(W):
                got, exp = lists[k][y][x], list(expected[k, y, x])
                assert got == sorted(got)
                for z in got:
                    j = int(np.argmin(np.abs(np.array(exp) - z)))
                    assert abs(exp[j] - z) < 1e-5
                    exp.pop(j)
    # the page limit is an overflow too, not a silent clamp
    ll = _build(setup, pool="count", page_nodes=64)
    st = ll.stats()
    assert st["pool_capacity"] == 4 * 64 and st["overflow"] == n - 256 and st["overflowed"]


def test_heads_and_memory(setup, expected):
    ll = _build(setup, pool="count")
    heads, depth, nxt = ll.read()
    assert heads.shape == (2, H, W)
    empty = np.array([[not expected[0, y, x] for x in range(W)] for y in range(H)])
    assert ((heads[0] == EOL) == empty).all()
    mem = ll.memory()
    assert mem["ll.heads"] == 4 * 2 * W * H
    assert mem["ll.nodes0"] == 8 * _total(expected)
    assert mem["ll.counters"] == 32


def test_bad_arguments(setup):
    gpu, geo, res = setup
    with pytest.raises(LdbenchError, match="pool"):
        LayeredLinkedLists(gpu, geo, res, layers=1, width=4, pool="bogus")
    with pytest.raises(LdbenchError, match="pool_capacity"):
        LayeredLinkedLists(gpu, geo, res, layers=1, width=4, pool="fixed")
    ll = LayeredLinkedLists(gpu, geo, res, layers=1, width=4)
    with pytest.raises(LdbenchError, match="set_layers"):
        ll.build()
