"""Hostile output paths and damaged outputs: every command that writes refuses, in one line (exit 2, no
traceback) and before any work, a path no write can succeed at (ldbench/core/files.py, check_output_path);
``reference --out`` replaces only its own EXR; ``report`` on damaged images says so per file; ``score`` keeps
a run's schema version; ``export`` of an ``oit`` question carries each shape's opacity."""
import json
import os
from pathlib import Path

import numpy as np
import pytest

from ldbench.core.errors import LdbenchError
from ldbench.harness.cli import main
from test_cli import assert_one_line_error
from testkit import read_only_parent

TINY = ("--spp", "1", "--frames", "1", "--warmup", "0", "--no-progress", "--no-report")


def _tiny_run_dir(d: Path) -> Path:
    """A finished run's files (one row) without rendering anything."""
    from ldbench.harness import records

    records.write_results([records.make_row(run_id="r1", scene="cornell", method="hbao", effect="ao",
                                            effect_params={"effect": "ao"}, params={}, width=8, height=8)], d)
    (d / "suite.json").write_text(json.dumps({"name": "t", "source": "", "jobs": 1}))
    return d


def _bad_paths(tmp_path: Path) -> dict:
    f = tmp_path / "file.txt"
    f.write_text("mine")
    return {"under a file": (f / "out", "is a file, not a folder"),
            "deeper under a file": (f / "a" / "out", "is a file, not a folder"),
            "under /proc": (Path("/proc/ldbench-no-such/out"), "cannot write in /proc"),
            "read-only": (read_only_parent(tmp_path) / "out", "cannot write in"),
            "name over 255 bytes": (tmp_path / ("é" * 130), "bytes): more than the"),
            "folder name over 255 bytes": (tmp_path / ("a" * 256) / "out", "bytes): more than the")}


def test_every_command_that_writes_refuses_an_impossible_output_in_one_line(tmp_path, capsys):
    """Every command that writes (export, new-method, run, score, reference, history add and plot, reproduce,
    compare --md/--json), each with every kind of impossible output (under a regular file, under /proc, in a
    folder nothing can be created in, a name longer than the file system takes): one line naming it, exit 2,
    before any work; nothing is written anywhere."""
    run = _tiny_run_dir(tmp_path / "run")
    answer = tmp_path / "answer.npy"
    np.save(answer, np.zeros(3, np.float32))
    before = sorted(p.name for p in tmp_path.iterdir())
    commands = {
        "export": lambda p: ["export", "--scene", "cornell", "--effect", "ao", "--size", "8x8", "--spp", "1",
                             "--out", str(p)],
        "new-method": lambda p: ["new-method", "hostile-out", "--out", str(p)],
        "run": lambda p: ["run", "--scene", "cornell", "--method", "hbao", "--effect", "ao", "--size", "8x8",
                          *TINY, "--out", str(p)],
        "score": lambda p: ["score", str(p), "--answer", str(answer), "--scene", "cornell", "--effect", "rays",
                            "--size", "8x8", "--no-report"],
        "reference": lambda p: ["reference", "--scene", "cornell", "--effect", "ao", "--size", "8x8", "--spp", "1",
                                "--out", f"{p}.exr"],
        "history add": lambda p: ["history", "add", str(run), "--history-dir", str(p)],
        "history plot": lambda p: ["history", "plot", "--history-dir", str(run), "--out", str(p)],
        "reproduce": lambda p: ["reproduce", "aalund2015-fig8", "--scale", "ci", "--no-progress", "--out", str(p)],
        "compare --md": lambda p: ["compare", str(run), str(run), "--md", f"{p}.md"],
        "compare --json": lambda p: ["compare", str(run), str(run), "--json", f"{p}.json"],
    }
    tries = [(argv, case) for argv in commands.values() for case in _bad_paths(tmp_path).values()]
    for argv, (path, needle) in tries:  # every case for every command
        rc = main(argv(path))
        err = capsys.readouterr().err
        assert_one_line_error(rc, err, needle)  # the message names what is wrong, not a traceback
        assert str(path)[:40] in err, err
    assert {p.name for p in tmp_path.iterdir()} <= {*before, "file.txt", "ro"}  # "ro": read_only_parent's own
    assert (tmp_path / "file.txt").read_text() == "mine" and sorted(p.name for p in run.iterdir()) == [
        "results.csv", "results.parquet", "suite.json"]


