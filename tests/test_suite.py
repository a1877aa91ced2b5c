"""Suites and parameters are strict: a value of the wrong type, out of range or unused is one clear
error before anything renders, never a silent conversion (ldbench/harness/suite.py, ldbench/methods/base.py _coerce,
--set/--spp/--frames/--warmup/--size in ldbench/harness/cli.py)."""
import dataclasses

import numpy as np
import pytest

from ldbench.harness.checks import camera_sees_geometry, unique_scene_names
from ldbench.harness.cli import build_parser, suite_from_args
from ldbench.core.errors import LdbenchError
from ldbench.harness.defaults import SIZE as DEFAULT_SIZE
from ldbench.harness.suite import MAX_FRAMES, MAX_SEED, MAX_SPP, MAX_WARMUP, parse_size, resolve_sizes, suite_from_dict
from ldbench.core.params import _coerce
from ldbench.methods.base import get_method


def suite(head=None, **run):
    r = {"scene": "cornell", "effect": "ao", "methods": ["hbao"], **run}
    return suite_from_dict({"suite": {"size": "16x16", **(head or {})}, "run": [r]}, name="t")


@pytest.mark.parametrize("head,run,needle", [
    ({}, {"params": {"hbao": {"directions": True}}}, "directions"),  # not 1
    ({}, {"params": {"hbao": {"directions": 8.0}}}, "directions"),
    ({}, {"params": {"hbao": {"blur": 1}}}, "blur"),
    ({}, {"params": {"hbao": {"integral": 5}}}, "integral"),
    ({}, {"params": {"hbao": {"angle_bias": "0.5x"}}}, "angle_bias"),
    ({"frames": 2.5}, {}, "frames"),  # not truncated to 2
    ({"frames": True}, {}, "frames"),
    ({"warmup": -3}, {}, "warmup"),
    ({"spp": "64"}, {}, "spp"),
    ({"spp": 0}, {}, "spp"),
    ({"spp": MAX_SPP + 1}, {}, "spp"),
    ({"spp": MAX_SPP, "size": "4096x4096"}, {}, "2^40"),  # rays per reference
    ({"name": 5}, {}, "name"),
    ({"description": ["x"]}, {}, "description"),
    ({"size": [16.5, 16]}, {}, "size"),
    ({"size": [True, 16]}, {}, "size"),
    ({"size": "2x16"}, {}, "3"),  # SSIM needs 3 x 3
    ({}, {"scene": 5}, "scene"),
    ({}, {"effect": 5}, "effect"),
    ({}, {"methods": [1]}, "methods"),
    ({}, {"params": {"hbao": 3}}, "params"),
    # parameters for a method this [[run]] does not run (the command line rejects them too)
    ({}, {"params": {"direct-raster": {"shadow_size": 64}}}, "direct-raster"),
    # every integer has an upper bound, checked before anything renders
    ({"frames": 10 ** 20}, {}, "frames must be <= 10000"),
    ({"frames": MAX_FRAMES + 1}, {}, "frames"),
    ({"warmup": MAX_WARMUP + 1}, {}, "warmup must be <="),
    ({}, {"seed": 2 ** 63}, "seed must be <= 4294967295"),
    ({}, {"seed": MAX_SEED + 1}, "seed"),
    ({}, {"seed": -1}, "seed"),
    ({}, {"effect": "rays", "methods": ["ldi"], "effect_params": {"rays_per_pixel": 1025}}, "rays_per_pixel"),
    ({}, {"methods": ["ldm"], "params": {"ldm": {"visibility_bias": float("inf")}}}, "visibility_bias=inf .* finite"),
    # effect parameters the effect does not use: one rule, naming the effect's parameters
    ({}, {"effect": "rays", "methods": ["ldi"], "d_max": 0.5}, "'rays' does not use parameter 'd_max'.*ray_kind"),
    ({}, {"effect": "rays", "methods": ["ldi"], "effect_params": {"ray_kind": ["diffuse", "glossy"],
                                                                  "light_radius": 0.2}}, "light_radius"),
    ({}, {"effect_params": {"ray_kind": "ao"}}, "'ao' does not use parameter 'ray_kind'.*d_max, falloff"),
    ({}, {"effect": ["ao", "direct"], "methods": "all", "d_max": 0.5}, "'direct' does not use parameter 'd_max'"),
])
def test_suite_rejects(head, run, needle):
    with pytest.raises(LdbenchError, match="(?s).*" + needle.replace("^", r"\^")):
        suite(head, **run)


