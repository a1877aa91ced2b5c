"""The command line: listings, an end-to-end run, and bad input → one line on stderr, exit 2, no
traceback, and no run directory that looks complete."""
import os
import subprocess
import sys
from pathlib import Path

import pytest

from harness.cli import main
from harness.errors import LdbenchError
from testkit import read_only_parent

ROOT = Path(__file__).resolve().parents[1]


def run_cli(*args, env=None):
    e = dict(os.environ, **(env or {}))
    p = subprocess.run([sys.executable, "-m", "harness.cli", *args], cwd=ROOT, capture_output=True, text=True,
                       env=e, timeout=300)
    return p.returncode, p.stdout, p.stderr


def assert_one_line_error(rc, err, *needles):
    assert rc == 2, err
    # warnings (e.g. an ignored area emitter) may precede it; the error itself is one line
    lines = [l for l in err.strip().splitlines() if l.strip() and not l.startswith("ldbench: warning: ")]
    assert len(lines) == 1, err
    assert lines[0].startswith("ldbench: error: ")
    assert "Traceback" not in err
    for n in needles:
        assert n in lines[0], lines[0]


def test_listings(capsys):
    assert main(["scenes"]) == 0
    out = capsys.readouterr().out
    assert "cornell" in out and "atrium" in out and "hairball" in out
    assert main(["methods"]) == 0
    out = capsys.readouterr().out
    for m in ("direct-raster", "ldm (also: ldm-ao)", "hbao"):
        assert m in out


def test_run_writes_complete_directory(tmp_path):
    out = tmp_path / "run"
    rc, so, se = run_cli("run", "--scene", "cornell", "--method", "direct-raster", "--effect", "direct",
                         "--size", "32x32", "--spp", "4", "--frames", "2", "--warmup", "1", "--out", str(out),
                         "--no-progress")
    assert rc == 0, se
    for f in ("results.parquet", "results.csv", "summary.md", "index.html"):
        assert (out / f).exists(), f
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # no partial dir left


@pytest.mark.parametrize("args,needles", [
    (["run", "--scene", "nosuchscene", "--method", "direct-raster", "--effect", "direct"], ["nosuchscene"]),
    (["run", "--scene", "cornell", "--method", "nosuchmethod", "--effect", "direct"], ["nosuchmethod"]),
    (["run", "--scene", "cornell", "--method", "direct-raster", "--effect", "glow"], ["glow"]),
    (["run", "--scene", "cornell", "--method", "direct-raster", "--effect", "direct",
      "--set", "direct-raster.bogus=1"], ["bogus"]),
    (["run", "--scene", "cornell", "--method", "direct-raster", "--effect", "direct",
      "--set", "direct-raster.shadow_size=3"], ["shadow_size"]),
    (["run", "--scene", "cornell", "--method", "direct-raster", "--effect", "ao"], ["does not support", "ao"]),
    (["run", "--scene", "cornell", "--scene-set", "subdivide=-1", "--method", "direct-raster",
      "--effect", "direct"], ["subdivide"]),
    (["run", "--scene", "cornell", "--method", "direct-raster", "--effect", "direct", "--size", "abc"], ["size"]),
    (["reference", "cornell", "--effect", "ao", "--falloff", "cubic"], ["falloff"]),
    (["report", "/nonexistent/run"], ["not a run directory"]),
    (["frobnicate"], ["invalid choice"]),
])
def test_bad_input_one_line(tmp_path, args, needles):
    out = tmp_path / "run"
    if args[0] == "run":
        args = args + ["--out", str(out), "--no-progress"]
    rc, so, se = run_cli(*args)
    assert_one_line_error(rc, se, *needles)
    assert not out.exists() and not list(tmp_path.iterdir())


