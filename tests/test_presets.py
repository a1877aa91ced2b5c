"""Fast defaults and the ``paper`` preset: the preset mechanism (``preset = NAME`` expands under the values
given beside it), and, for every adapter whose default is a fast build, the default's output equals the
paper build's (``ldm`` AO, rays and indirect; ``cdi-vpl`` VPL ranges and rays; ``ldi`` indirect light and
rays) on llvmpipe."""
from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from ldbench.core.effects import Effect
from ldbench.core.errors import LdbenchError
from ldbench.core.scenes import load_scene
from ldbench.methods.base import View, get_method
from ldbench.methods.cdi_vpl import CdiVplParams
from ldbench.methods.ldi import LdiParams
from ldbench.methods.ldm import LdmParams
from ldbench.references.registry import EXACT

from testkit import cornell_like


# ---- the mechanism ------------------------------------------------------------------------------------

def test_paper_preset_is_the_paper_build():
    fast, paper = LdmParams().structure, LdmParams.from_dict({"preset": "paper"}).structure
    assert (fast.source, fast.sorted_insert, fast.pool, fast.splat_sort) == ("splat", False, "lazy", True)
    assert (paper.layout, paper.source, paper.sorted_insert, paper.pool) == ("linked", "raster", True, "grow")
    c = CdiVplParams.from_dict({"preset": "paper"}).structure
    assert (c.source, c.assembly, c.pool, c.max_list) == ("one_pass", "direct", "grow", 32)
    assert (CdiVplParams().structure.assembly, CdiVplParams().structure.pool) == ("sort", "lazy")
    i = LdiParams.from_dict({"preset": "paper"}).structure
    assert (i.source, i.assembly, i.pool) == ("peel", "direct", "grow")
    assert (LdiParams().structure.source, LdiParams().structure.pool) == ("splat", "lazy")
    t, tp = LdmParams().trace, LdmParams.from_dict({"preset": "paper"}).trace
    assert (t.map_batch, tp.map_batch) == (64, 0)


def test_values_beside_a_preset_win_under_any_name():
    for given in ({"structure.pool": "lazy"}, {"pool": "lazy"}, {"structure": {"pool": "lazy"}}):
        s = LdmParams.from_dict({"preset": "paper", **given}).structure
        assert (s.source, s.sorted_insert, s.pool) == ("raster", True, "lazy"), given
    # the rest of the preset stays
    assert LdmParams.from_dict({"preset": "paper", "directions": 8}).directions == 8


def test_unknown_preset_is_one_error():
    with pytest.raises(LdbenchError, match=r"preset='fast'.*known: paper"):
        LdmParams.from_dict({"preset": "fast"})
    with pytest.raises(LdbenchError, match=r"preset='paper'.*known: none"):
        get_method("hbao").Params.from_dict({"preset": "paper"})


def test_a_source_sets_the_defaults_that_follow_it():
    """Depth peeling builds compacted layers: an LDI suite that names only ``structure.source = peel`` (or
    the earlier ``build = peel``) gets the direct assembly peeling needs, not the fast default's sort; an
    explicit assembly is still checked."""
    for given in ({"structure.source": "peel"}, {"build": "peel"}):
        s = LdiParams.from_dict(given).structure
        assert (s.assembly, s.pool) == ("direct", "grow"), given
    with pytest.raises(LdbenchError, match="source='peel'"):
        LdiParams.from_dict({"structure.source": "peel", "structure.assembly": "sort"})


def test_cli_lists_presets_and_refuses_an_unknown_one(tmp_path):
    for name, has in (("ldm", True), ("cdi-vpl", True), ("ldi", True), ("hbao", False)):
        out = subprocess.run([sys.executable, "-m", "ldbench.harness.cli", "methods", name], capture_output=True,
                             text=True)  # `ldbench methods NAME`: that method's parameters, presets included
        assert out.returncode == 0 and out.stdout.startswith(name), out.stderr
        assert any(line.startswith('- `preset = "paper"`') for line in out.stdout.splitlines()) == has, name
        assert has or "preset" not in out.stdout
    bad = subprocess.run([sys.executable, "-m", "ldbench.harness.cli", "run", "--scene", "cornell", "--method", "ldm",
                          "--effect", "ao", "--size", "8x8", "--set", "ldm.preset=fast", "--out", str(tmp_path / "r")],
                         capture_output=True, text=True)
    assert bad.returncode == 2 and bad.stderr.strip().count("\n") == 0 and "preset='fast'" in bad.stderr


