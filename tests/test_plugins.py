"""Methods, effects and scenes from outside ldbench (ldbench/core/plugins.py): entry points,
``package.module:Class`` names, one error for two classes with one name, provenance columns, and the example plugin of
examples/example-ao installed into a fresh virtual environment and run from outside the source tree,
under the local and the Ray executor. Nothing here is marked slow: `make test` (CI) runs all of it
(about 40 s on llvmpipe, the installed-plugin test about 25 s of that).
"""
import importlib.util
import json
import os
import shutil
import subprocess
import sys
import sysconfig
import textwrap
from pathlib import Path

import pytest

from ldbench.core import plugins
from ldbench.harness.cli import main

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "example-ao"
TINY = ["--size", "16x16", "--spp", "1", "--frames", "1", "--warmup", "0", "--no-report", "--no-progress"]


@pytest.fixture
def clean_plugins(monkeypatch):
    """No development plugin registered before or after (register_reference writes os.environ)."""
    monkeypatch.setenv(plugins.ENV[plugins.METHOD_GROUP], "")
    from ldbench.core.effects import base as effects_base

    monkeypatch.setattr(effects_base, "_REGISTRY", None)
    yield


def _module(folder: Path, name: str, text: str) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / f"{name}.py").write_text(textwrap.dedent(text))
    return folder


def _fake_dist(folder: Path, dist: str, version: str, entry_points: str) -> None:
    """A distribution's metadata on ``folder`` (what pip would install), entry points included."""
    info = folder / f"{dist.replace('-', '_')}-{version}.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {dist}\nVersion: {version}\n")
    (info / "entry_points.txt").write_text(textwrap.dedent(entry_points))


DUP_METHOD = """
    from ldbench.methods.hbao import HBAO

    class Dup(HBAO):
        name = "hbao"
"""


def test_module_class_name_with_a_taken_name_is_one_line(tmp_path, monkeypatch, capsys, clean_plugins):
    monkeypatch.syspath_prepend(str(_module(tmp_path / "src", "dupmod", DUP_METHOD)))
    rc = main(["run", "--scene", "cornell", "--method", "dupmod:Dup", "--effect", "ao", "--out",
               str(tmp_path / "r"), *TINY])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and len(err.splitlines()) == 1, err
    assert "two methods are named 'hbao'" in err and "ldbench.methods.hbao.HBAO (ldbench)" in err and "dupmod:Dup" in err
    assert not (tmp_path / "r").exists()


def test_the_builtin_class_by_module_class_is_no_name_clash(tmp_path, capsys, clean_plugins):
    """``--method ldbench.methods.hbao:HBAO`` names the built-in class itself: registering it beside the
    built-in registration is the same class twice, not two methods named 'hbao'."""
    from ldbench.harness import records
    from ldbench.methods.base import canonical_name, get_method, registry
    from ldbench.methods.hbao import HBAO

    ref = f"{HBAO.__module__}:{HBAO.__qualname__}"
    assert ref == "ldbench.methods.hbao:HBAO"
    assert canonical_name(ref) == "hbao" and plugins.references() == [(ref, plugins._import_root(HBAO))]
    assert registry()["hbao"] is HBAO and get_method(ref) is HBAO and get_method("hbao") is HBAO
    rc = main(["run", "--scene", "cornell", "--method", ref, "--effect", "ao", "--out", str(tmp_path / "r"), *TINY])
    assert rc == 0, capsys.readouterr().err
    row = records.read_results(tmp_path / "r").iloc[0]
    assert row["method"] == "hbao" and row["status"] == "ok"


def test_entry_point_duplicates_name_both_sources(tmp_path, monkeypatch, clean_plugins):
    from ldbench.core.effects.base import registry as effects
    from ldbench.core.errors import LdbenchError
    from ldbench.methods.base import registry

    src = _module(tmp_path / "site", "dupmod_ep", DUP_METHOD + """
    from ldbench.core.effects.ao import AO

    class DupAO(AO):
        pass
""")
    _fake_dist(src, "dup-plugin", "2.5", """
        [ldbench.methods]
        twin = dupmod_ep:Dup
        [ldbench.effects]
        twin-ao = dupmod_ep:DupAO
    """)
    monkeypatch.syspath_prepend(str(src))
    with pytest.raises(LdbenchError) as e:
        registry()
    msg = str(e.value)
    assert "\n" not in msg and "ldbench.methods.hbao.HBAO (ldbench)" in msg
    assert "dupmod_ep.Dup (distribution dup-plugin 2.5, entry point twin)" in msg, msg
    with pytest.raises(LdbenchError) as e:
        effects()
    assert "two effects are named 'ao'" in str(e.value) and "dup-plugin 2.5" in str(e.value)


def test_entry_point_method_and_effect_are_registered(tmp_path, monkeypatch, clean_plugins):
    from ldbench.core.effects.base import registry as effects
    from ldbench.methods.base import registry

    src = _module(tmp_path / "site", "newmod", """
    from ldbench.core.effects.ao import AO
    from ldbench.methods.hbao import HBAO

    class New(HBAO):
        name = "new-hbao"

    class NewAO(AO):
        name = "ao2"
""")
    _fake_dist(src, "new-plugin", "1.0", "[ldbench.methods]\nn = newmod:New\n[ldbench.effects]\ne = newmod:NewAO\n")
    monkeypatch.syspath_prepend(str(src))
    assert registry()["new-hbao"].__module__ == "newmod"
    assert type(effects()["ao2"]).__name__ == "NewAO"
    prov = plugins.provenance(registry()["new-hbao"])
    assert (prov["module"], prov["dist"], prov["dist_version"]) == ("newmod", "new-plugin", "1.0")


