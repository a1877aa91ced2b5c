"""The command line: listings, an end-to-end run, and bad input → one line on stderr, exit 2, no
traceback, and no run directory that looks complete."""
import os
import subprocess
import sys
from pathlib import Path

import pytest

from harness.cli import main

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
    for m in ("direct-raster", "ldm-ao", "hbao"):
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
    assert jobs == {"ldm-ao": {"directions": 8, "resolution": 16}, "hbao": {}}
    rc, _, se = run_cli("run", str(suite), "--set", "direct-raster.shadow_size=64")
    assert_one_line_error(rc, se, "direct-raster", "does not run")
    rc, _, se = run_cli("run", str(suite), "--set", "ldm-ao.directions=0")
    assert_one_line_error(rc, se, "directions")
