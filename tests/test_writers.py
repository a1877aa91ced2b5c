"""``ldbench run --writers N`` (ldbench/harness/writers.py): writer processes score and save finished jobs while
the main thread renders the next. The same rows and images as the serial run, in job order; a failure in a
writer is its job's error row; at most N jobs in flight; an interrupted pool drains what was handed over and
leaves no writer behind; an interrupted run commits nothing, as before."""
import json
import multiprocessing
import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from ldbench.core.errors import LdbenchError
from ldbench.harness.writers import Writers, default_writers

pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")


# ---- finishers a writer imports from this module (spawned writers import it by name) -----------------------
def slow_finish(task, prep, phases, row_calls=1):
    """Marks its start and end in ``task.dir``; takes ``task.seconds``; returns the job's index."""
    d = Path(task.dir)
    (d / f"started-{task.i}").write_text(repr(time.time()))  # not the mtime: some file systems keep it coarse
    time.sleep(task.seconds)
    (d / f"done-{task.i}").write_text(repr(time.time()))
    return {"i": task.i, "pid": os.getpid()}


def dying_finish(task, prep, phases, row_calls=1):
    """Job 1's writer process dies (as a segfault in a library would end it); the others answer."""
    if task.i == 1:
        os._exit(3)
    return {"i": task.i}


def _task(i, d, seconds):
    return SimpleNamespace(i=i, dir=str(d), seconds=seconds, fields={"scene": "s", "method": f"m{i}"})


def test_rows_come_back_in_job_order_whatever_order_the_writers_finish_in(tmp_path):
    """Later jobs take less time here, so they finish first; the rows are still in job order."""
    with Writers(3, finish=slow_finish) as pool:
        for i in range(6):
            pool.submit(i, "k", None, _task(i, tmp_path, 0.15 * (6 - i)))
        rows = pool.rows()
    assert [r["i"] for r in rows] == list(range(6))
    assert len({r["pid"] for r in rows}) > 1  # several writers did the work


def test_at_most_n_jobs_are_in_flight(tmp_path):
    """After each hand-over, the jobs handed over and not done are at most N (a job waits for a free writer),
    and N of them do run at once."""
    n, peak = 2, 0
    with Writers(n, finish=slow_finish) as pool:
        for i in range(7):
            pool.submit(i, "k", None, _task(i, tmp_path, 0.25))
            live = i + 1 - len(list(tmp_path.glob("done-*")))
            peak = max(peak, live)
            assert live <= n, f"{live} jobs in flight after handing over job {i}, more than {n}"
        rows = pool.rows()
    assert len(rows) == 7 and pool.max_in_flight == n and peak == n
    # Some pair of jobs overlapped in time. Not necessarily the first two: a writer process that starts late on
    # a loaded host (seen on 16 busy cores) leaves the first jobs to the other.
    span = [tuple(float((tmp_path / f"{k}-{i}").read_text()) for k in ("started", "done")) for i in range(7)]
    assert any(a0 < b1 and b0 < a1 for i, (a0, a1) in enumerate(span) for b0, b1 in span[i + 1:]), \
        f"the two writers never ran at once: {span}"


def test_a_writer_that_dies_is_its_jobs_error_row_and_the_others_finish(tmp_path):
    with Writers(2, finish=dying_finish) as pool:
        for i in range(4):
            pool.submit(i, "k", None, _task(i, tmp_path, 0))
        rows = pool.rows()
    assert rows[0] == {"i": 0} and rows[2] == {"i": 2} and rows[3] == {"i": 3}
    assert rows[1]["method"] == "m1" and rows[1]["status"] == \
        "error: the writer process ended while scoring and saving this job (exit code 3)", rows[1]


