"""The command line: listings, an end-to-end run, and bad input → one line on stderr, exit 2, no
traceback, and no run directory that looks complete."""
import os
import subprocess
import sys
from pathlib import Path

import pytest

from ldbench.harness.cli import main
from ldbench.core.errors import LdbenchError
from ldbench.methods.base import registry
from testkit import read_only_parent

ROOT = Path(__file__).resolve().parents[1]


def run_cli(*args, env=None):
    e = dict(os.environ, **(env or {}))
    p = subprocess.run([sys.executable, "-m", "ldbench.harness.cli", *args], cwd=ROOT, capture_output=True, text=True,
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
    assert len(out.splitlines()) == len(registry())  # one line a method; `methods NAME` for its parameters
    assert main(["methods", "ldm-ao"]) == 0  # an alias names its method
    one = capsys.readouterr().out
    assert one.startswith("ldm (also: ldm-ao)") and "directions" in one and "hbao" not in one
    assert main(["methods", "nope"]) == 2
    assert "unknown method 'nope'" in capsys.readouterr().err


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
    (["reference", "--scene", "cornell", "--effect", "ao", "--falloff", "cubic"], ["falloff"]),
    (["report", "/nonexistent/run"], ["not a run directory"]),
    (["reference", "--scene", "cornell", "--effect", "ao", "--ray-kind", "ao"], ["does not use parameter 'ray_kind'"]),
    (["reference", "--scene", "cornell", "--effect", "rays", "--d-max", "0.5"], ["does not use parameter 'd_max'"]),
    (["run", "--scene", "cornell", "--method", "hbao", "--effect", "ao", "--frames", str(10 ** 20)], ["frames"]),
    (["run", "--scene", "cornell", "--method", "hbao", "--effect", "ao", "--seed", str(2 ** 63)], ["seed"]),
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
    rc, _, se = run_cli("reference", "--scene", str(bad), "--effect", "ao", "--size", "8x8", "--spp", "1")
    assert_one_line_error(rc, se, "malformed XML")
    missing = tmp_path / "missing.xml"
    missing.write_text("<scene version='3.0.0'><sensor type='perspective'><float name='fov' value='40'/>"
                       "</sensor><shape type='ply'><string name='filename' value='nope.ply'/></shape></scene>")
    rc, _, se = run_cli("reference", "--scene", str(missing), "--effect", "ao", "--size", "8x8", "--spp", "1")
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
    from ldbench.harness.cli import build_parser, suite_from_args

    suite = tmp_path / "s.toml"
    suite.write_text('[suite]\nsize = "16x16"\n[[run]]\nscene = "cornell"\neffect = "ao"\n'
                     'methods = ["ldm-ao", "hbao"]\n[run.params.ldm-ao]\ndirections = 32\n')
    args = build_parser().parse_args(["run", str(suite), "--set", "ldm-ao.directions=8",
                                      "--set", "ldm-ao.resolution=16"])
    jobs = {j.method: dict(j.params) for j in suite_from_args(args).jobs}
    from ldbench.methods.base import get_method
    ldm = get_method("ldm-ao").name  # the adapter's name (ldm-ao may be an alias of it)
    assert jobs == {ldm: {"directions": 8, "resolution": 16}, "hbao": {}}
    rc, _, se = run_cli("run", str(suite), "--set", "direct-raster.shadow_size=64")
    assert_one_line_error(rc, se, "direct-raster", "does not run")
    rc, _, se = run_cli("run", str(suite), "--set", "ldm-ao.directions=0")
    assert_one_line_error(rc, se, "directions")


# ---- users' files, bad input ---------------------------------------------------------------------
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
    p = subprocess.run([sys.executable, "-m", "ldbench.harness.cli", "run", "--scene", "cornell", "--method", "hbao",
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


def test_rerun_never_deletes_a_users_file_beside_the_results(tmp_path):
    """A finished run into which the user put a file of their own is not replaced: one line, exit 2,
    nothing touched (ldbench deletes only what it wrote)."""
    out = tmp_path / "run"
    assert tiny_run(out)[0] == 0
    (out / "notes.txt").write_text("mine")
    first = (out / "results.csv").read_text()
    rc, _, se = tiny_run(out, "--set", "hbao.directions=4")
    assert rc == 2 and "notes.txt" in se and len(se.strip().splitlines()) == 1, se
    assert (out / "notes.txt").read_text() == "mine" and (out / "results.csv").read_text() == first
    (out / "notes.txt").unlink()
    assert tiny_run(out, "--set", "hbao.directions=4")[0] == 0


def test_suite_name_cannot_escape_runs(tmp_path):
    work = tmp_path / "a" / "b"
    work.mkdir(parents=True)
    s = work / "s.toml"
    s.write_text('[suite]\nname = "../../escape"\nsize = "16x16"\nspp = 4\nframes = 1\nwarmup = 0\n'
                 '[[run]]\nscene = "cornell"\neffect = "ao"\nmethods = ["hbao"]\n')
    p = subprocess.run([sys.executable, "-m", "ldbench.harness.cli", "run", str(s), "--no-progress", "--no-report"],
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


def test_size_beyond_the_gpu_or_memory_fails_before_rendering(tmp_path, gpu):
    """Sizes past this device's real limits, asked of the device (a 141 GB GPU holds what a small card
    cannot): one past GL_MAX_TEXTURE_SIZE (or past the command line's own bound), and a square within it
    that needs more host or GPU memory than is free; both refused before anything is rendered."""
    from ldbench.core.gpu import GPU_BYTES_PER_PIXEL, HOST_BYTES_PER_PIXEL, host_available_bytes

    lim = int(gpu.ctx.info["GL_MAX_TEXTURE_SIZE"])
    cases = [(f"{lim + 1}x16", f"{lim + 1}x16"), ("1x1", "1x1")]
    free = [b // per for b, per in ((host_available_bytes(), HOST_BYTES_PER_PIXEL),
                                    (gpu.available_gpu_memory(), GPU_BYTES_PER_PIXEL)) if b]
    side = int((4 * min(free)) ** 0.5)  # 4× what is free: free memory moves while the test runs
    if side <= lim:
        cases.append((f"{side}x{side}", f"{side}x{side}"))
    cache = tmp_path / "cache"
    for size, needle in cases:
        rc, _, se = tiny_run(tmp_path / "r", size=size, env={"LDBENCH_CACHE": str(cache)})
        assert_one_line_error(rc, se, needle)
    assert not cache.exists() and not (tmp_path / "r").exists()


def test_every_command_checks_the_memory_a_size_needs_before_any_work(tmp_path):
    """export and reference (no GPU context) refuse a size this machine's memory cannot hold, as run does,
    in one line and before anything is written (the side from the measured bytes per pixel)."""
    from ldbench.core.gpu import HOST_BYTES_PER_PIXEL, host_available_bytes
    from ldbench.harness.suite import MAX_SIDE

    side = int((4 * host_available_bytes() / HOST_BYTES_PER_PIXEL) ** 0.5)  # 4×: free memory moves meanwhile
    if side > MAX_SIDE:
        pytest.skip(f"this machine holds a {MAX_SIDE}² image: no size to refuse for memory")
    size = f"{side}x{side}"
    for args in (("export", "--scene", "cornell", "--effect", "ao", "--spp", "1", "--out", str(tmp_path / "q")),
                 ("reference", "--scene", "cornell", "--effect", "ao", "--spp", "1", "--out", str(tmp_path / "r.exr"))):
        rc, _, se = run_cli(*args, "--size", size, env={"LDBENCH_CACHE": str(tmp_path / "cache")})
        assert_one_line_error(rc, se, size, "memory")
    assert sorted(p.name for p in tmp_path.iterdir()) == []


def test_gpu_size_limits(gpu):
    lim = int(gpu.ctx.info["GL_MAX_TEXTURE_SIZE"])
    gpu.check_image_size(64, 48)
    with pytest.raises(LdbenchError, match="GL_MAX"):
        gpu.check_image_size(lim + 1, 16)
    from ldbench.core.gpu import HOST_BYTES_PER_PIXEL, host_available_bytes
    side = int((host_available_bytes() / HOST_BYTES_PER_PIXEL) ** 0.5) + 1
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
    from ldbench.harness.records import read_results
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
    from ldbench.harness.cli import main

    assert main(["reference", "--scene", "teapot", "--effect", "oit", "--size", "16x16", "--out", str(tmp_path / "o.exr")]) == 0
    assert (tmp_path / "o.exr").exists()
    assert main(["reference", "--scene", "cornell", "--effect", "rays", "--size", "16x16"]) == 2
    assert "per ray" in capsys.readouterr().err


# ---- faults that lose rows or hang ------------------------------------------------------------------
def _tiny_suite():
    """hbao and ldm, AO on the Cornell box at 16x16: two cheap rows."""
    from ldbench.harness.suite import suite_from_dict

    return suite_from_dict({"suite": {"name": "t", "size": "16x16", "spp": 4, "warmup": 0, "frames": 1},
                            "run": [{"scene": "cornell", "effect": "ao", "methods": ["hbao", "ldm"],
                                     "params": {"ldm": {"directions": 8, "resolution": 16}}}]}, name="t")


def test_an_unexpected_exception_is_one_row_and_the_run_completes(tmp_path, monkeypatch):
    """A job raising something other than LdbenchError (a bug, a driver fault) marks its own row
    ``error: TYPE: message``; the other rows are kept and the run directory is committed."""
    from ldbench.methods.hbao import HBAO
    from ldbench.harness.executors import run_jobs

    def broken(self, *a, **k):
        raise RuntimeError("simulated driver fault\nsecond line")

    monkeypatch.setattr(HBAO, "frame", broken)
    out = tmp_path / "run"
    df = run_jobs(_tiny_suite(), out, progress=False, report=False)
    st = dict(zip(df["method"], df["status"]))
    assert st["hbao"] == "error: RuntimeError: simulated driver fault", st
    assert st["ldm"] == "ok" and (out / "results.parquet").is_file()


def test_a_job_past_its_time_limit_is_one_row_and_the_run_goes_on(tmp_path, monkeypatch):
    """A method that never returns (an endless loop in Python) is stopped at the suite's job_timeout: its row
    says so, the other rows are kept, the run completes; the limit is a suite key and a flag, validated."""
    import time as _time

    from ldbench.harness.executors import run_jobs
    from ldbench.harness.suite import override
    from ldbench.methods.hbao import HBAO

    def forever(self, *a, **k):  # 20 s at most: without the limit this test fails instead of hanging
        t = _time.perf_counter()
        while _time.perf_counter() - t < 20:
            _time.sleep(0.01)
        raise AssertionError("not stopped by the time limit")

    monkeypatch.setattr(HBAO, "frame", forever)
    suite = override(_tiny_suite(), job_timeout=1.5)
    t0 = _time.perf_counter()
    df = run_jobs(suite, tmp_path / "run", progress=False, report=False)
    st = dict(zip(df["method"], df["status"]))
    assert st["hbao"].startswith("error: the job ran past its time limit of 1.5 s"), st
    assert st["ldm"] == "ok" and _time.perf_counter() - t0 < 15
    for bad in (-1, float("nan"), "10", True):
        with pytest.raises(LdbenchError, match="job-timeout must be a number of seconds"):
            override(_tiny_suite(), job_timeout=bad)
    rc, _, se = run_cli("run", "--scene", "cornell", "--method", "hbao", "--effect", "ao", "--job-timeout", "-3",
                        "--out", str(tmp_path / "r"), *TINY)
    assert_one_line_error(rc, se, "job_timeout must be a number of seconds")


def test_a_job_stuck_outside_python_is_named_on_stderr_then_stopped_on_return(monkeypatch, capsys):
    """A job that does not come back to Python (SIGALRM blocked, as inside a hung driver call) cannot be stopped
    in this process: past its limit and the notice delay, one line on stderr says so (and names the Ray
    executor, which kills such a worker); once the call returns, the limit stops the job as usual."""
    import signal
    import time as _time

    from ldbench.harness import runner

    monkeypatch.setattr(runner, "STUCK_NOTICE_S", 0.3)
    with pytest.raises(runner.JobTimeout, match="past its time limit of 0.2 s"):
        with runner.time_limit(0.2):
            signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGALRM})
            try:
                _time.sleep(1.0)  # the alarm (0.2 s) and the notice (0.5 s) fall in here
            finally:
                signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGALRM})  # a pending alarm raises here
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "past its time limit of 0.2 s" in err and "--executor ray" in err, err
    with runner.time_limit(5.0):  # a job in time, and one stopped in Python at its limit: no notice
        pass
    with pytest.raises(runner.JobTimeout):
        with runner.time_limit(0.2):
            _time.sleep(1.0)
    _time.sleep(0.5)
    assert capsys.readouterr().err == ""