def test_check_output_path_counts_the_names_the_writer_adds(tmp_path):
    """A run directory's name is checked with its ``.NAME.partial-PID`` sibling: a name the file system takes
    alone but not with that suffix is refused before the partial folder fails to appear; a name that fits is
    fine and nothing is left from the probe."""
    from ldbench.core.files import check_output_path
    from ldbench.harness.rundir import RunDir

    fits = tmp_path / ("r" * 200)
    RunDir(fits).check()
    with pytest.raises(LdbenchError, match="more than"):
        RunDir(tmp_path / ("r" * 250)).check()  # 250 bytes fit, .NAME.partial-PID does not
    assert check_output_path(tmp_path / "x" / ("y" * 255), into=True) == tmp_path / "x" / ("y" * 255)
    assert list(tmp_path.iterdir()) == []


def test_a_file_system_error_midway_is_one_line(tmp_path, monkeypatch, capsys):
    """A disk that fills up (or turns read-only) after the checks: one line, exit 2, the partial run
    removed; an OSError that is not the file system's answer (a bug) keeps its traceback."""
    import errno

    from ldbench.harness import export

    def full(*a, **k):
        raise OSError(errno.ENOSPC, "No space left on device", str(tmp_path / "q" / "scene.ply"))

    monkeypatch.setattr(export, "_write_question", full)
    rc = main(["export", "--scene", "cornell", "--effect", "ao", "--size", "8x8", "--out", str(tmp_path / "q")])
    assert_one_line_error(rc, capsys.readouterr().err, "No space left on device", "scene.ply")
    assert list(tmp_path.iterdir()) == []

    def bug(*a, **k):
        raise OSError(errno.EBADF, "Bad file descriptor")

    monkeypatch.setattr(export, "_write_question", bug)
    with pytest.raises(OSError, match="Bad file descriptor"):
        main(["export", "--scene", "cornell", "--effect", "ao", "--size", "8x8", "--out", str(tmp_path / "q")])


def test_reference_out_replaces_only_its_own_exr(tmp_path, capsys):
    """``reference --out FILE.exr`` writes the EXR with ldbench's tag and replaces only such a file: a user's
    own EXR of that name is refused in one line, untouched, before anything renders."""
    from ldbench.core.exr import write_exr

    mine = tmp_path / "mine.exr"
    write_exr(mine, {"Y": np.full((4, 4), 7.0, np.float32)})
    data = mine.read_bytes()
    args = ["reference", "--scene", "cornell", "--effect", "ao", "--d-max", "0.5", "--size", "8x8", "--spp", "1"]
    assert_one_line_error(main([*args, "--out", str(mine)]), capsys.readouterr().err, "did not write")
    assert mine.read_bytes() == data
    ours = tmp_path / "ref.exr"
    assert main([*args, "--out", str(ours)]) == 0
    assert main([*args, "--out", str(ours)]) == 0  # its own file: replaced
    assert sorted(p.name for p in tmp_path.iterdir()) == ["mine.exr", "ref.exr"]


def test_report_on_damaged_images_names_each_file_and_exits_2(tmp_path, capsys, monkeypatch):
    """A run whose PNGs are zero bytes (or not PNGs): ``report`` says so once per file, writes the rest of the
    report without those grids, and exits 2 in one error line; no traceback."""
    from ldbench.harness import records
    from ldbench.reports import report

    run = tmp_path / "run"
    img = run / "images" / "cornell"
    img.mkdir(parents=True)
    (img / "m.png").write_bytes(b"")
    (img / "ref.png").write_bytes(b"GIF89a not a png")
    (img / "m-error.exr").write_bytes(b"")
    images = {"image": "images/cornell/m.png", "reference": "images/cornell/ref.png",
              "error_exr": "images/cornell/m-error.exr", "answer_source": "/nowhere/answer.png"}
    records.write_results([records.make_row(run_id="r1", scene="cornell", scene_hash="h", method="m", effect="ao",
                                            effect_params={"effect": "ao", "d_max": 0.5, "falloff": "step"},
                                            params={}, width=8, height=8, psnr=20.0, images=images)], run)
    (run / "suite.json").write_text(json.dumps({"name": "t", "source": "", "jobs": 1}))
    rc = main(["report", str(run)])
    err = capsys.readouterr().err
    assert_one_line_error(rc, err, "3 image file(s)", "cannot be read")
    warned = [ln for ln in err.splitlines() if ln.startswith("ldbench: warning: ")]
    assert sorted(w.split("image file ")[1] for w in warned) == [
        "images/cornell/m-error.exr: empty (0 bytes)", "images/cornell/m.png: empty (0 bytes)",
        "images/cornell/ref.png: not a PNG file"], warned
    assert (run / "index.html").is_file()
    assert report.damaged_images(run, [{"images": {"image": "images/cornell/missing.png"}}]) == []  # the grid's note