def test_a_job_a_writer_cannot_unpickle_is_finished_in_the_main_process(tmp_path, monkeypatch):
    """A plugin's class from a folder the writers' path lacks (added after they started): that job is
    finished here, not lost."""
    (tmp_path / "late_plugin.py").write_text("class Task:\n    pass\n")
    with Writers(1, finish=slow_finish) as pool:
        monkeypatch.syspath_prepend(str(tmp_path))
        import late_plugin

        t = late_plugin.Task()
        t.__dict__.update(vars(_task(1, tmp_path, 0)))
        pool.submit(0, "k", None, _task(0, tmp_path, 0))
        pool.submit(1, "k", None, t)
        rows = pool.rows()
    assert [r["i"] for r in rows] == [0, 1] and pool.inline == 1
    assert rows[0]["pid"] != os.getpid() and rows[1]["pid"] == os.getpid()
    sys.modules.pop("late_plugin", None)


def test_writers_that_cannot_start_leave_the_jobs_to_the_main_process(tmp_path):
    """A script without ``if __name__ == "__main__":`` (spawn imports it again in each writer, which then
    fails): one warning, every job finished in the main process, no hang."""
    script = tmp_path / "unguarded.py"
    script.write_text(f"""import os, sys
sys.path.insert(0, {str(Path(__file__).parent)!r})
from ldbench.harness.writers import Writers
from test_writers import slow_finish, _task
with Writers(2, finish=slow_finish) as pool:
    for i in range(3):
        pool.submit(i, "k", None, _task(i, {str(tmp_path)!r}, 0))
    rows = pool.rows()
print("rows", [r["i"] for r in rows], "here", sum(r["pid"] == os.getpid() for r in rows), "inline", pool.inline)
""")
    p = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr
    out = [ln for ln in p.stdout.splitlines() if ln.startswith("rows")]
    assert out[-1] == "rows [0, 1, 2] here 3 inline 3", p.stdout
    assert "the writer processes could not start" in p.stderr


def test_sigterm_waits_for_the_jobs_handed_over_and_stops_every_writer(tmp_path):
    """SIGTERM while the pool is open: SystemExit (status 15) in the main thread, so the run directory would
    be deleted; before that the two jobs handed over are finished and every writer has ended."""
    script = tmp_path / "term.py"
    script.write_text(f"""import os, signal, sys
sys.path.insert(0, {str(Path(__file__).parent)!r})
from ldbench.harness.writers import Writers
from test_writers import slow_finish, _task
if __name__ == "__main__":
    with Writers(2, finish=slow_finish) as pool:
        print("pids", *[w.proc.pid for w in pool._writers], flush=True)
        for i in range(2):
            pool.submit(i, "k", None, _task(i, {str(tmp_path)!r}, 0.5))
        os.kill(os.getpid(), signal.SIGTERM)
        print("not reached", flush=True)
""")
    p = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=120)
    assert p.returncode == signal.SIGTERM and "not reached" not in p.stdout, (p.returncode, p.stdout, p.stderr)
    assert (tmp_path / "done-0").is_file() and (tmp_path / "done-1").is_file()
    pids = [int(x) for x in p.stdout.split()[1:3]]
    for pid in pids:
        for _ in range(50):  # reaped by now, or about to be
            try:
                os.kill(pid, 0)
            except ProcessLookupError:
                break
            time.sleep(0.1)
        else:
            raise AssertionError(f"writer {pid} outlived the run")


# ---- the real finish_job, on arrays made here (no GL) ---------------------------------------------------
def _finish_task(i, folder, *, shape=(16, 16, 1), value=0.25):
    from ldbench.core.effects import Effect
    from ldbench.harness import records
    from ldbench.harness.runner import Finish
    from ldbench.methods.base import Result

    fields = {"scene": "synthetic", "method": f"m{i}", "effect": "ao", "width": 16, "height": 16, "status": "ok"}
    return Finish(spec=Effect("ao", d_max=0.5).spec, result=Result(image=np.full(shape, value, np.float32)),
                  fields=fields, timing=records.timing_fields({"total": [1.0], "wall": [1.0]}), memory={"b": 64},
                  folder=folder, label=f"m{i}-ao", ref_label="reference-ao")