# ---- the default's output is the paper build's ----------------------------------------------------------

def _frame(gpu, scene, method, effect, inputs=None, size=48, frames=2, **params):
    cls = get_method(method)
    m = cls(cls.Params.from_dict(params))
    m.setup(gpu, scene)
    try:
        if inputs is not None and hasattr(inputs, "upload"):
            inputs.upload(gpu)
        for _ in range(frames):  # the second frame: the lazy pool sized from the first
            r = m.frame(View(scene.camera, size, size), effect, inputs).resolve()
    finally:
        m.release()
    assert not r.invariants, r.invariants
    return r


LDM = dict(directions=32, resolution=32)


def test_ldm_default_renders_the_paper_build(gpu):
    """The same lists, so the same AO image and, with the same splats, the same indirect image, to 1e-6
    (measured on llvmpipe: AO 1.2e-7, indirect 0 relative to the image's maximum). The default's atomic
    splats add the raster's pixels in another order (tests/test_ldm_indirect.py measures the few pixels a
    rounded splat corner moves): median relative difference below 5e-7, at most 0.5 % of the pixels above
    1e-5 (measured 0 and 0)."""
    scene = cornell_like()
    for eff, extra in ((Effect("ao", d_max=0.5), {}), (Effect("indirect"), {"indirect.splat": "atomic"})):
        a = _frame(gpu, scene, "ldm", eff, **LDM)
        b = _frame(gpu, scene, "ldm", eff, preset="paper", **LDM, **extra)
        assert a.counters["fragments_stored"] == b.counters["fragments_stored"] > 1000
        d = np.abs(a.image - b.image).max() / max(float(np.abs(b.image).max()), 1e-12)
        assert d <= 1e-6, (eff.name, d)
        assert a.counters["build_variant"] == "splat" and b.counters["build_variant"] == "raster"
    a, b = a.image, _frame(gpu, scene, "ldm", Effect("indirect"), preset="paper", **LDM).image
    rel = np.abs(a - b).sum(-1) / np.maximum(b.sum(-1), 1e-6)
    assert np.median(rel) < 5e-7 and (rel > 1e-5).mean() <= 0.005, (np.median(rel), (rel > 1e-5).mean())


@pytest.fixture(scope="module")
def cornell():
    return load_scene("cornell")


def test_ldm_and_cdi_rays_answer_as_the_paper_build(gpu, cornell):
    e = Effect("rays", ray_kind="diffuse", rays_per_pixel=2)
    batch = e.spec.inputs(cornell, 32, 32, e.params, 0, exact=EXACT)
    for method, kw in (("ldm", LDM), ("cdi-vpl", dict(directions=48, resolution=32))):
        a = _frame(gpu, cornell, method, e, batch, size=32, **kw).arrays["t"]
        b = _frame(gpu, cornell, method, e, batch, size=32, preset="paper", **kw).arrays["t"]
        np.testing.assert_allclose(a, b, rtol=2e-5, atol=2e-7, err_msg=method)  # depths to float rounding
        assert np.isfinite(a).mean() > 0.5


def test_cdi_default_ranges_equal_the_paper_build(gpu, cornell):
    """The one-pass CDI assembled as sorted pairs without a read-back, its lists sorted in registers up to
    128 fragments (the paper preset: count + fill, 32, longer lists by the exact slow path): the same arrays,
    so the same ranges bit for bit."""
    e = Effect("vpl_range", rsm=32)
    batch = e.spec.inputs(cornell, 8, 8, e.params, 0, exact=EXACT)
    a = _frame(gpu, cornell, "cdi-vpl", e, batch, size=8)
    b = _frame(gpu, cornell, "cdi-vpl", e, batch, size=8, preset="paper")
    np.testing.assert_array_equal(a.arrays["range"], b.arrays["range"])
    assert a.counters["assembly"] == "sort" and b.counters["assembly"] == "direct"


def test_ldi_default_renders_the_paper_build(gpu, cornell):
    """Single pass (compute splat, sorted pairs) against depth peeling: the same image to 1e-6 relative
    (measured on llvmpipe: 0)."""
    e = Effect("indirect")
    kw = dict(directions=24, resolution=32, **{"image.rays_per_pixel": 4})
    a = _frame(gpu, cornell, "ldi", e, size=24, **kw)
    b = _frame(gpu, cornell, "ldi", e, size=24, preset="paper", **kw)
    d = np.abs(a.image - b.image).max() / float(np.abs(b.image).max())
    assert d <= 1e-6 and b.image.max() > 0, d