@pytest.fixture(scope="module")
def finished_run(tmp_path_factory):
    """One tiny finished run (hbao, AO, 16x16) that tests copy and damage."""
    out = tmp_path_factory.mktemp("finished") / "run"
    rc, _, se = tiny_run(out)
    assert rc == 0, se
    return out


def test_partial_run_folder_is_refused_by_every_reader(tmp_path, finished_run):
    """A run killed while writing leaves .OUT.partial-PID/ with the marker: report, history add,
    compare and reproduce --from-run refuse it in one line (its rows are not a finished run)."""
    import shutil

    from ldbench.harness.rundir import MARKER

    partial = tmp_path / ".run.partial-12345"
    shutil.copytree(finished_run, partial)
    (partial / MARKER).write_text("12345\n")
    for args in (["report", str(partial)], ["history", "add", str(partial), "--history-dir", str(tmp_path / "h")],
                 ["compare", str(finished_run), str(partial)], ["compare", str(partial / "results.parquet"),
                                                                 str(finished_run)],
                 ["reproduce", "aalund2015-fig8", "--from-run", str(partial), "--no-report"]):
        rc, _, se = run_cli(*args)
        assert_one_line_error(rc, se, "unfinished run")
    assert not (tmp_path / "h").exists()


def test_foreign_results_columns_are_one_line_for_every_reader(tmp_path):
    """A results.parquet of other columns: the same one-line schema error from every reader."""
    import pandas as pd

    run = tmp_path / "foreign"
    run.mkdir()
    pd.DataFrame({"a": [1], "b": ["x"]}).to_parquet(run / "results.parquet")
    (run / "suite.json").write_text('{"name": "x", "source": "", "jobs": 1}')
    for args in (["report", str(run)], ["reproduce", "aalund2015-fig8", "--from-run", str(run), "--no-report"],
                 ["compare", str(run), str(run)], ["history", "add", str(run), "--history-dir", str(tmp_path / "h")]):
        rc, _, se = run_cli(*args)
        assert_one_line_error(rc, se, "not an ldbench results table", "no column 'scene'")
    assert sorted(p.name for p in run.iterdir()) == ["results.parquet", "suite.json"]