def _prepared():
    from ldbench.harness.runner import Prepared
    from ldbench.references.render import Reference

    yy, xx = np.mgrid[0:16, 0:16]
    mean = (0.2 + 0.6 * (xx + yy) / 30.0)[..., None].astype(np.float32)
    ref = Reference(mean=mean, variance=np.full_like(mean, 1e-4), mask=np.ones((16, 16), bool), meta={"spp": 4})
    return Prepared(scene=SimpleNamespace(name="synthetic"), inputs=None, reference=ref)


def test_an_exception_in_a_pooled_score_or_save_is_that_jobs_error_row(tmp_path):
    """Job 1's image has the wrong shape (its score raises), job 2's folder cannot be made (its save raises):
    each is its own row's error, worded as on the serial path; the others are scored and saved."""
    from ldbench.harness.runner import finish_job

    blocked = tmp_path / "blocked"
    blocked.write_text("a file where the images folder should be")
    tasks = [_finish_task(0, tmp_path / "img"), _finish_task(1, tmp_path / "img", shape=(8, 8, 1)),
             _finish_task(2, blocked / "img"), _finish_task(3, tmp_path / "img", value=0.5)]
    prep = _prepared()
    with Writers(2) as pool:
        for i, t in enumerate(tasks):
            pool.submit(i, "k", prep, t)
        rows = pool.rows()
    serial = [finish_job(t, prep) for t in tasks]
    status = [r["status"] for r in rows]
    assert status[0] == "ok" and status[3] == "ok", status
    assert status[1] == "error: a method returned an image of shape (8, 8, 1), the reference has (16, 16, 1)"
    assert status[2].startswith("error: "), status
    assert status == [r["status"] for r in serial]
    assert rows[0]["psnr"] == serial[0]["psnr"] and rows[3]["ssim"] == serial[3]["ssim"]
    assert (tmp_path / "img" / "m3-ao.exr").is_file() and np.isnan(rows[1]["psnr"])


def test_an_interrupt_after_k_jobs_keeps_those_k_rows_and_no_writer_writes_after(tmp_path):
    """Ctrl-C with k jobs handed over: the pool waits for them (their rows complete, their files written),
    stops every writer, and nothing is written after it closed."""
    prep, k = _prepared(), 3
    with pytest.raises(KeyboardInterrupt):
        with Writers(2) as pool:
            for i in range(k):
                pool.submit(i, "k", prep, _finish_task(i, tmp_path / "img"))
            raise KeyboardInterrupt
    rows = pool.done()
    assert [r["method"] for r in rows] == ["m0", "m1", "m2"] and all(r["status"] == "ok" for r in rows)
    for r in rows:
        files = [p for p in json.loads(r["images"]).values() if isinstance(p, str) and p.endswith((".exr", ".png"))]
        assert len(files) == 4 and all((tmp_path / "img" / Path(p).name).is_file() for p in files), files
    assert not [p for p in multiprocessing.active_children() if p.name == "ldbench-writer"]
    before = sorted(p.name for p in (tmp_path / "img").iterdir())
    time.sleep(0.3)
    assert sorted(p.name for p in (tmp_path / "img").iterdir()) == before
    assert not [n for n in before if ".tmp" in n]  # no half-written file


def test_default_writers():
    assert default_writers("cpu-software", 64) == 0  # llvmpipe: the frames run on the CPU cores
    assert default_writers("nvidia", 16) == 8 and default_writers("nvidia", 64) == 8
    assert default_writers("gpu", 2) == 1 and default_writers("gpu", 1) == 0


# ---- the whole run (llvmpipe) ----------------------------------------------------------------------------
def _suite():
    from ldbench.harness.suite import suite_from_dict

    return suite_from_dict({"suite": {"name": "w", "size": "16x16", "spp": 4, "warmup": 0, "frames": 1},
                            "run": [{"scene": "cornell", "effect": "ao", "d_max": [0.25, 0.5],
                                     "methods": ["hbao", "gtao", "ldm"],
                                     "params": {"ldm": {"directions": 8, "resolution": 16}}}]}, name="w")