def test_suite_accepts_declared_types():
    s = suite({"frames": 3, "warmup": 0, "spp": 4, "name": "ok", "size": [16, 12]},
              params={"hbao": {"directions": 8, "angle_bias": 1, "blur": False}})
    j = s.jobs[0]
    assert (j.width, j.height, j.frames, j.warmup, j.spp, s.name) == (16, 12, 3, 0, 4, "ok")
    p = get_method("hbao").Params.from_dict(dict(j.params))
    assert p.angle_bias == 1.0 and isinstance(p.angle_bias, float) and p.blur is False  # ints widen to floats
    # methods = "all": params for any method that supports the effect are used
    s = suite_from_dict({"suite": {"size": "16x16"}, "run": [{"scene": "cornell", "effect": "ao",
                         "params": {"hbao": {"directions": 4}}}]}, name="t")
    assert "hbao" in {j.method for j in s.jobs} and len({j.method for j in s.jobs}) > 1


@pytest.mark.parametrize("kind,value,ok", [
    (bool, True, True), (bool, "false", True), (bool, 1, False), (bool, 2, False), (bool, "yes", False),
    (int, 3, True), (int, "3", True), (int, True, False), (int, 2.0, False), (int, 2.5, False),
    (float, 2, True), (float, 0.5, True), (float, "inf", True), (float, "1e-3", True), (float, True, False),
    (float, "nan", False), (float, "fast", False),
    (str, "grow", True), (str, 5, False), (str, True, False),
])
def test_coerce_is_strict(kind, value, ok):
    if ok:
        assert isinstance(_coerce(kind, value, "p"), kind)
    else:
        with pytest.raises(LdbenchError, match="parameter p="):
            _coerce(kind, value, "p")


def run_args(*argv):
    return suite_from_args(build_parser().parse_args(["run", *argv]))


ADHOC = ("--scene", "cornell", "--method", "hbao", "--effect", "ao", "--size", "16x16")


@pytest.mark.parametrize("extra,needle", [
    (["--set", "hbao.blur_sharpness=true"], "blur_sharpness"),  # not 1.0
    (["--set", "hbao.blur=2"], "blur"),  # not True
    (["--set", "hbao.directions=2.5"], "directions"),
    (["--set", "hbao.integral=1"], "integral"),
    (["--warmup", "-3"], "warmup"),
    (["--frames", "0"], "frames"),
    (["--spp", "0"], "spp"),
    (["--spp", str(10 ** 11)], "spp"),
    (["--size", "1x1"], "size"),
    (["--frames", str(10 ** 20)], "frames must be <="),
    (["--set", f"hbao.seed={2 ** 31}"], "seed=2147483648 of method 'hbao' above its maximum"),
    (["--warmup", str(10 ** 20)], "warmup must be <="),
])
def test_command_line_rejects(tmp_path, extra, needle):
    with pytest.raises(LdbenchError, match=needle):
        run_args(*ADHOC, *extra)
    f = tmp_path / "s.toml"  # the same flags over a suite file (there they used to be ignored)
    f.write_text('[suite]\nsize = "16x16"\n[[run]]\nscene = "cornell"\neffect = "ao"\nmethods = ["hbao"]\n')
    with pytest.raises(LdbenchError, match=needle):
        run_args(str(f), *extra)


def test_a_grouped_parameter_is_held_to_the_integer_bound():
    """structure.pool_capacity (no declared maximum) sits in a parameter group: the 2^31 - 1 bound of
    ldbench.harness.suite.method_params applies to it as to a flat parameter, by its dotted and its earlier name."""
    for kv in (f"ldm.structure.pool_capacity={2 ** 31}", f"ldm.pool_capacity={2 ** 31}"):
        with pytest.raises(LdbenchError, match="structure.pool_capacity=2147483648 of method 'ldm' above its max"):
            run_args("--scene", "cornell", "--method", "ldm", "--effect", "ao", "--size", "16x16", "--set", kv)


def test_a_sweep_may_give_a_parameter_some_of_its_kinds_use():
    """ray_kind = [diffuse, glossy, shadow] with light_radius: shadow uses it (the bundled suites do this)."""
    s = suite(effect="rays", methods=["ldi"], effect_params={"ray_kind": ["diffuse", "shadow"], "light_radius": 0.2})
    assert sorted(j.effect.ray_kind for j in s.jobs) == ["diffuse", "shadow"]


@pytest.mark.parametrize("extra,needle", [
    (["--seed", str(2 ** 63)], "seed must be <="),
    (["--seed", "-1"], "seed must be >="),
    (["--effect-set", "d_max=0.5"], "does not use parameter 'd_max'"),
    (["--d-max", "0.5", "--ray-kind", "glossy"], "with ray_kind='glossy' does not use parameter 'd_max'"),
])
def test_command_line_rejects_rays(extra, needle):
    with pytest.raises(LdbenchError, match=needle):
        run_args("--scene", "cornell", "--method", "ldi", "--effect", "rays", *extra)