def test_reference_out_writes_only_the_exr(tmp_path, capsys):
    """`reference --out photo.exr` leaves the user's photo.png beside it alone; a name that is not an
    .exr file is refused before rendering."""
    from ldbench.harness.cli import main
    from ldbench.core.exr import read_exr

    (tmp_path / "photo.png").write_bytes(b"my holiday")
    assert main(["reference", "--scene", "cornell", "--effect", "ao", "--size", "8x8", "--spp", "2",
                 "--out", str(tmp_path / "photo.exr")]) == 0
    assert (tmp_path / "photo.png").read_bytes() == b"my holiday"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["photo.exr", "photo.png"]
    assert read_exr(tmp_path / "photo.exr")["Y"].shape == (8, 8)
    capsys.readouterr()
    assert main(["reference", "--scene", "cornell", "--effect", "ao", "--size", "8x8", "--spp", "2",
                 "--out", str(tmp_path / "photo.png")]) == 2
    assert "must name an .exr file" in capsys.readouterr().err
    assert (tmp_path / "photo.png").read_bytes() == b"my holiday"


def test_ctrl_c_during_the_report_never_commits(tmp_path, monkeypatch, capsys):
    """A Ctrl-C while the report is written (the last step before the commit) exits 130 and leaves no
    run directory, even when the code it interrupted caught the KeyboardInterrupt (a library's broad
    handler, as once happened after a Ray run)."""
    import signal

    import ldbench.reports.report

    def swallowing_report(*a, **k):
        try:
            os.kill(os.getpid(), signal.SIGINT)
        except KeyboardInterrupt:
            pass  # caught by someone else's code

    monkeypatch.setattr(ldbench.reports.report, "build_report", swallowing_report)
    out = tmp_path / "run"
    rc = main(["run", "--scene", "cornell", "--method", "hbao", "--effect", "ao", "--size", "16x16", *TINY[:-1],
               "--out", str(out)])
    assert rc == 130 and capsys.readouterr().err.strip().endswith("ldbench: interrupted")
    assert not out.exists() and not list(tmp_path.iterdir())
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler  # restored