def test_score_keeps_the_schema_version_of_the_run_it_joins(tmp_path, monkeypatch):
    """Rows added to a run written by a newer ldbench of the same major version (1.7 > this one's): the file
    stays 1.7 (minor versions only add columns) and its rows keep their own version; a newer major is refused
    before anything is scored."""
    import pyarrow.parquet as pq

    from ldbench.core.effects import Effect
    from ldbench.harness import records, score
    from ldbench.harness.score import Question, make_answer, score_into_run

    run = _tiny_run_dir(tmp_path / "run")
    t = pq.read_table(run / "results.parquet")
    t = t.replace_schema_metadata({**t.schema.metadata, records.SCHEMA_VERSION_KEY: b"1.7"})
    pq.write_table(t.set_column(t.schema.get_field_index("schema_version"), "schema_version",
                                __import__("pyarrow").array(["1.7"])), run / "results.parquet")
    monkeypatch.setattr(score, "score_rows", lambda items, out, **kw: [records.make_row(
        run_id="r2", scene="cornell", method="x", effect="ao", effect_params={"effect": "ao"}, params={}, width=8,
        height=8)])  # the rows as scoring makes them; no reference rendered
    item = (Question("cornell", Effect("ao", d_max=0.5), 8, 8, spp=1), make_answer(tmp_path / "a.exr"))
    score_into_run([item], run, report=False)
    df = records.read_results(run)
    assert df.attrs["schema_version"] == "1.7" and list(df["schema_version"]) == ["1.7", records.SCHEMA_VERSION]
    t = pq.read_table(run / "results.parquet")
    pq.write_table(t.replace_schema_metadata({**t.schema.metadata, records.SCHEMA_VERSION_KEY: b"2.0"}),
                   run / "results.parquet")
    with pytest.raises(LdbenchError, match="schema version 2.0, newer"):
        score_into_run([item], run, report=False)
    assert records._kept_schema_version(None, run) == records.SCHEMA_VERSION
    assert records._kept_schema_version("1.0", run) == records.SCHEMA_VERSION


def test_oit_export_carries_each_shape_opacity(tmp_path):
    """An ``oit`` question's scene.xml holds each mesh's opacity (a ``mask`` BSDF), question.json's materials
    too: the scene read back from the export has the same opacities and the same exact reference; other
    effects' XML stays opaque (their references ignore opacity)."""
    from ldbench.core.effects import Effect
    from ldbench.core.scenes import load_scene
    from ldbench.harness.export import export_question
    from ldbench.harness.score import Question
    from ldbench.references import render_effect

    params = {"opacity": 0.3, "segments": 8}
    q = export_question(Question("teapot", Effect("oit"), 8, 8, spp=1, scene_params=params), tmp_path / "q")
    src, back = load_scene("teapot", **params), load_scene(str(q / "scene.xml"))
    assert [m.opacity for m in back.meshes] == [m.opacity for m in src.meshes] and min(
        m.opacity for m in src.meshes) == 0.3
    assert [m["opacity"] for m in json.loads((q / "question.json").read_text())["materials"]] == [
        m.opacity for m in src.meshes]
    ref = [render_effect(s, Effect("oit"), width=8, height=8, spp=1, seed=0, cache=False).mean for s in (src, back)]
    assert np.array_equal(ref[0], ref[1])
    d = export_question(Question("teapot", Effect("ao"), 8, 8, spp=1, scene_params=params), tmp_path / "d")
    assert 'type="mask"' not in (d / "scene.xml").read_text()
    assert all(m.opacity == 1.0 for m in load_scene(str(d / "scene.xml")).meshes)