ROOM_SCENE = '''
    """A new scene is this one module (and an entry point naming its class)."""
    from dataclasses import dataclass

    from ldbench.core.meshio import box_parts, merge
    from ldbench.core.params import param
    from ldbench.core.scene import Camera, Scene, SpotLight
    from ldbench.core.scenes.base import SceneBuilder, SceneParams, part_mesh, rgb


    @dataclass(frozen=True)
    class RoomParams(SceneParams):
        side: float = param(2.0, "side of the room (m)", lo=0.5, hi=100.0)
        cells: int = param(1, "cells along every side of a wall", lo=1, hi=64)
        albedo: tuple = rgb((0.7, 0.7, 0.7), "the walls' albedo")


    class Room(SceneBuilder):
        """An open cubic room lit from its ceiling.

        For the plugin test only."""

        name = "test-room"
        Params = RoomParams

        def build(self, p):
            s = p.side
            room = box_parts((-s / 2, 0, -s / 2), (s / 2, s, s / 2), p.cells, skip=("+z",), inward=True)
            walls = merge(room.values())
            cam = Camera(origin=(0.0, s / 2, 2 * s), target=(0.0, s / 2, 0.0), fov_y=45.0)
            light = SpotLight(position=(0.0, 0.95 * s, 0.0), target=(0.0, 0.0, 0.0), intensity=(10.0,) * 3,
                              cutoff_angle=70.0)
            return Scene("test-room", [part_mesh("walls", walls, p.albedo)], cam, [light])
'''


def test_a_new_scene_is_one_module(tmp_path, monkeypatch, capsys, clean_plugins):
    """A scene module outside ldbench, declared by an entry point of group ``ldbench.scenes``: discovered, its
    parameters validated like a built-in scene's (one line naming scene and parameter), listed by
    ``ldbench scenes``, and run through the command line like any scene."""
    from ldbench.core.errors import LdbenchError
    from ldbench.core.scenes import builders, load_scene
    from ldbench.harness import records

    src = _module(tmp_path / "site", "roomscene", ROOM_SCENE)
    _fake_dist(src, "room-scene", "0.3", "[ldbench.scenes]\nroom = roomscene:Room\n")
    assert "test-room" not in builders()
    monkeypatch.syspath_prepend(str(src))
    assert builders()["test-room"].__module__ == "roomscene"

    sc = load_scene("test-room:side=3,cells=2e0", albedo="0.5")  # the spellings of a built-in scene's values
    assert sc.params == {"side": 3.0, "cells": 2, "albedo": [0.5, 0.5, 0.5]} and sc.triangle_count == 5 * 2 * 4
    assert load_scene(sc.name, **sc.params).content_hash() == sc.content_hash()
    for params, words in (({"side": 0.1}, "side=0.1 below its minimum 0.5"), ({"cells": 1.5}, "cells=1.5"),
                          ({"albedo": "1, 2, 3"}, "albedo=(1.0, 2.0, 3.0) outside [0, 1]"),
                          ({"colour": 1}, "unknown parameter 'colour'")):
        with pytest.raises(LdbenchError) as e:
            load_scene("test-room", **params)
        assert "\n" not in str(e.value) and "'test-room'" in str(e.value) and words in str(e.value), e.value

    assert main(["scenes"]) == 0
    assert "test-room" in capsys.readouterr().out
    out = tmp_path / "r"
    rc = main(["run", "--scene", "test-room", "--scene-set", "side=0.1", "--method", "direct-raster", "--effect",
               "direct", "--out", str(out), *TINY])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and len(err.splitlines()) == 1 and "scene 'test-room'" in err and "side" in err, err
    assert not out.exists()
    rc = main(["run", "--scene", "test-room", "--scene-set", "side=3", "--method", "direct-raster", "--effect",
               "direct", "--out", str(out), *TINY])
    assert rc == 0, capsys.readouterr().err
    row = records.read_results(out).iloc[0]
    assert (row["scene"], row["status"], row["triangles"]) == ("test-room", "ok", 5 * 2)
    assert row["psnr"] > 10, row["psnr"]  # the room is lit and the method sees it as the reference does


@pytest.mark.parametrize("name,words", [("cornell", "two scenes are named 'cornell'"),
                                        ("dragon", "the registered real scene")])
def test_a_scene_plugin_may_not_take_a_name_in_use(tmp_path, monkeypatch, clean_plugins, name, words):
    from ldbench.core.errors import LdbenchError
    from ldbench.core.scenes import builders

    module = f"dupscene_{name}"  # one module per case: a module imported once stays imported
    src = _module(tmp_path / "site", module, ROOM_SCENE.replace('name = "test-room"', f'name = "{name}"'))
    _fake_dist(src, "dup-scene", "1.0", f"[ldbench.scenes]\ndup = {module}:Room\n")
    monkeypatch.syspath_prepend(str(src))
    with pytest.raises(LdbenchError) as e:
        builders()
    msg = str(e.value)
    assert "\n" not in msg and words in msg and f"{module}.Room (distribution dup-scene 1.0, entry point dup)" in msg