def test_retries_bounded():
    pytest.importorskip("ray")
    from ldbench.harness.executors.ray import MAX_RETRIES, RayExecutor

    with pytest.raises(LdbenchError, match=f"--retries must be <= {MAX_RETRIES}"):
        RayExecutor(retries=MAX_RETRIES + 1)


def test_command_line_overrides_a_suite(tmp_path):
    f = tmp_path / "s.toml"
    f.write_text('[suite]\nsize = "16x16"\nspp = 8\nframes = 4\n[[run]]\nscene = "cornell"\neffect = "ao"\n'
                 'methods = ["hbao"]\n')
    j = run_args(str(f), "--spp", "2", "--frames", "1", "--warmup", "0", "--size", "8x6",
                 "--set", "hbao.blur=false").jobs[0]
    assert (j.spp, j.frames, j.warmup, j.width, j.height, dict(j.params)) == (2, 1, 0, 8, 6, {"blur": False})


def test_parse_size():
    assert parse_size("3x3") == (3, 3) and parse_size([640, 480]) == (640, 480)
    for bad in ("3x", "x3", "3.5x4", "-4x4", "4x4x4", (4,), (4, 4.0), 44):
        with pytest.raises(LdbenchError, match="size"):
            parse_size(bad)


def test_size_minimum_is_what_the_metrics_need():
    from ldbench.core import metrics

    a = np.random.default_rng(0).random((3, 3, 3)).astype(np.float32)
    assert np.isfinite(metrics.all_metrics(a, a * 0.5)["ssim"])
    with pytest.raises(LdbenchError):
        metrics.all_metrics(a[:2, :2], a[:2, :2])


@dataclasses.dataclass(eq=False)
class FakeScene:
    name: str
    params: dict
    h: str = "0123456789abcdef"

    def content_hash(self):
        return self.h


def test_default_size_is_the_xml_film():
    s = suite_from_dict({"run": [{"scene": "cornell", "effect": "ao", "methods": ["hbao"]}]}, name="t")
    j = s.jobs[0]
    assert j.width is None  # not decided before the scene is loaded
    scenes = {j.scene_key: FakeScene("x", {"film": (40, 30)})}
    assert (resolve_sizes(s.jobs, scenes)[0].width, resolve_sizes(s.jobs, scenes)[0].height) == (40, 30)
    scenes = {j.scene_key: FakeScene("x", {})}
    assert (resolve_sizes(s.jobs, scenes)[0].width, resolve_sizes(s.jobs, scenes)[0].height) == DEFAULT_SIZE
    sized = suite_from_dict({"suite": {"size": "20x10"}, "run": [{"scene": "cornell", "effect": "ao",
                             "methods": ["hbao"]}]}, name="t").jobs
    assert (resolve_sizes(sized, scenes)[0].width, resolve_sizes(sized, scenes)[0].height) == (20, 10)


def test_unique_scene_names():
    from ldbench.core.scenes import load_scene

    a, b = FakeScene("scene", {}, "aaaaaa11"), FakeScene("scene", {}, "bbbbbb22")
    c, d = load_scene("cornell"), load_scene("cornell", subdivide=2)
    out = unique_scene_names({("a/scene.xml", ()): a, ("b/scene.xml", ()): b,
                              ("cornell", ()): c, ("cornell", (("subdivide", 2),)): d})
    assert out[("a/scene.xml", ())].name == "scene-aaaaaa" and out[("b/scene.xml", ())].name == "scene-bbbbbb"
    assert out[("cornell", ())].name == "cornell" and out[("cornell", (("subdivide", 2),))].name == "cornell"


def test_camera_sees_geometry():
    class Ref:
        mask = np.zeros((4, 4), bool)

    with pytest.raises(LdbenchError, match="sees no geometry"):
        camera_sees_geometry(FakeScene("s", {}), Ref(), 4, 4)
    Ref.mask[1, 2] = True
    camera_sees_geometry(FakeScene("s", {}), Ref(), 4, 4)


def test_a_bundled_suite_by_name(tmp_path, monkeypatch):
    """`ldbench run default` from any folder: a bundled suite is found by its name."""
    from ldbench.harness.suite import load_suite

    monkeypatch.chdir(tmp_path)
    s = load_suite("default")
    assert s.name == "default" and s.jobs
    assert load_suite("suites/default.toml").name == "default"