def test_unreachable_ray_address_is_one_line_within_the_stated_time(tmp_path):
    pytest.importorskip("ray")
    import time

    from ldbench.harness.executors.ray import CONNECT_TIMEOUT_S

    t0 = time.monotonic()
    rc, _, se = tiny_run(tmp_path / "run", "--executor", "ray", "--address", "127.0.0.1:1")
    assert_one_line_error(rc, se, "cannot join the Ray cluster at 127.0.0.1:1")
    assert time.monotonic() - t0 < CONNECT_TIMEOUT_S + 30
    assert not list(tmp_path.iterdir())


UNDECODABLE = b"\xff\xfe[\x00s\x00]\x00\x80\x81"


@pytest.mark.parametrize("kind", ["suite", "xml", "ply", "obj", "baseline", "history-add", "history-file",
                                  "history-plot"])
def test_undecodable_input_files_are_one_line(tmp_path, kind, request):
    """Bytes that are not UTF-8 in any file ldbench reads: one line, exit 2, nothing written."""
    f = tmp_path / {"suite": "s.toml", "xml": "s.xml", "ply": "m.ply", "obj": "m.obj"}.get(kind, "r.csv")
    f.write_bytes(UNDECODABLE)
    hist = tmp_path / "hist"
    if kind == "suite":
        args = ["run", str(f), "--out", str(tmp_path / "run")]
    elif kind in ("xml", "ply", "obj"):
        args = ["reference", "--scene", str(f), "--effect", "ao", "--size", "8x8", "--spp", "1"]
    elif kind == "baseline":
        args = ["compare", str(f), str(f)]
    elif kind == "history-add":
        args = ["history", "add", str(f), "--history-dir", str(hist)]
    elif kind == "history-plot":
        hist.mkdir()
        (hist / "machine.parquet").write_bytes(UNDECODABLE)
        args = ["history", "plot", "--history-dir", str(hist)]
    else:  # the history file a run is added to
        from ldbench.harness.history import row_machine_key
        from ldbench.harness.records import read_results

        run = request.getfixturevalue("finished_run")
        hist.mkdir()
        (hist / f"{row_machine_key(read_results(run).iloc[0])}.parquet").write_bytes(UNDECODABLE)
        args = ["history", "add", str(run), "--history-dir", str(hist)]
    before = sorted(p.name for p in tmp_path.rglob("*"))
    rc, _, se = run_cli(*args)
    assert_one_line_error(rc, se)
    assert sorted(p.name for p in tmp_path.rglob("*") if p.name != ".lock") == before  # (history's own lock)