def test_broken_references_are_one_line(tmp_path, monkeypatch, capsys, clean_plugins):
    monkeypatch.syspath_prepend(str(_module(tmp_path / "src", "okmod", "X = 1\n")))
    for ref, why in (("nosuchmod:Thing", "cannot import"), ("okmod:Missing", "has no 'Missing'"),
                     ("okmod:X", "not a named Method subclass")):
        rc = main(["run", "--scene", "cornell", "--method", ref, "--effect", "ao", "--out", str(tmp_path / "r"),
                   *TINY])
        err = capsys.readouterr().err.strip()
        assert rc == 2 and len(err.splitlines()) == 1 and why in err, (ref, err)


def test_version_flag(capsys):
    with pytest.raises(SystemExit) as e:
        main(["--version"])
    assert e.value.code == 0
    out = capsys.readouterr().out
    assert out.startswith(f"ldbench {plugins.ldbench_version()} (") and plugins.ldbench_version() == "0.1.0"


# --------------------------------------------------------------------------------------------------
# the example plugin, installed into a fresh virtual environment


def _git(cwd, *args):
    return subprocess.run(["git", "-C", str(cwd), "-c", "user.email=t@example.com", "-c", "user.name=t", *args],
                          check=True, capture_output=True, text=True).stdout


@pytest.fixture(scope="module")
def venv(tmp_path_factory):
    """A venv that sees this environment's dependencies (a .pth line: no network), ldbench as installed here
    (``pip install -e .``: this tree), and the example plugin installed from its own git repository (``pip install
    git+file://``, as one would from GitHub): the plugin's commit is that repository's."""
    if shutil.which("git") is None:
        pytest.skip("git not installed")
    tmp = tmp_path_factory.mktemp("plugin")
    repo = tmp / "example-ao"
    shutil.copytree(EXAMPLE, repo, ignore=shutil.ignore_patterns("__pycache__", "*.egg-info", "build"))
    _git(repo, "init", "-q")
    _git(repo, "add", ".")
    _git(repo, "commit", "-q", "-m", "example")
    commit = _git(repo, "rev-parse", "HEAD").strip()
    env_dir = tmp / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(env_dir)], check=True, timeout=120)
    py = env_dir / "bin" / "python"
    purelib = Path(subprocess.run([str(py), "-c", "import sysconfig; print(sysconfig.get_path('purelib'))"],
                                  check=True, capture_output=True, text=True).stdout.strip())
    deps = {sysconfig.get_path("purelib"), sysconfig.get_path("platlib")}
    # site directories (their .pth files run): this environment's ldbench install (editable or not) and
    # its dependencies
    (purelib / "ldbench-test-deps.pth").write_text(
        "import site; " + "; ".join(f"site.addsitedir({d!r})" for d in sorted(deps)) + "\n")
    p = subprocess.run([sys.executable, "-m", "pip", "--python", str(py), "install", "-q", "--no-deps",
                        "--no-build-isolation", "--no-index", f"git+file://{repo}"],
                       capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr[-3000:]
    work = tmp / "work"
    work.mkdir()
    env = {k: v for k, v in os.environ.items() if not k.startswith("LDBENCH_PLUGIN")}
    env.pop("PYTHONPATH", None)
    env.update(PYTHONNOUSERSITE="1", LDBENCH_CACHE=str(tmp / "ref-cache"))
    return {"py": py, "work": work, "env": env, "commit": commit, "purelib": purelib}


def _ldbench(v, *args, timeout=300):
    p = subprocess.run([str(v["py"]), "-m", "ldbench.harness.cli", *map(str, args)], cwd=v["work"], env=v["env"],
                       capture_output=True, text=True, timeout=timeout)
    assert p.returncode == 0, f"{args} -> {p.returncode}\n{p.stdout[-2000:]}\n{p.stderr[-3000:]}"
    return p.stdout


def _rows(v, run):
    import pandas as pd

    return pd.read_parquet(v["work"] / run / "results.parquet").set_index("method")


@pytest.mark.slow  # pip-installs the example and starts a Ray cluster (~12 s on two cores)
def test_example_plugin_installed_lists_and_runs_local_and_ray(venv):
    import pandas as pd

    listed = _ldbench(venv, "methods")
    assert "example-ao  [example]  effects: ao" in listed and "samples" not in listed, listed
    params = _ldbench(venv, "methods", "example-ao")
    assert params.startswith("example-ao  [example]  effects: ao") and "samples" in params, params
    _ldbench(venv, "run", "--scene", "cornell", "--method", "example-ao", "--method", "hbao", "--effect", "ao",
             "--d-max", "0.5", "--out", "local", *TINY)
    local = _rows(venv, "local")
    ours = local.loc["example-ao"]
    assert ours["status"] == "ok" and 5 < ours["psnr"] < 60, ours["psnr"]
    assert (ours["method_module"], ours["method_dist"], ours["method_version"], ours["method_commit"]) == \
        ("example_ao", "ldbench-example-ao", "0.3.1", venv["commit"])
    assert local.loc["hbao", "method_dist"] == "ldbench"
    theirs, own = local.loc["hbao", "method_commit"], ours["commit"]  # ldbench's own (None outside git)
    assert (pd.isna(theirs) and pd.isna(own)) or theirs == own

    # under Ray, with a package.module:Class method from the working folder beside it
    if importlib.util.find_spec("ray") is None:
        pytest.skip("the local run passed; the Ray run needs ray (the test extra installs it)")
    (venv["work"] / "devao.py").write_text("from example_ao import ExampleAO\n\n\nclass DevAO(ExampleAO):\n"
                                           "    name = 'dev-ao'\n")
    _ldbench(venv, "run", "--scene", "cornell", "--method", "example-ao", "--method", "devao:DevAO", "--effect",
             "ao", "--d-max", "0.5", "--executor", "ray", "--out", "ray", *TINY)
    ray_rows = _rows(venv, "ray")
    assert (ray_rows["status"] == "ok").all(), ray_rows["status"]
    assert ray_rows.loc["example-ao", "psnr"] == pytest.approx(ours["psnr"], abs=1e-9)
    assert ray_rows.loc["dev-ao", "psnr"] == pytest.approx(ours["psnr"], abs=1e-9)  # the same kernel
    assert ray_rows.loc["dev-ao", "method_module"] == "devao" and pd.isna(ray_rows.loc["dev-ao", "method_dist"])
    assert ray_rows.loc["example-ao", "method_commit"] == venv["commit"]


def test_installed_wheel_records_the_commit_it_was_built_from(tmp_path):
    """setup.py writes ldbench/core/build_info.json into the wheel; an installed ldbench reports that commit
    (rows' ``commit`` column and ``--version``), not None."""
    if shutil.which("git") is None or not (ROOT / ".git").exists():
        pytest.skip("needs git and a checkout")
    src = tmp_path / "src"
    subprocess.run(["git", "clone", "-q", str(ROOT), str(src)], check=True, timeout=120)
    commit = _git(src, "rev-parse", "HEAD").strip()
    p = subprocess.run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "--no-build-isolation", "--no-index",
                        "-w", str(tmp_path / "dist"), str(src)], capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr[-3000:]
    (wheel,) = (tmp_path / "dist").glob("ldbench-*.whl")
    env_dir = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(env_dir)], check=True, timeout=120)
    py = env_dir / "bin" / "python"
    purelib = Path(subprocess.run([str(py), "-c", "import sysconfig; print(sysconfig.get_path('purelib'))"],
                                  check=True, capture_output=True, text=True).stdout.strip())
    deps = {sysconfig.get_path("purelib"), sysconfig.get_path("platlib")}
    (purelib / "ldbench-test-deps.pth").write_text("".join(f"{d}\n" for d in sorted(deps)))
    p = subprocess.run([sys.executable, "-m", "pip", "--python", str(py), "install", "-q", "--no-deps", "--no-index",
                        str(wheel)], capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr[-3000:]
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "LDBENCH_COMMIT", "LDBENCH_DIRTY")}
    out = subprocess.run([str(py), "-c", "import json, ldbench.core.plugins as p; print(p.__file__); "
                          "print(json.dumps(p.ldbench_info()))"], cwd=tmp_path, env=env, capture_output=True,
                         text=True, check=True).stdout.splitlines()
    assert Path(out[0]).is_relative_to(purelib), out
    assert json.loads(out[1]) == {"version": "0.1.0", "commit": commit, "dirty": False}