def test_bad_scene_files(tmp_path):
    bad = tmp_path / "bad.xml"
    bad.write_text("<scene version='3.0.0'><shape type='obj'>")
    rc, _, se = run_cli("reference", str(bad), "--effect", "ao", "--size", "8x8", "--spp", "1")
    assert_one_line_error(rc, se, "malformed XML")
    missing = tmp_path / "missing.xml"
    missing.write_text("<scene version='3.0.0'><sensor type='perspective'><float name='fov' value='40'/>"
                       "</sensor><shape type='ply'><string name='filename' value='nope.ply'/></shape></scene>")
    rc, _, se = run_cli("reference", str(missing), "--effect", "ao", "--size", "8x8", "--spp", "1")
    assert_one_line_error(rc, se, "nope.ply")
    rc, _, se = run_cli("run", "--scene", str(tmp_path / "gone.ply"), "--method", "direct-raster",
                        "--effect", "direct", "--out", str(tmp_path / "r"))
    assert_one_line_error(rc, se, "gone.ply")
    assert not (tmp_path / "r").exists()


def test_xml_scene_without_light_refuses_direct(tmp_path):
    cbox = ROOT.parent / "shared" / "scenes" / "cornell_box_mitsuba3" / "classic" / "cbox.xml"
    if not cbox.exists():
        pytest.skip("shared scenes not beside the checkout")
    rc, _, se = run_cli("run", "--scene", str(cbox), "--method", "direct-raster", "--effect", "direct",
                        "--size", "16x16", "--out", str(tmp_path / "r"), "--no-progress")
    assert_one_line_error(rc, se, "no spot or point light")
    assert not (tmp_path / "r").exists()


def test_no_gl43_is_one_line(tmp_path):
    """No usable EGL/GL 4.3 (forced by pointing EGL at a vendor file that does not exist)."""
    env = {"__EGL_VENDOR_LIBRARY_FILENAMES": str(tmp_path / "none.json"),
           "__EGL_VENDOR_LIBRARY_DIRS": str(tmp_path)}
    rc, _, se = run_cli("run", "--scene", "cornell", "--method", "direct-raster", "--effect", "direct",
                        "--size", "16x16", "--out", str(tmp_path / "r"), "--no-progress", env=env)
    assert_one_line_error(rc, se, "OpenGL 4.3")
    assert not (tmp_path / "r").exists()


def test_set_overrides_suite_params(tmp_path):
    from harness.cli import build_parser, suite_from_args

    suite = tmp_path / "s.toml"
    suite.write_text('[suite]\nsize = "16x16"\n[[run]]\nscene = "cornell"\neffect = "ao"\n'
                     'methods = ["ldm-ao", "hbao"]\n[run.params.ldm-ao]\ndirections = 32\n')
    args = build_parser().parse_args(["run", str(suite), "--set", "ldm-ao.directions=8",
                                      "--set", "ldm-ao.resolution=16"])
    jobs = {j.method: dict(j.params) for j in suite_from_args(args).jobs}
    from methods.base import get_method
    ldm = get_method("ldm-ao").name  # the adapter's name (ldm-ao may be an alias of it)
    assert jobs == {ldm: {"directions": 8, "resolution": 16}, "hbao": {}}
    rc, _, se = run_cli("run", str(suite), "--set", "direct-raster.shadow_size=64")
    assert_one_line_error(rc, se, "direct-raster", "does not run")
    rc, _, se = run_cli("run", str(suite), "--set", "ldm-ao.directions=0")
    assert_one_line_error(rc, se, "directions")


# ---- issue 17: users' files, bad input --------------------------------------------------------------
TINY = ("--spp", "4", "--frames", "1", "--warmup", "0", "--no-progress", "--no-report")


def tiny_run(out, *extra, scene="cornell", method="hbao", effect="ao", size="16x16", env=None):
    args = ["run", "--scene", scene, "--method", method, "--effect", effect, *TINY, "--out", str(out), *extra]
    if size:
        args += ["--size", size]
    return run_cli(*args, env=env)


def test_out_never_deletes_a_foreign_folder(tmp_path):
    precious = tmp_path / "precious"
    precious.mkdir()
    (precious / "thesis.tex").write_text("years of work")
    rc, _, se = tiny_run(precious)
    assert_one_line_error(rc, se, "not an ldbench run")
    assert (precious / "thesis.tex").read_text() == "years of work"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["precious"]