def _run(out, writers):
    from ldbench.harness.executors import get_executor, run_jobs

    return run_jobs(_suite(), out, progress=False, report=False, executor=get_executor("local", writers=writers))


def test_a_pooled_run_has_the_serial_runs_rows_and_images(tmp_path, caplog, monkeypatch):
    """Every column but the times, in the same order, and every image byte for byte; a job whose pooled
    score raises is the same error row; the time split says what overlapped."""
    import logging

    from ldbench.harness.executors.check import differences
    from ldbench.methods.hbao import HBAO

    frame = HBAO.frame

    def small_image(self, view, effect, inputs):  # the d_max 0.5 job's image is the wrong shape
        r = frame(self, view, effect, inputs)
        if effect.d_max == 0.5:
            r.image = np.zeros((3, 3, 1), np.float32)
        return r

    monkeypatch.setattr(HBAO, "frame", small_image)
    caplog.set_level(logging.INFO, logger="ldbench.harness.executors.local")
    a = _run(tmp_path / "serial", 0)
    assert "writer" not in caplog.text
    b = _run(tmp_path / "pooled", 2)
    assert differences(tmp_path / "serial", tmp_path / "pooled") == []
    assert list(a["method"]) == list(b["method"]) == ["hbao", "gtao", "ldm"] * 2
    assert b["status"].tolist().count("ok") == 5
    assert b["status"][3] == "error: a method returned an image of shape (3, 3, 1), the reference has (16, 16, 1)"
    line = [ln for ln in caplog.text.splitlines() if "writer processes beside the main thread" in ln]
    assert len(line) == 1 and " wait " in line[0] and " handoff " in line[0], caplog.text
    main, writers = line[0].split("; ")
    # the job whose score raised was scored (6) but not saved (5)
    assert " score " not in main and " frames 6× " in main and "score 6× " in writers and "save 5× " in writers


def test_an_interrupted_pooled_run_commits_nothing_and_leaves_no_writer(tmp_path, monkeypatch):
    """Ctrl-C in the sixth job's set-up, five handed to writers: as on the serial path, no run directory, no
    partial folder, nothing a writer wrote after the abort, and no writer process left."""
    from ldbench.methods.ldm import Ldm

    calls = {"n": 0}
    setup = Ldm.setup

    def interrupted(self, gpu, scene):
        calls["n"] += 1
        if calls["n"] == 2:  # the 6th job (ldm runs 3rd and 6th): five done
            raise KeyboardInterrupt
        return setup(self, gpu, scene)

    monkeypatch.setattr(Ldm, "setup", interrupted)
    with pytest.raises(KeyboardInterrupt):
        _run(tmp_path / "run", 2)
    time.sleep(0.3)
    assert list(tmp_path.iterdir()) == []
    assert not [p for p in multiprocessing.active_children() if p.name == "ldbench-writer"]


@pytest.mark.parametrize("args,needle", [(["--writers", "-1"], "--writers must be an integer in [0, 64]"),
                                         (["--writers", "two"], "--writers must be an integer in [0, 64]"),
                                         (["--writers", "65"], "--writers must be an integer in [0, 64]"),
                                         (["--writers", "2", "--executor", "ray"], "--writers goes with the local")])
def test_bad_writers_is_one_line(tmp_path, capsys, args, needle):
    from ldbench.harness.cli import main

    rc = main(["run", "--scene", "cornell", "--method", "hbao", "--effect", "ao", "--size", "8x8",
               "--out", str(tmp_path / "r"), *args])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and needle in err[0], err
    assert not (tmp_path / "r").exists()


def test_writers_refuse_a_count_out_of_range():
    with pytest.raises(ValueError):
        Writers(0)
    with pytest.raises(LdbenchError, match="writers"):
        from ldbench.harness.cli import _writers_arg

        _writers_arg("1.5")