def test_the_run_seed_reaches_methods(tmp_path, monkeypatch, clean_plugins):
    """--seed reaches a method as ``run_seed`` (before setup) and ``View.seed``; a method's own seed
    parameter is mixed with it (Method.seed_for), unchanged at run seed 0."""
    import numpy as np

    from ldbench.harness.executors import run_jobs
    from ldbench.harness.suite import suite_from_dict
    from ldbench.methods.base import Method
    from ldbench.core.exr import read_exr

    monkeypatch.syspath_prepend(str(_module(tmp_path / "src", "seedprobe", """
        from ldbench.methods.hbao import HBAO

        class Probe(HBAO):
            name = "seed-probe"

            def setup(self, gpu, scene):
                self.setup_seed = self.run_seed
                super().setup(gpu, scene)

            def frame(self, view, effect, inputs=None):
                r = super().frame(view, effect, inputs)
                r.counters = {**r.counters, "setup_seed": self.setup_seed, "view_seed": view.seed,
                              "mixed": self.seed_for(self.params.seed)}
                return r
    """)))

    def run(seed):
        out = tmp_path / f"s{seed}"
        suite = suite_from_dict({"suite": {"name": "seed", "size": "16x16", "spp": 2, "warmup": 0, "frames": 1},
                                 "run": [{"scene": "cornell", "effect": "ao", "d_max": 0.5, "seed": seed,
                                          "methods": ["seedprobe:Probe"], "params": {"seed-probe": {"blur": False}}}]},
                                name="seed")
        row = run_jobs(suite, out, progress=False, report=False).iloc[0]
        return row, read_exr(out / row["images"]["exr"])["Y"]

    r0, img0 = run(0)
    r7, img7 = run(7)
    assert r0["counters"] == {**r0["counters"], "setup_seed": 0, "view_seed": 0, "mixed": 0}
    assert r7["counters"]["setup_seed"] == 7 and r7["counters"]["view_seed"] == 7
    assert r7["counters"]["mixed"] == (7 * 0x9E3779B9) % 2**32
    assert not np.array_equal(img0, img7)  # another rotation texture
    m = Method()
    assert m.seed_for(5) == 5  # run seed 0: the parameter itself
    m.run_seed = 1
    assert m.seed_for(5) != 5 and 0 <= m.seed_for(5, bits=31) < 2**31


