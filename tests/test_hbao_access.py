"""hbao's ``access = "deinterleaved"`` on llvmpipe: the same image as today's interleaved access for both integrals,
with and without the plane fit, blur and pixel-step sampling, at sizes that are no multiple of the layers'
workgroups; every workgroup of the AO pass on one 4×4 layer (one rotation), where the interleaved one holds
all 16; and checks that a broken layer lookup or pixel mapping fails."""
import math

import numpy as np
import pytest

from ldbench.core.effects import Effect
from ldbench.core.errors import LdbenchError
from ldbench.methods.base import View
from ldbench.methods.hbao import HBAO, HBAOParams
from test_hbao import broken_hbao

CASES = [  # (parameters, effect, width, height)
    ({}, Effect("ao", 0.35, "step"), 128, 128),
    ({"integral": "cosine"}, Effect("ao", math.inf, "step"), 100, 77),
    ({"plane_fit": False, "blur": False}, Effect("ao", 0.5, "quadratic"), 131, 64),
    ({"sampling": "pixel_step", "steps": 64}, Effect("ao", 1.0, "step"), 96, 96),
]


def run(gpu, method_cls, params, effect, w, h, scene):
    m = method_cls(HBAOParams(**params))
    m.setup(gpu, scene)
    gpu.begin_frame()
    r = m.frame(View(scene.camera, w, h), effect).resolve()
    stages, _ = gpu.end_frame()
    counts = m.sample_counts(View(scene.camera, w, h), effect)
    m.release()
    return r, stages, counts


def check_same_image(gpu, method_cls=HBAO):
    """Deinterleaved access reads the values interleaved access computes, at the same samples, in the same
    order: the images agree to float rounding (bound 1e-5: another compiler may fuse the view transform
    differently in the two passes; measured bit-identical on llvmpipe), and so do the samples marched."""
    from ldbench.core.scenes import load_scene

    sc = load_scene("cornell")
    for params, eff, w, h in CASES:
        a, _, ca = run(gpu, HBAO, {**params, "access": "interleaved"}, eff, w, h, sc)
        b, stages, cb = run(gpu, method_cls, {**params, "access": "deinterleaved"}, eff, w, h, sc)
        assert set(stages) == {"gbuffer", "deinterleave", "hbao"} | ({"blur"} if params.get("blur", True) else set())
        d = np.abs(a.image - b.image).max()
        assert d <= 1e-5, f"{params} {w}x{h}: deinterleaved access changes the image by {d:.3g}"
        assert np.array_equal(ca, cb), f"{params}: another number of samples"


def test_deinterleaved_access_gives_the_same_image(gpu):
    check_same_image(gpu)


def test_a_wrong_layer_lookup_fails(gpu, tmp_path):
    broken = broken_hbao(tmp_path, ("ivec2 cell = q & 3, t = q >> 2;", "ivec2 t = q & 3, cell = q >> 2;"))
    with pytest.raises(AssertionError, match="changes the image"):
        check_same_image(gpu, broken)


def group_cells(gpu, method_cls, access, w=100, h=77):
    """Per workgroup of the AO pass, the set of pixel cells (x mod 4, y mod 4) and the pixels it computes."""
    from ldbench.core.scenes import load_scene

    sc = load_scene("cornell")
    m = method_cls(HBAOParams(access=access))
    m.setup(gpu, sc)
    ids = m.workgroups(View(sc.camera, w, h), Effect("ao", 0.35, "step"))[::-1]  # GL rows: row 0 = bottom
    m.release()
    ys, xs = np.mgrid[0:h, 0:w]
    cells, pixels = {}, {}
    for g, x, y in zip(ids.ravel().astype(np.int64), xs.ravel(), ys.ravel()):
        cells.setdefault(g, set()).add((x % 4, y % 4))
        pixels.setdefault(g, []).append((x, y))
    return cells, pixels


def check_one_layer_per_group(gpu, method_cls=HBAO):
    """Deinterleaved: every workgroup's pixels lie in one cell of the 4×4 noise tile (one rotation and jitter
    for all 64), 4 pixels apart; interleaved: a full group holds all 16 cells."""
    cells, pixels = group_cells(gpu, method_cls, "deinterleaved")
    assert all(len(c) == 1 for c in cells.values()), "a workgroup spans several layers"
    for px in pixels.values():
        px = np.array(px)
        assert np.all((px - px.min(0)) % 4 == 0)
        assert np.all(px.max(0) - px.min(0) <= 28)  # an 8 × 8 block of one layer
    cells, _ = group_cells(gpu, HBAO, "interleaved")
    assert max(len(c) for c in cells.values()) == 16


def test_deinterleaved_workgroups_share_one_rotation(gpu):
    check_one_layer_per_group(gpu)


def test_image_order_mapping_fails(gpu, tmp_path):
    """The pixel mapping of the deinterleaved kernel replaced by image order: the same image, but the
    workgroups span every layer again."""
    broken = broken_hbao(tmp_path, ("ivec2 p = 4 * (g - cell * quarter) + cell;", "ivec2 p = g;"))
    with pytest.raises(AssertionError, match="several layers"):
        check_one_layer_per_group(gpu, broken)


def test_access_parameter():
    assert HBAOParams().access == "deinterleaved"
    with pytest.raises(LdbenchError, match="access"):
        HBAOParams(access="tiled")
