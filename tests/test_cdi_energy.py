"""cdi-vpl's indirect energy on a spot-lit coloured wall beside a floor (docs/reference/methods/cdi_vpl.md, "Energy budget"):
mean radiance over the image and the floor against Mitsuba's one-bounce reference, each loss switched off
in turn (scripts/cdi_vpl_energy.py prints the whole budget).

Measured (48², RSM 64², every texel a VPL, 256 spp): default image −26.4 %, floor −34.4 %; exact ranges
−25.9 / −33.9 %; misses at 2 × the diagonal −1.2 / −1.0 %; ranges cut nowhere −1.2 / −1.0 %, the same with
one grid cell and without the depth mask. So the range cut-off (the mean of six hit distances, a miss counting
0.5 × the diagonal) is the loss, not the CDI, the grid binning, the depth mask or the VPL flux.
Mutations seen failing: flux × step² dropped (the vpl_step = 2 row), the cut-off at half the range,
cos θ_x × 0.9."""
from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

from ldbench.core.effects import Effect
from ldbench.references import render_reference
from testkit import wall_floor_scene

SIZE, RSM = 48, 64


def _script():
    path = Path(__file__).resolve().parents[1] / "scripts" / "cdi_vpl_energy.py"
    spec = importlib.util.spec_from_file_location("cdi_vpl_energy", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.fixture(scope="module")
def energy():
    return _script()


@pytest.fixture(scope="module")
def case(energy):
    scene = wall_floor_scene()
    ref = render_reference(scene, Effect("indirect"), width=SIZE, height=SIZE, spp=256, progress=False)
    return scene, ref


def test_the_range_cut_off_is_the_loss(gpu, energy, case):
    scene, ref = case
    uncut = energy.UNCUT
    b = energy.budget(gpu, scene, ref, SIZE, RSM, (
        ("default", {}), ("exact", {"vpl.range": "exact"}), ("far misses", {"indirect.miss_range": 2.0}),
        ("uncut", uncut), ("uncut grid 1", {**uncut, "indirect.grid": 1}), ("uncut no mask", {**uncut, "indirect.depth_mask": False}),
        ("uncut step 2", {**uncut, "indirect.vpl_step": 2, "rsm_scale": 2})))
    img, floor = {k: v[0] for k, v in b.items()}, {k: v[1] for k, v in b.items()}
    assert 0.70 <= img["default"] <= 0.77 and 0.62 <= floor["default"] <= 0.69, b
    assert abs(img["exact"] - img["default"]) < 0.02, b  # the CDI's ranges are not the loss
    for k in ("far misses", "uncut", "uncut grid 1", "uncut no mask", "uncut step 2"):
        assert 0.975 <= img[k] <= 1.0 and 0.975 <= floor[k] <= 1.0, (k, b)
    assert img["uncut grid 1"] == pytest.approx(img["uncut"], rel=1e-4)  # binning loses nothing
    assert img["uncut no mask"] == pytest.approx(img["uncut"], rel=1e-4)  # nor the depth mask