def test_out_dot_is_refused(tmp_path):
    (tmp_path / "mine.txt").write_text("x")
    p = subprocess.run([sys.executable, "-m", "harness.cli", "run", "--scene", "cornell", "--method", "hbao",
                        "--effect", "ao", "--size", "16x16", *TINY, "--out", "."], cwd=tmp_path,
                       capture_output=True, text=True, env=dict(os.environ, PYTHONPATH=str(ROOT)), timeout=300)
    assert_one_line_error(p.returncode, p.stderr, "current directory")
    assert sorted(x.name for x in tmp_path.iterdir()) == ["mine.txt"]


def test_out_on_a_file_or_read_only_parent_fails_before_rendering(tmp_path):
    cache = tmp_path / "cache"
    f = tmp_path / "file"
    f.write_text("x")
    rc, _, se = tiny_run(f, env={"LDBENCH_CACHE": str(cache)})
    assert_one_line_error(rc, se, "not a directory")
    assert f.read_text() == "x"
    rc, _, se = tiny_run(read_only_parent(tmp_path) / "run", env={"LDBENCH_CACHE": str(cache)})
    assert_one_line_error(rc, se, "cannot")
    assert not cache.exists()  # nothing was rendered (no reference cached)


def test_rerun_replaces_the_run(tmp_path):
    out = tmp_path / "run"
    assert tiny_run(out)[0] == 0
    first = (out / "results.csv").read_text()
    rc, _, se = tiny_run(out, "--set", "hbao.directions=4")
    assert rc == 0, se
    assert (out / "results.csv").read_text() != first
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]


def test_suite_name_cannot_escape_runs(tmp_path):
    work = tmp_path / "a" / "b"
    work.mkdir(parents=True)
    s = work / "s.toml"
    s.write_text('[suite]\nname = "../../escape"\nsize = "16x16"\nspp = 4\nframes = 1\nwarmup = 0\n'
                 '[[run]]\nscene = "cornell"\neffect = "ao"\nmethods = ["hbao"]\n')
    p = subprocess.run([sys.executable, "-m", "harness.cli", "run", str(s), "--no-progress", "--no-report"],
                       cwd=work, capture_output=True, text=True, env=dict(os.environ, PYTHONPATH=str(ROOT)),
                       timeout=300)
    assert p.returncode == 0, p.stderr
    runs = list((work / "runs").iterdir())
    assert len(runs) == 1 and runs[0].name.startswith("escape-")
    assert sorted(x.name for x in tmp_path.iterdir()) == ["a"] and sorted(x.name for x in (tmp_path / "a").iterdir()) == ["b"]


def xml_scene(path: Path, *, target="0, 0, 0", shape_extra="", film=(24, 18), box=1.0):
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(f"""<scene version="3.0.0">
<sensor type="perspective"><float name="fov" value="45"/>
<transform name="to_world"><lookat origin="0, 0.5, 5" target="{target}" up="0, 1, 0"/></transform>
<film type="hdrfilm"><integer name="width" value="{film[0]}"/><integer name="height" value="{film[1]}"/></film>
</sensor>
<shape type="cube"><transform name="to_world">{shape_extra}<scale value="{box}"/></transform><bsdf type="diffuse"/></shape>
<shape type="rectangle"><transform name="to_world">{shape_extra}<scale value="3"/><rotate x="1" angle="-90"/>
<translate y="-1"/></transform><bsdf type="diffuse"/></shape>
<emitter type="point"><point name="position" x="0" y="3" z="3"/><rgb name="intensity" value="10"/></emitter>
</scene>
""")
    return path


@pytest.mark.parametrize("how", ["facing_away", "zero_scale"])
@pytest.mark.parametrize("method,effect", [("direct-raster", "direct"), ("hbao", "ao")])
def test_scene_without_visible_geometry(tmp_path, how, method, effect):
    kw = {"target": "0, 0.5, 10"} if how == "facing_away" else {"shape_extra": '<scale value="0"/>'}
    sc = xml_scene(tmp_path / "empty.xml", **kw)
    rc, _, se = tiny_run(tmp_path / "r", scene=str(sc), method=method, effect=effect)
    assert_one_line_error(rc, se, "sees no geometry")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["empty.xml"]