def test_xml_scene_with_a_negative_intensity_is_one_line(tmp_path):
    """A negative spot intensity in an XML scene: one line before anything renders (checked on the
    SpotLight, whatever loader built it; vertices beyond float32: tests/test_scenes.py)."""
    xml = ("<scene version='3.0.0'><sensor type='perspective'><float name='fov' value='40'/>"
           "<transform name='to_world'><lookat origin='0,1,4' target='0,0,0' up='0,1,0'/></transform></sensor>"
           "<emitter type='spot'><rgb name='intensity' value='{i}'/><transform name='to_world'>"
           "<lookat origin='0,3,0' target='0,0,0' up='0,0,1'/></transform></emitter>"
           "<shape type='rectangle'><transform name='to_world'><scale value='{s}'/>"
           "<rotate x='1' angle='-90'/></transform></shape></scene>")
    for i, s, needle in (("-5, -5, -5", "1", "negative"),):
        f = tmp_path / "s.xml"
        f.write_text(xml.format(i=i, s=s))
        rc, _, se = run_cli("reference", "--scene", str(f), "--effect", "direct", "--size", "8x8", "--spp", "1")
        assert_one_line_error(rc, se, needle)
        assert "Warning" not in se


def test_an_unexpected_reference_failure_marks_its_jobs_and_the_run_completes(tmp_path, monkeypatch):
    """As on the Ray executor: a reference raising something other than LdbenchError marks the rows of
    its jobs; the jobs of other references still run."""
    import ldbench.references as refs
    from ldbench.harness.executors import run_jobs
    from ldbench.harness.suite import suite_from_dict

    real = refs.render_reference

    def flaky(scene, effect, **k):
        if effect.d_max == 0.5:
            raise MemoryError("simulated")
        return real(scene, effect, **k)

    monkeypatch.setattr(refs, "render_reference", flaky)
    suite = suite_from_dict({"suite": {"name": "t", "size": "16x16", "spp": 2, "warmup": 0, "frames": 1},
                             "run": [{"scene": "cornell", "effect": "ao", "d_max": [0.5, "inf"],
                                      "methods": ["hbao"]}]}, name="t")
    df = run_jobs(suite, tmp_path / "run", progress=False, report=False)
    st = sorted(df["status"])
    assert st == ["error: reference failed: MemoryError: simulated", "ok"], st