def test_new_method_template_installs_lists_and_runs(venv, tmp_path, capsys):
    assert main(["new-method", "tmpl-ao", "--out", str(tmp_path / "tmpl")]) == 0
    assert main(["new-method", "tmpl-ao", "--out", str(tmp_path / "tmpl")]) == 2  # never overwrites
    assert main(["new-method", "Bad Name", "--out", str(tmp_path / "x")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 2 and "exists" in err[0] and "method name" in err[1]
    p = subprocess.run([sys.executable, "-m", "pip", "--python", str(venv["py"]), "install", "-q", "--no-deps",
                        "--no-build-isolation", "--no-index", str(tmp_path / "tmpl")],
                       capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr[-3000:]
    assert "tmpl-ao  []  effects: ao" in _ldbench(venv, "methods")
    _ldbench(venv, "run", "--scene", "cornell", "--method", "tmpl-ao", "--effect", "ao", "--d-max", "0.5",
             "--out", "tmpl", *TINY)
    row = _rows(venv, "tmpl").loc["tmpl-ao"]
    assert row["status"] == "ok" and row["psnr"] > 5 and row["method_dist"] == "ldbench-tmpl-ao"


def test_module_class_names_are_forwarded_to_workers(tmp_path, monkeypatch, clean_plugins):
    """A worker of a remote cluster does not inherit the driver's environment: the executor forwards the
    registered references (and their import folders) explicitly, and a worker resolves them by name."""
    from ldbench.harness.executors.ray import forwarded_env
    from ldbench.methods.base import canonical_name, get_method

    src = _module(tmp_path / "src", "fwdmod", "from ldbench.methods.hbao import HBAO\n\n\nclass Fwd(HBAO):\n    name = 'fwd'\n")
    monkeypatch.syspath_prepend(str(src))
    assert canonical_name("fwdmod:Fwd") == "fwd"
    env = dict(forwarded_env())
    assert json.loads(env[plugins.ENV[plugins.METHOD_GROUP]]) == [["fwdmod:Fwd", str(src)]]
    code = ("import os, sys; from ldbench.methods.base import get_method; print(get_method('fwd').__module__)")
    child = {k: v for k, v in os.environ.items() if not k.startswith("LDBENCH_PLUGIN")}
    child.update(env, PYTHONPATH=str(ROOT))  # what Worker.__init__ sets, in a fresh process elsewhere
    out = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=child, capture_output=True, text=True)
    assert out.returncode == 0 and out.stdout.strip() == "fwdmod", out.stderr[-2000:]
    assert get_method("fwd").__module__ == "fwdmod"


def test_example_ao_kernel_in_tree(monkeypatch, tmp_path, clean_plugins):
    """The example's SSAO against the reference (thresholds just below the measured 13.2 dB step and
    16.1 dB quadratic at 32², spp 16), and the quadratic mode weighting occluders below 1."""
    from ldbench.harness.executors import run_jobs
    from ldbench.harness.suite import suite_from_dict

    from ldbench.harness.newmethod import write_template

    write_template("tmpl-in-tree", out=tmp_path / "tmpl")  # the new-method template, measured 13.1 dB
    monkeypatch.syspath_prepend(str(tmp_path / "tmpl"))
    monkeypatch.syspath_prepend(str(EXAMPLE))
    suite = suite_from_dict({"suite": {"name": "ex", "size": "32x32", "spp": 16, "warmup": 0, "frames": 1},
                             "run": [{"scene": "cornell", "effect": "ao", "d_max": 0.5,
                                      "falloff": ["step", "quadratic"], "methods": ["example_ao:ExampleAO"]},
                                     {"scene": "cornell", "effect": "ao", "d_max": 0.5,
                                      "methods": ["tmpl_in_tree:TmplInTree"]}]},
                            name="ex")
    df = run_jobs(suite, tmp_path / "r", progress=False, report=False)
    assert df.set_index("method").loc["tmpl-in-tree", "psnr"] > 12.5
    df = df[df["method"] == "example-ao"]
    step, quad = (df[df["effect_params"].map(lambda e: e["falloff"] == f)].iloc[0] for f in ("step", "quadratic"))
    assert step["psnr"] > 12.5 and quad["psnr"] > 15.5, (step["psnr"], quad["psnr"])
    from ldbench.core.exr import read_exr

    mean = {f: read_exr(tmp_path / "r" / r["images"]["exr"])["Y"].mean() for f, r in (("s", step), ("q", quad))}
    assert mean["q"] > mean["s"] + 0.01, mean


def test_plugin_imports_that_raise_are_one_line(tmp_path, monkeypatch, capsys, clean_plugins):
    """A plugin module that raises anything but ImportError at import (RuntimeError, ZeroDivisionError,
    SystemExit), named by --method (local or Ray executor), by a suite or by LDBENCH_PLUGIN_METHODS: one
    line, exit 2."""
    from test_cli import assert_one_line_error

    src = tmp_path / "src"
    for name, body in (("boom_rt", "raise RuntimeError('plugin broke\\nsecond line')\n"),
                       ("boom_zero", "x = 1 / 0\n"), ("boom_exit", "import sys\nsys.exit(3)\n")):
        _module(src, name, body)
    monkeypatch.syspath_prepend(str(src))
    for mod, why in (("boom_rt", "RuntimeError: plugin broke"), ("boom_zero", "ZeroDivisionError"),
                     ("boom_exit", "SystemExit: 3")):
        ref = f"{mod}:Thing"
        rc = main(["run", "--scene", "cornell", "--method", ref, "--effect", "ao", "--out", str(tmp_path / "r"),
                   *TINY])
        assert_one_line_error(rc, capsys.readouterr().err, "cannot import", why)
        rc = main(["run", "--scene", "cornell", "--method", ref, "--effect", "ao", "--out", str(tmp_path / "r"),
                   "--executor", "ray", *TINY])  # refused before any worker starts
        assert_one_line_error(rc, capsys.readouterr().err, "cannot import", why)
        suite = tmp_path / f"{mod}.toml"
        suite.write_text(f'[suite]\nname = "s"\nsize = "16x16"\nspp = 1\nwarmup = 0\nframes = 1\n\n[[run]]\n'
                         f'scene = "cornell"\neffect = "ao"\nmethods = ["{ref}"]\n')
        rc = main(["run", str(suite), "--out", str(tmp_path / "r"), "--no-report", "--no-progress"])
        assert_one_line_error(rc, capsys.readouterr().err, "cannot import", why)
        monkeypatch.setenv(plugins.ENV[plugins.METHOD_GROUP], json.dumps([[ref, str(src)]]))
        assert_one_line_error(main(["methods"]), capsys.readouterr().err, "cannot import", why)
        monkeypatch.setenv(plugins.ENV[plugins.METHOD_GROUP], "")
    assert not (tmp_path / "r").exists()


def test_malformed_plugin_environment_is_one_line(monkeypatch, capsys, clean_plugins):
    from test_cli import assert_one_line_error

    for text in ("not json", "5", '{"a": 1}', '["abc"]', '[["a:B"]]', '[["a:B", "x", "y"]]', "[[1, 2]]",
                 '[["a:B", 5]]', "[null]"):
        monkeypatch.setenv(plugins.ENV[plugins.METHOD_GROUP], text)
        assert_one_line_error(main(["methods"]), capsys.readouterr().err, "LDBENCH_PLUGIN_METHODS")


BAD_OUTPUT = """
    import numpy as np
    from ldbench.methods.hbao import HBAO

    class NanImage(HBAO):
        name = "nan-image"

        def frame(self, view, effect, inputs=None):
            r = super().frame(view, effect, inputs).resolve()
            img = np.array(r.image, np.float64)
            img[0, 0], img[1, 1], img[2, 2], img[3, 3] = np.nan, np.inf, -np.inf, 1e300  # float32: inf
            r.image = img
            return r

    class NanMask(HBAO):
        name = "nan-mask"

        def frame(self, view, effect, inputs=None):
            r = super().frame(view, effect, inputs).resolve()
            r.mask = np.full(np.shape(r.image)[:2], np.nan, np.float32)
            return r

    class Huge(HBAO):
        name = "huge-memory"
        memory = 1e30

        def frame(self, view, effect, inputs=None):
            r = super().frame(view, effect, inputs)
            r.memory_bytes = {**r.memory_bytes, "huge": self.memory}
            return r

    class NegHuge(Huge):
        name = "neg-huge-memory"
        memory = -1e30

    class ExitZero(HBAO):
        name = "exit-zero"

        def frame(self, view, effect, inputs=None):
            raise SystemExit(0)

    class ExitThree(HBAO):
        name = "exit-three"

        def frame(self, view, effect, inputs=None):
            import sys

            r = super().frame(view, effect, inputs)
            r.image = lambda: sys.exit(3)  # when the runner reads the image back
            return r
"""


@pytest.mark.filterwarnings("error::RuntimeWarning")  # no numpy warning may reach stderr
def test_non_finite_images_masks_and_memory_of_a_method_never_ok(tmp_path, monkeypatch, clean_plugins):
    """``run`` (local executor; tests/test_executor_ray.py runs the same on Ray): a method's NaN/inf pixels are
    failed pixels (``degraded: 4 non-finite pixels``, counted in ``nonfinite``, finite metrics), a NaN mask is no
    coverage, and ``memory_bytes`` of ±1e30 or a ``sys.exit()`` in its frame is that row's error while every
    other row is written."""
    check_bad_output_rows(tmp_path, monkeypatch)


def test_sigterm_during_a_job_still_ends_the_run(tmp_path, monkeypatch):
    """SIGTERM (``Terminated``, what ldbench's handler raises) is not a plugin's ``sys.exit()``: it ends the run,
    exit status 15, and the partial run directory is deleted."""
    from ldbench.core.errors import Terminated, exit_on_sigterm
    from ldbench.harness.executors import run_jobs
    from ldbench.harness.suite import suite_from_dict
    from ldbench.methods.hbao import HBAO

    monkeypatch.setattr(HBAO, "frame", lambda self, *a, **k: exit_on_sigterm(15, None))
    suite = suite_from_dict({"suite": {"name": "t", "size": "8x8", "spp": 1, "warmup": 0, "frames": 1},
                             "run": [{"scene": "cornell", "effect": "ao", "d_max": 0.5, "methods": ["hbao"]}]},
                            name="t")
    with pytest.raises(Terminated) as e:
        run_jobs(suite, tmp_path / "run", progress=False, report=False)
    assert e.value.code == 15 and isinstance(e.value, SystemExit) and list(tmp_path.iterdir()) == []


def check_bad_output_rows(tmp_path, monkeypatch, executor=None):
    """The rows of :data:`BAD_OUTPUT`'s methods (``module:Class`` plugins) beside hbao's, on ``executor``."""
    import numpy as np

    from ldbench.harness.executors import run_jobs
    from ldbench.harness.suite import suite_from_dict

    monkeypatch.syspath_prepend(str(_module(tmp_path / "src", "badout", BAD_OUTPUT)))
    methods = ["hbao", "badout:NanImage", "badout:NanMask", "badout:Huge", "badout:NegHuge", "badout:ExitZero",
               "badout:ExitThree"]
    suite = suite_from_dict({"suite": {"name": "bad", "size": "16x16", "spp": 1, "warmup": 0, "frames": 1},
                             "run": [{"scene": "cornell", "effect": "ao", "d_max": 0.5, "methods": methods}]},
                            name="bad")
    df = run_jobs(suite, tmp_path / "run", progress=False, report=False, executor=executor).set_index("method")
    assert list(df.index) == ["hbao", "nan-image", "nan-mask", "huge-memory", "neg-huge-memory", "exit-zero",
                              "exit-three"]
    assert df.loc["hbao", "status"] == "ok" and df.loc["hbao", "nonfinite"] == 0
    nan = df.loc["nan-image"]
    assert nan["status"] == "degraded: 4 non-finite pixels" and nan["nonfinite"] == 4
    assert all(np.isfinite(nan[c]) for c in ("psnr", "ssim", "flip", "relmse"))
    assert nan["coverage"] <= df.loc["hbao", "coverage"]
    mask = df.loc["nan-mask"]
    assert mask["coverage"] == 0.0 and mask["nonfinite"] == 256 and mask["status"].startswith("degraded: ")
    for m in ("huge-memory", "neg-huge-memory"):
        assert df.loc[m, "status"].startswith("error: ") and "'huge'" in df.loc[m, "status"], df.loc[m, "status"]
    for m, code in (("exit-zero", 0), ("exit-three", 3)):  # a plugin's sys.exit() ends its job, not the run
        assert df.loc[m, "status"].startswith(f"error: sys.exit({code}) called inside the job"), df.loc[m, "status"]


# One in-tree method per effect, and the array its answer's poisoned values go into.
IN_TREE = [("ao", "hbao", "image", {"d_max": 0.5}), ("direct", "direct-raster", "image", {}),
           ("indirect", "ldm", "image", {}), ("glossy_indirect", "ldi", "image", {}),
           ("soft_shadows", "ldi", "image", {}), ("oit", "wboit", "image", {}),
           ("rays", "ldm", "t", {}), ("vpl_range", "cdi-vpl", "range", {})]


@pytest.mark.filterwarnings("error::RuntimeWarning")
@pytest.mark.parametrize("effect,method,where,extra", IN_TREE, ids=[e for e, *_ in IN_TREE])
def test_non_finite_answers_of_an_in_tree_method_are_never_ok(tmp_path, monkeypatch, effect, method, where, extra):
    """Every effect, through an in-tree method whose frame is made to answer +inf and -inf in two places (NaN
    where the effect reads it as no answer): the row is ``degraded``, counts the values in ``nonfinite``, and
    its metrics stay finite."""
    import numpy as np

    from ldbench.harness.executors import run_jobs
    from ldbench.harness.suite import suite_from_dict
    from ldbench.methods.base import get_method

    cls = get_method(method)
    frame = cls.frame

    def poisoned(self, *a, **k):
        r = frame(self, *a, **k).resolve()
        if where == "image":
            img = np.array(r.image, np.float32)
            img.reshape(-1, img.shape[-1])[[1, 5], 0] = (np.inf, -np.inf)
            r.image = img
        else:
            v = np.array(r.arrays[where], np.float32)
            v.reshape(-1)[[0, 3]] = (np.inf, -np.inf) if where == "range" else (-np.inf, -np.inf)
            r.arrays[where] = v
        return r

    monkeypatch.setattr(cls, "frame", poisoned)
    suite = suite_from_dict({"suite": {"name": "nan", "size": "16x16", "spp": 4, "warmup": 0, "frames": 1},
                             "run": [{"scene": "cornell", "effect": effect, "methods": [method], **extra}]},
                            name="nan")
    row = run_jobs(suite, tmp_path / "run", progress=False, report=False).iloc[0]
    assert row["nonfinite"] == 2 and row["status"].startswith("degraded: 2 non-finite"), (row["status"],
                                                                                        row["nonfinite"])
    metrics = [c for c in ("psnr", "ssim", "relmse", "rmse", "hit_agreement") if c in row and row[c] == row[c]]
    assert metrics and all(np.isfinite(row[c]) for c in metrics), {c: row[c] for c in metrics}


DEPTH_EFFECT = '''
    """A new effect is this one module: its definition and parameters, its own result column, its ground
    truth, and (here, to run it) a method that computes it; its shader sits beside it."""
    from dataclasses import dataclass

    import numpy as np

    from ldbench.core.bindings import B
    from ldbench.core.effects.base import ImageEffect
    from ldbench.core.gpu import read_texture
    from ldbench.core.params import ParamsBase
    from ldbench.methods.base import Method, Result
    from ldbench.methods.uniforms import set_uniforms
    from ldbench.references.render import Reference


    @dataclass(frozen=True)
    class DepthParams(ParamsBase):
        pass


    class Depth(ImageEffect):
        """The eye distance of the surface through each pixel's centre."""

        name = "depth"
        Params = DepthParams
        channels = 1
        units = "eye distance (scene units)"
        columns = {**ImageEffect.columns, "depth_err_max": "float"}

        def stochastic(self, params):
            return False

        def render_reference(self, scene, params, *, width, height, spp, seed, inputs, exact):
            hits = exact.primary_hits(scene, width, height)
            mean = np.where(hits["mask"], hits["distance"], 0.0).astype(np.float32)[..., None]
            return Reference(mean=mean, variance=np.zeros_like(mean), mask=hits["mask"],
                             meta={"spp": 1, "variant": "exact"})

        def score(self, result, reference, *, scene, inputs, stage_ms):
            m = super().score(result, reference, scene=scene, inputs=inputs, stage_ms=stage_ms)
            img, covered = self.method_image(result, reference)
            both = reference.mask & covered
            m["depth_err_max"] = float(np.abs(img - reference.mean)[both].max()) if both.any() else float("nan")
            return m


    class GDepth(Method):
        name = "g-depth"
        paper = "example"
        effects = frozenset({"depth"})

        def setup(self, gpu, scene):
            self.setup_scene(gpu, scene)
            self.prog = gpu.compute(self.shader("depth.glsl"))
            self._size = None

        def frame(self, view, effect, inputs=None):
            w, h = view.width, view.height
            if self._size != (w, h):
                self.out, self._size = self.res.texture("depth", (w, h), 1, "f4"), (w, h)
            with self.gpu.stage("gbuffer"):
                self.gbuf.render(view)
            with self.gpu.stage("depth"):
                set_uniforms(self.prog, g_position=0, eye=tuple(view.camera.origin))
                self.gbuf.bind(0)
                self.out.bind_to_image(B.OUT_IMAGE, read=False, write=True)
                self.prog.run((w + 7) // 8, (h + 7) // 8)
            self.gpu.ctx.memory_barrier()
            out = self.out
            return Result(image=lambda: read_texture(out, 1), mask=self.gbuf.mask, memory_bytes=self.res.by_buffer())
'''

DEPTH_GLSL = """#include "common/common.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
layout(r32f, binding = B_OUT_IMAGE) writeonly uniform image2D out_depth;
uniform sampler2D g_position;  // world position, w = 1 where the pixel's view ray hits
uniform vec3 eye;
void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(p, imageSize(out_depth)))) return;
    vec4 pos = texelFetch(g_position, p, 0);
    imageStore(out_depth, p, vec4(pos.w < 0.5 ? 0.0 : distance(pos.xyz, eye)));
}
"""


def test_a_new_effect_is_one_module(tmp_path, monkeypatch, capsys, clean_plugins):
    """An effect module outside ldbench (an entry point of group ``ldbench.effects``, with a method for it):
    ``run --effect depth`` renders its own ground truth, scores it with its own column, and the report
    captions its error map in its own units; nothing of ldbench names the effect."""
    from ldbench.harness import records

    src = _module(tmp_path / "site", "depthfx", DEPTH_EFFECT)
    (src / "depth.glsl").write_text(DEPTH_GLSL)
    _fake_dist(src, "depth-effect", "0.1", "[ldbench.effects]\ndepth = depthfx:Depth\n"
                                           "[ldbench.methods]\ng-depth = depthfx:GDepth\n")
    monkeypatch.syspath_prepend(str(src))
    out = tmp_path / "r"
    rc = main(["run", "--scene", "cornell", "--method", "g-depth", "--effect", "depth", "--size", "24x24",
               "--spp", "1", "--frames", "1", "--warmup", "0", "--no-progress", "--out", str(out)])
    assert rc == 0, capsys.readouterr().err
    row = records.read_results(out).iloc[0]
    assert (row["effect"], row["status"], row["coverage"]) == ("depth", "ok", 1.0), row["status"]
    # the G-buffer's position against Mitsuba's hit through the same pixel centre: float rounding of a
    # distance of about 3.5 (the test bound of the G-buffer's own exactness test, 2e-5 of the eye distance)
    assert row["depth_err_max"] < 1e-4 and row["psnr"] > 60, (row["depth_err_max"], row["psnr"])
    maps = [json.loads(p.read_text()) for p in out.rglob("maps.json")]
    assert [m["abs"]["definition"] for m in maps] == ["|test − reference| (eye distance (scene units), mean over "
                                                     "channels)"], maps