def test_size_beyond_the_gpu_or_memory_fails_before_rendering(tmp_path):
    cache = tmp_path / "cache"
    for size, needle in (("16384x16384", "16384x16384"), ("1x1", "1x1")):
        rc, _, se = tiny_run(tmp_path / "r", size=size, env={"LDBENCH_CACHE": str(cache)})
        assert_one_line_error(rc, se, needle)
    assert not cache.exists() and not (tmp_path / "r").exists()


def test_gpu_size_limits(gpu):
    lim = int(gpu.ctx.info["GL_MAX_TEXTURE_SIZE"])
    gpu.check_image_size(64, 48)
    with pytest.raises(LdbenchError, match="GL_MAX"):
        gpu.check_image_size(lim + 1, 16)
    from harness.gpu import HOST_BYTES_PER_PIXEL, _host_available_bytes
    side = int((_host_available_bytes() / HOST_BYTES_PER_PIXEL) ** 0.5) + 1
    if side <= lim:
        with pytest.raises(LdbenchError, match="memory"):
            gpu.check_image_size(side, side)


def test_same_named_scene_files_get_distinct_labels_and_film_size(tmp_path):
    a = xml_scene(tmp_path / "a" / "scene.xml", film=(20, 15))
    b = xml_scene(tmp_path / "b" / "scene.xml", film=(20, 15), box=0.5)
    s = tmp_path / "s.toml"
    s.write_text('[suite]\nspp = 4\nframes = 1\nwarmup = 0\n'  # no size: the films' 20x15
                 f'[[run]]\nscene = "{a}"\neffect = "ao"\nmethods = ["hbao"]\n'
                 f'[[run]]\nscene = "{b}"\neffect = "ao"\nmethods = ["hbao"]\n')
    out = tmp_path / "r"
    rc, so, se = run_cli("run", str(s), "--out", str(out), "--no-progress", "--no-report")
    assert rc == 0, se
    from harness.records import read_results
    df = read_results(out)
    assert len(set(df["scene"])) == 2 and all(n.startswith("scene-") for n in df["scene"])
    assert set(zip(df["width"], df["height"])) == {(20, 15)}
    folders = {Path(i["image"]).parent for i in df["images"]}
    assert len(folders) == 2 and all((out / f).is_dir() for f in folders)


def test_corrupt_results_are_one_line(tmp_path):
    run = tmp_path / "run"
    run.mkdir()
    (run / "results.parquet").write_bytes(b"PAR1" + os.urandom(200))
    (run / "suite.json").write_text("{}")
    rc, _, se = run_cli("report", str(run))
    assert_one_line_error(rc, se, "results.parquet")
    rc, _, se = run_cli("compare", str(run), str(run))
    assert_one_line_error(rc, se, "results.parquet")


def test_compare_checks_the_schema(tmp_path):
    unrelated = tmp_path / "unrelated.csv"
    unrelated.write_text("a,b\n1,2\n")
    rc, _, se = run_cli("compare", str(unrelated), str(unrelated))
    assert_one_line_error(rc, se, "no column 'scene'")
    out = tmp_path / "run"
    assert tiny_run(out)[0] == 0
    import pandas as pd
    df = pd.read_csv(out / "results.csv")
    df.drop(columns=["psnr"]).to_csv(tmp_path / "base.csv", index=False)
    rc, _, se = run_cli("compare", str(tmp_path / "base.csv"), str(out))
    assert_one_line_error(rc, se, "no column 'psnr'")


def test_reference_of_every_image_effect(tmp_path, capsys):
    """`ldbench reference` goes through the effect's own reference (oit has no Mitsuba image integrator
    of the usual kind); per-ray effects are refused with one line."""
    from harness.cli import main

    assert main(["reference", "teapot", "--effect", "oit", "--size", "16x16", "--out", str(tmp_path / "o.exr")]) == 0
    assert (tmp_path / "o.exr").exists()
    assert main(["reference", "cornell", "--effect", "rays", "--size", "16x16"]) == 2
    assert "per ray" in capsys.readouterr().err