def test_reference_takes_the_scene_as_run_does_and_the_old_spelling_warns(tmp_path):
    """`reference --scene X` like run and export; `reference X` still works and says once that it is deprecated;
    two different scenes, or none, are one line."""
    args = ("--effect", "ao", "--size", "8x8", "--spp", "1", "--no-cache")
    rc, _, se = run_cli("reference", "--scene", "cornell", *args, "--out", str(tmp_path / "a.exr"))
    assert rc == 0 and "deprecated" not in se, se
    rc, _, se = run_cli("reference", "cornell", *args, "--out", str(tmp_path / "b.exr"))
    assert rc == 0 and se.count("deprecated") == 1 and "--scene cornell" in se, se
    rc, _, se = run_cli("reference", "cornell", "--scene", "atrium", *args)
    assert_one_line_error(rc, se, "two scenes")
    rc, _, se = run_cli("reference", *args)
    assert_one_line_error(rc, se, "--scene")


def _in_a_terminal(args, cwd):
    """Run ``python -m ldbench.harness.cli ARGS`` with stdout and stderr on a pseudo-terminal; its output."""
    import fcntl
    import pty
    import select
    import struct
    import termios

    master, slave = pty.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 120, 0, 0))  # a terminal has a size
    p = subprocess.Popen([sys.executable, "-m", "ldbench.harness.cli", *args], cwd=cwd, stdin=subprocess.DEVNULL,
                         stdout=slave, stderr=slave)
    os.close(slave)
    out = b""
    while True:
        r, _, _ = select.select([master], [], [], 300)
        if not r:
            break
        try:
            chunk = os.read(master, 65536)
        except OSError:  # the child closed the terminal
            break
        if not chunk:
            break
        out += chunk
    p.wait(timeout=300)
    os.close(master)
    return p.returncode, out.decode(errors="replace")


def test_progress_bars_on_a_terminal_and_not_in_a_pipe(tmp_path):
    """References, jobs and scored answers show a progress bar on a terminal (tqdm on stderr), and nothing of it
    reaches a pipe or a log."""
    run = ["run", "--scene", "cornell", "--method", "hbao", "--effect", "ao", "--d-max", "0.5", "--size", "16x16",
           "--spp", "4", "--frames", "1", "--warmup", "0", "--no-report"]
    rc, out = _in_a_terminal([*run, "--out", str(tmp_path / "tty")], tmp_path)
    assert rc == 0, out
    assert "references" in out and "runs" in out and ("it/s]" in out or "s/it]" in out), out
    rc, so, se = run_cli(*run, "--out", str(tmp_path / "pipe"))
    assert rc == 0 and "it/s]" not in se + so and "s/it]" not in se + so, se
    from ldbench.core.exr import write_image
    import numpy as np

    ans = tmp_path / "a.exr"
    write_image(ans, np.full((16, 16, 1), 0.5, np.float32))
    score = ["score", str(tmp_path / "scored"), "--answer", str(ans), "--scene", "cornell", "--effect", "ao",
             "--d-max", "0.5", "--size", "16x16", "--spp", "1", "--no-report"]
    rc, out = _in_a_terminal(score, tmp_path)
    assert rc == 0 and "answers" in out, out
