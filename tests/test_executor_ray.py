"""The Ray executor on a 2-worker local cluster (``ray.init(num_cpus=2, num_gpus=0)``: without GPUs each
task asks for one CPU, so two run at a time), on llvmpipe.

* a Ray run equals a serial run: same rows, same metrics, same images bit for bit (timing columns
  differ), with tasks writing into the run directory and with tasks returning their files;
* faults: a worker that dies marks only its job's rows ``error: …`` and the run completes; a task that
  fails once succeeds on its retry; Ctrl-C kills every task and leaves no run directory behind;
* without Ray installed, ``--executor ray`` is one line, exit 2.
"""
import os
import re
import signal
import sys
import threading
import time

import numpy as np
import pytest

ray = pytest.importorskip("ray", reason="the test extra installs ray (pip install -e '.[test]')")

from ldbench.harness.executors.check import TIMED, differences, image_files  # noqa: E402
from ldbench.harness.executors.ray import RayExecutor, cpus_per_gpu, group_jobs  # noqa: E402
from ldbench.harness.executors import run_jobs  # noqa: E402
from ldbench.harness.suite import suite_from_dict  # noqa: E402

def _suite(d_max=(0.5, "inf"), methods=("hbao", "ldm")):
    return suite_from_dict({"suite": {"name": "ray-test", "size": "24x24", "spp": 8, "warmup": 0, "frames": 1},
                            "run": [{"scene": "cornell", "effect": "ao", "d_max": list(d_max),
                                     "methods": list(methods),
                                     "params": {"ldm": {"directions": 16, "resolution": 32}}}]}, name="ray-test")


@pytest.fixture(scope="module")
def cluster():
    ray.init(num_cpus=2, num_gpus=0, include_dashboard=False, log_to_driver=False, logging_level="ERROR")
    yield
    ray.shutdown()


@pytest.fixture(scope="module")
def serial(tmp_path_factory):
    out = tmp_path_factory.mktemp("serial") / "run"
    return out, run_jobs(_suite(d_max=("inf",)), out, progress=False, report=False)


def _assert_same_run(a_dir, a, b_dir, b):
    assert len(a) == len(b) == 2 and (a["status"] == "ok").all() and (b["status"] == "ok").all()
    assert np.isfinite(a["psnr"]).all() and np.isfinite(b["psnr"]).all()
    assert differences(a_dir, b_dir) == []  # every column but times, every image byte for byte
    assert len(image_files(b_dir)) == 2 * 3 + 2  # per job: image (png + exr), error map (exr); the reference
    assert not list(b_dir.glob(".*")), "staging folders must not reach the committed run"


def test_differences_bite(serial, tmp_path):
    """The comparison the Ray tests rely on sees a changed metric and a changed image byte."""
    import shutil

    from ldbench.harness import records

    copy = tmp_path / "copy"
    shutil.copytree(serial[0], copy)
    assert differences(serial[0], copy) == []
    df = records.read_results(copy)
    df.loc[1, "ssim"] += 1e-12
    records.write_results(df.to_dict("records"), copy)
    img = sorted((copy / "images").rglob("*.exr"))[0]
    data = bytearray(img.read_bytes())
    data[-1] ^= 1
    img.write_bytes(bytes(data))
    d = differences(serial[0], copy)
    assert len(d) == 2 and "ssim" in d[0] and d[1] == f"image differs: {img.relative_to(copy).as_posix()}", d


def test_ray_run_equals_serial_run(cluster, serial, tmp_path):
    """Two workers, each writing into the run directory (the same file system). Three calls (the
    reference, two groups of one job) served by two processes that are still alive at the end: a worker
    is reused, not started per call."""
    out = tmp_path / "ray"
    ex = RayExecutor(group_size=1)
    df = run_jobs(_suite(d_max=("inf",)), out, progress=False, report=False, executor=ex)
    _assert_same_run(*serial, out, df)
    assert df["egl_device"].tolist() == [0] * 2 and df["cuda_device"].isna().all()  # llvmpipe: EGL device 0
    procs = ex.stats["processes"]
    assert ex.stats["workers"] == 2 and ex.stats["calls"] == 3, ex.stats
    assert len({p["pid"] for p in procs}) == 2 and sum(p["calls"] for p in procs) == 3, procs


@pytest.fixture
def ldb_log(caplog, monkeypatch):
    """The package's INFO records in caplog (also after a CLI test, whose logging setup stops propagation)."""
    import logging

    monkeypatch.setattr(logging.getLogger("ldbench"), "propagate", True)
    caplog.set_level(logging.INFO, logger="ldbench")
    return caplog


def _calls(procs, phase):
    return sum(p["phases"].get(phase, [0.0, 0])[1] for p in procs)


def test_ray_workers_log_where_their_time_went(cluster, tmp_path, ldb_log):
    """Each worker's split (ldbench/harness/phases.py) counts what it did: one reference, two groups of one job
    (each taken from the object store, set up, rendered, scored, saved), and it accounts for most of the
    worker's busy time but never more; the first call's wait is apart from the idle time between calls.
    The driver logs its split (what it put into the object store, the groups' files it moved) and one per
    worker, and warns that this cluster's workers ran at a lower priority than the driver."""
    caplog = ldb_log
    ex = RayExecutor(group_size=1)
    run_jobs(_suite(d_max=("inf",)), tmp_path / "ray", progress=False, report=False, executor=ex)
    procs = ex.stats["processes"]
    assert _calls(procs, "reference render") + _calls(procs, "reference cache") == 1, procs
    for phase in ("receive", "setup", "frames", "release", "score", "save", "row", "files"):
        assert _calls(procs, phase) == 2, (phase, procs)
    for p in procs:
        timed = sum(s for s, _ in p["phases"].values())
        assert 0.98 * p["busy_s"] <= timed <= p["busy_s"] + 1e-6, p  # measured 0.9997 of it
        assert p["first_wait_s"] is not None and p["first_wait_s"] >= 0 and p["idle_s"] >= 0, p
        if p["calls"] == 1:
            assert p["idle_s"] == 0, p
    lines = [r.getMessage() for r in caplog.records if " split: " in r.getMessage()]
    assert sum(ln.startswith("ray: worker ") for ln in lines) == 2, lines
    driver = [ln for ln in lines if ln.startswith("ray: driver split: ")]
    assert len(driver) == 1 and re.fullmatch(r"ray: driver split: put 1× \d+\.\d s, merge 2× \d+\.\d s", driver[0]), lines
    # this cluster (the fixture's ray.init) runs its workers at Ray's niceness, 15 above the driver's (os.nice
    # adds, up to 19; the suite itself may run under nice): the run says so
    own = os.getpriority(os.PRIO_PROCESS, 0)
    worker = min(own + 15, 19)
    assert all(p["nice"] == worker for p in procs), (own, procs)
    warned = [r.getMessage() for r in caplog.records if r.levelname == "WARNING" and "niceness" in r.getMessage()]
    if worker > own:
        assert len(warned) == 1 and f"niceness {worker}, below this process ({own})" in warned[0], warned


def test_serial_run_logs_where_its_time_went(tmp_path, monkeypatch, ldb_log):
    """The serial run logs the same split: a reference rendered, then the same one from the cache."""
    caplog = ldb_log
    monkeypatch.setenv("LDBENCH_CACHE", str(tmp_path / "cache"))
    for run, ref in (("a", "reference render 1×"), ("b", "reference cache 1×")):
        caplog.clear()
        run_jobs(_suite(d_max=("inf",)), tmp_path / run, progress=False, report=False)
        line = next(r.getMessage() for r in caplog.records if r.getMessage().startswith("local: "))
        assert line.startswith("local: 1 references, 2 jobs in "), line
        assert ref in line and "reference " not in line.replace(ref, ""), line
        for phase in ("setup", "frames", "score", "save", "row"):
            assert re.search(rf"\b{phase} 2× \d+\.\d s", line), (phase, line)


def test_phases_text_in_order():
    from ldbench.harness.phases import Phases

    ph = Phases()
    ph.add("save", 0.25)
    ph.add("custom", 1.0)
    with ph("setup"):
        pass
    ph.add("save", 0.5)
    assert ph.calls == {"save": 2, "custom": 1, "setup": 1} and ph.seconds["save"] == 0.75
    assert Phases.text(ph.as_dict()) == "setup 1× 0.0 s, save 2× 0.8 s, custom 1× 1.0 s"
    assert Phases.text({}) == "nothing timed"


def test_group_jobs_by_reference():
    jobs = [j for j in _suite(d_max=(0.25, 0.5, "inf"), methods=("hbao", "ldm")).jobs]  # 6 jobs, 3 references
    groups = group_jobs(jobs, workers=1)  # 6 / (2 * 1) = 3 per task: one task per reference
    assert [[i for i, _ in items] for _, items in groups] == [[0, 1], [2, 3], [4, 5]]
    assert all(len({(j.effect, j.width) for _, j in items}) == 1 for _, items in groups)
    assert [len(items) for _, items in group_jobs(jobs, workers=3)] == [1] * 6
    assert [len(items) for _, items in group_jobs(jobs, workers=8, group_size=4)] == [2, 2, 2]


def test_cpus_per_gpu():
    """A GPU worker gets its GPU's share of its node's cores (Ray sets its OMP_NUM_THREADS from it), the
    smallest share over the nodes with GPUs, so that every GPU's worker can be placed."""
    assert cpus_per_gpu([{"CPU": 16.0, "GPU": 1.0}]) == 16
    assert cpus_per_gpu([{"CPU": 128.0, "GPU": 8.0}, {"CPU": 12.0, "GPU": 2.0}, {"CPU": 64.0}]) == 6
    assert cpus_per_gpu([{"CPU": 2.0, "GPU": 4.0}]) == 1 and cpus_per_gpu([{"CPU": 8.0}]) == 1


def test_dead_worker_marks_its_rows_and_the_run_completes(cluster, serial, tmp_path, monkeypatch):
    """Every task running an hbao job dies (os._exit). Tasks here return their files to the driver (as
    on machines that do not see the run directory): ldm's arrive, equal to the serial run's."""
    monkeypatch.setenv("LDBENCH_FAULT", "exit:hbao")
    out = tmp_path / "run"
    df = run_jobs(_suite(d_max=("inf",)), out, progress=False, report=False,
                  executor=RayExecutor(retries=0, group_size=2, stage_in_run_dir=False))
    st = dict(zip(df["method"], df["status"]))
    assert st["ldm"] == "ok"  # its group died, then it ran alone
    assert st["hbao"].startswith("error: worker died: its process ended") and "task failed 1 time" in st["hbao"], st
    assert (out / "results.parquet").is_file() and not list(tmp_path.glob(".run.*"))
    got, want = image_files(out), image_files(serial[0])
    assert sorted(got) == sorted(k for k in want if "/hbao-" not in k) and len(got) == 3 + 2
    assert all(got[k] == want[k] for k in got)
    ldm = df["method"] == "ldm"
    assert differences(serial[0], out, ignore=TIMED | {"status"}) != []  # hbao's row lost its metrics
    assert df.loc[ldm, "psnr"].tolist() == serial[1].loc[serial[1]["method"] == "ldm", "psnr"].tolist()


def test_dead_reference_task_marks_its_jobs(cluster, tmp_path, monkeypatch):
    monkeypatch.setenv("LDBENCH_FAULT", "exit:reference")
    df = run_jobs(_suite(d_max=("inf",)), tmp_path / "run", progress=False, report=False,
                  executor=RayExecutor(retries=0))
    assert len(df) == 2 and all(s.startswith("error: reference task failed: worker died")
                                for s in df["status"]), df["status"].tolist()


@pytest.mark.parametrize("retries", [0, 1])
def test_retry_recovers_a_failed_task(cluster, tmp_path, monkeypatch, retries):
    """ldm's first attempt raises: its retry runs it; without retries its row is the error (one job per
    call, so no job-by-job rerun hides the difference)."""
    once = tmp_path / "fired"
    monkeypatch.setenv("LDBENCH_FAULT", f"raise:ldm:{once}")
    df = run_jobs(_suite(d_max=("inf",)), tmp_path / "run", progress=False, report=False,
                  executor=RayExecutor(retries=retries, group_size=1))
    st = dict(zip(df["method"], df["status"]))
    assert once.is_file() and st["hbao"] == "ok", st
    want = "ok" if retries else "error: RuntimeError: injected fault in ldm (task failed 1 time)"
    assert st["ldm"] == want, st


def test_ctrl_c_cancels_every_task_and_leaves_no_run_directory(cluster, tmp_path, monkeypatch):
    """SIGINT (what Ctrl-C sends) while an hbao task sleeps: KeyboardInterrupt in the driver (the CLI
    turns it into exit 130, tests/test_cli.py), every task killed, no run directory left."""
    fired = tmp_path / "sleeping"
    monkeypatch.setenv("LDBENCH_FAULT", f"sleep:hbao:{fired}")
    out = tmp_path / "run"

    def interrupt():
        deadline = time.monotonic() + 60
        while not fired.is_file() and time.monotonic() < deadline:
            time.sleep(0.1)
        seen["partial"] = [p.name for p in tmp_path.glob(".run.partial-*")]
        os.kill(os.getpid(), signal.SIGINT)

    seen: dict = {}
    t = threading.Thread(target=interrupt, daemon=True)
    t.start()
    with pytest.raises(KeyboardInterrupt):
        run_jobs(_suite(d_max=("inf",)), out, progress=False, report=False, executor=RayExecutor(group_size=1))
    t.join()
    assert fired.is_file() and seen["partial"], "interrupted while the run directory was being written"
    assert not out.exists() and not list(tmp_path.glob(".run*")), list(tmp_path.iterdir())
    task_pid = int(fired.read_text())
    for _ in range(50):  # the sleeping task was killed, not left running
        try:
            os.kill(task_pid, 0)
        except ProcessLookupError:
            break
        time.sleep(0.1)
    else:
        pytest.fail(f"task process {task_pid} still alive")
    for _ in range(100):  # both workers free again (Ray returns the resources of killed tasks shortly after)
        if ray.available_resources().get("CPU") == 2:
            break
        time.sleep(0.1)
    else:
        pytest.fail(f"cluster resources not released: {ray.available_resources()}")


def test_without_ray_one_line_exit_2(tmp_path, monkeypatch, capsys):
    from ldbench.harness.cli import main

    monkeypatch.setitem(sys.modules, "ray", None)  # import ray -> ImportError
    out = tmp_path / "run"
    rc = main(["run", "--scene", "cornell", "--method", "hbao", "--effect", "ao", "--d-max", "0.1", "--size", "16x16",
               "--out", str(out), "--executor", "ray"])
    err = capsys.readouterr().err
    assert rc == 2 and err.strip() == "ldbench: error: the Ray executor needs Ray: pip install 'ldbench[ray]'"
    assert not out.exists() and not list(tmp_path.iterdir())


def test_cli_flags_checked(tmp_path, capsys):
    from ldbench.harness.cli import main

    base = ["run", "--scene", "cornell", "--method", "hbao", "--effect", "ao", "--out", str(tmp_path / "r")]
    assert main(base + ["--retries", "2"]) == 2
    assert "--address and --retries go with --executor ray" in capsys.readouterr().err
    assert main(base + ["--executor", "ray", "--retries", "-1"]) == 2
    assert "--retries must be an integer >= 0" in capsys.readouterr().err
    assert not list(tmp_path.iterdir())


def test_cli_ctrl_c_is_exit_130(tmp_path, monkeypatch, capsys):
    """What the Ctrl-C test above raises becomes exit 130 and one line at the command line."""
    import ldbench.harness.executors
    from ldbench.harness.cli import main

    def interrupted(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(ldbench.harness.executors, "run_jobs", interrupted)
    assert main(["run", "--scene", "cornell", "--method", "hbao", "--effect", "ao", "--d-max", "0.1", "--executor", "ray",
                 "--out", str(tmp_path / "r")]) == 130
    assert capsys.readouterr().err == "ldbench: interrupted\n"


def test_ctrl_c_during_the_report_of_a_ray_run_never_commits(cluster, tmp_path, monkeypatch):
    """SIGINT while the report of a finished Ray run is written, its KeyboardInterrupt caught by the
    code it interrupted: the run is still not committed (KeyboardInterrupt, exit 130 at the CLI)."""
    import ldbench.reports.report

    def swallowing_report(*a, **k):
        try:
            os.kill(os.getpid(), signal.SIGINT)
        except KeyboardInterrupt:
            pass

    monkeypatch.setattr(ldbench.reports.report, "build_report", swallowing_report)
    out = tmp_path / "run"
    with pytest.raises(KeyboardInterrupt):
        run_jobs(_suite(d_max=("inf",)), out, progress=False, report=True,
                 executor=RayExecutor())
    assert not out.exists() and not list(tmp_path.glob(".run*")), list(tmp_path.iterdir())


# ---- the driver renders references while the workers start ------------------------------------------
@pytest.fixture(scope="module")
def serial3(tmp_path_factory):
    """A serial run of three references (d_max 0.25, 0.5, inf), two jobs each."""
    out = tmp_path_factory.mktemp("serial3") / "run"
    return out, run_jobs(_suite(d_max=(0.25, 0.5, "inf")), out, progress=False, report=False)


@pytest.mark.parametrize("driver", [0, 1, 3])
def test_driver_references_then_workers_each_reference_once(cluster, serial3, tmp_path, driver):
    """The driver renders the first ``driver`` references at most (the first always, the others while no
    worker is ready), the workers the rest: every reference once, and the rows and images equal the
    serial run's."""
    out = tmp_path / "ray"
    ex = RayExecutor(group_size=1, driver_references=driver)
    df = run_jobs(_suite(d_max=(0.25, 0.5, "inf")), out, progress=False, report=False, executor=ex)
    assert (df["status"] == "ok").all() and differences(serial3[0], out) == []
    assert not list(out.glob(".*"))
    by_workers = sum(p["references"] for p in ex.stats["processes"])
    assert 1 <= ex.stats["driver_references"] <= 3 if driver else ex.stats["driver_references"] == 0, ex.stats
    if driver == 1:
        assert ex.stats["driver_references"] == 1
    assert ex.stats["driver_references"] + by_workers == 3, ex.stats  # none rendered twice, none skipped
    assert ex.stats["calls"] == by_workers + 6, ex.stats  # one call per job (group_size=1)
    # each worker opened its GL context and chose Mitsuba's variant when it started, before its first call
    from ldbench.references.variant import choose_variant

    assert all(p["warmed"] == {"gl": True, "mitsuba": choose_variant()} for p in ex.stats["processes"]), ex.stats


def test_reference_failing_in_the_driver_reads_as_in_a_worker(cluster, tmp_path, monkeypatch):
    """Every reference raises; without retries its jobs' rows say the same whether the driver or a worker
    tried it."""
    monkeypatch.setenv("LDBENCH_FAULT", "raise:reference")
    st = {}
    for driver in (1, 0):
        ex = RayExecutor(retries=0, driver_references=driver)
        df = run_jobs(_suite(d_max=("inf",)), tmp_path / f"run{driver}", progress=False, report=False, executor=ex)
        st[driver] = df["status"].tolist()
        assert ex.stats["driver_references"] == 0, ex.stats
    assert st[1] == st[0] == ["error: reference task failed: RuntimeError: injected fault in reference"] * 2, st


def test_reference_failing_in_the_driver_is_retried_by_a_worker(cluster, serial, tmp_path, monkeypatch):
    """The driver's attempt fails once: it counts as the first call, a worker's retry renders it."""
    once = tmp_path / "fired"
    monkeypatch.setenv("LDBENCH_FAULT", f"raise:reference:{once}")
    out = tmp_path / "run"
    ex = RayExecutor(retries=1, driver_references=1)
    df = run_jobs(_suite(d_max=("inf",)), out, progress=False, report=False, executor=ex)
    assert once.read_text().strip() == str(os.getpid()), "the driver made the first attempt"
    assert (df["status"] == "ok").all() and differences(serial[0], out) == []
    assert ex.stats["driver_references"] == 0 and sum(p["references"] for p in ex.stats["processes"]) == 1
    assert ex.stats["calls"] == 3, ex.stats  # the retry, then one call per job: none before the reference existed


def test_driver_references_checked():
    for bad in (-1, 1.5, True, "2"):
        with pytest.raises(Exception, match="driver references must be an integer >= 0"):
            RayExecutor(driver_references=bad)


def test_jobs_wait_for_their_reference(cluster, serial3, tmp_path, monkeypatch):
    """The first reference call (the first job's reference) takes two seconds longer: the other worker
    renders the other two meanwhile and then runs their jobs, not the first job, whose reference does not
    exist yet."""
    from ldbench.harness.runner import prepare_key

    jobs = _suite(d_max=(0.25, 0.5, "inf")).jobs
    assert sorted({prepare_key(j) for j in jobs}, key=str)[0] == prepare_key(jobs[0])  # the first call's
    monkeypatch.setenv("LDBENCH_FAULT", f"delay:reference:{tmp_path / 'delayed'}")
    out = tmp_path / "ray"
    ex = RayExecutor(group_size=1, driver_references=0)
    df = run_jobs(_suite(d_max=(0.25, 0.5, "inf")), out, progress=False, report=False, executor=ex)
    assert (df["status"] == "ok").all() and differences(serial3[0], out) == []
    assert sum(p["references"] for p in ex.stats["processes"]) == 3 and ex.stats["calls"] == 9, ex.stats


@pytest.mark.filterwarnings("error::RuntimeWarning")
def test_non_finite_answers_and_huge_memory_on_ray_as_locally(cluster, tmp_path, monkeypatch):
    """The Ray executor's tasks score through the same ``runner.run_job``: a plugin's NaN/inf pixels and NaN
    mask are ``degraded`` rows counted in ``nonfinite``, its ``memory_bytes`` of ±1e30 that row's error, every
    other row kept (tests/test_plugins.py runs the same check on the local executor)."""
    from ldbench.core import plugins
    from ldbench.core.effects import base as effects_base
    from test_plugins import check_bad_output_rows

    monkeypatch.setenv(plugins.ENV[plugins.METHOD_GROUP], "")
    monkeypatch.setattr(effects_base, "_REGISTRY", None)
    check_bad_output_rows(tmp_path, monkeypatch, executor=RayExecutor(group_size=1))


def test_a_job_past_its_time_limit_on_ray_is_one_row_and_the_run_goes_on(cluster, tmp_path, monkeypatch):
    """A plugin whose frame never returns, on a Ray worker: the suite's job_timeout stops it there (the worker
    runs its jobs on its main thread, where the limit's alarm is delivered), its row says so, the other rows
    are kept and the run completes (tests/test_cli.py checks the same on the local executor)."""
    from ldbench.core import plugins
    from ldbench.core.effects import base as effects_base
    from test_plugins import _module

    monkeypatch.setenv(plugins.ENV[plugins.METHOD_GROUP], "")
    monkeypatch.setattr(effects_base, "_REGISTRY", None)
    src = _module(tmp_path / "src", "forever", """
        import time
        from ldbench.methods.hbao import HBAO

        class Forever(HBAO):
            name = "forever"

            def frame(self, view, effect, inputs=None):  # 20 s at most: unstopped, the test fails, not hangs
                t = time.perf_counter()
                while time.perf_counter() - t < 20:
                    time.sleep(0.01)
                raise AssertionError("not stopped by the time limit")
    """)
    monkeypatch.syspath_prepend(str(src))
    suite = suite_from_dict({"suite": {"name": "t", "size": "16x16", "spp": 1, "warmup": 0, "frames": 1,
                                       # hbao's set-up on a Ray worker took 2 s on two cores busy with a second
                                       # test run (it was then past a limit of 3 s): 8 s leaves room
                                       "job_timeout": 8},
                             "run": [{"scene": "cornell", "effect": "ao", "d_max": 0.5,
                                      "methods": ["forever:Forever", "hbao"]}]}, name="t")
    t0 = time.perf_counter()
    df = run_jobs(suite, tmp_path / "run", progress=False, report=False, executor=RayExecutor(group_size=1))
    st = dict(zip(df["method"], df["status"]))
    assert st["forever"].startswith("error: the job ran past its time limit of 8 s"), st
    assert st["hbao"] == "ok" and time.perf_counter() - t0 < 60


def test_a_job_stuck_outside_python_on_ray_is_killed_and_the_run_goes_on(cluster, tmp_path, monkeypatch):
    """A job that never returns to Python (SIGALRM blocked, as inside a hung GPU driver call), so that the
    worker's own time limit cannot stop it: the driver kills and restarts that worker once the call is past its
    jobs' limits and the grace, the job's row says so, the job grouped with it runs again alone, and the run
    completes well before the stuck call's ten minutes."""
    monkeypatch.setenv("LDBENCH_FAULT", "stuck:hbao")
    suite = suite_from_dict({"suite": {"name": "t", "size": "16x16", "spp": 1, "warmup": 0, "frames": 1,
                                       "job_timeout": 8},  # as in the test above: room for a slow set-up
                             "run": [{"scene": "cornell", "effect": "ao", "d_max": 0.5, "methods": ["ldm", "hbao"],
                                      "params": {"ldm": {"directions": 16, "resolution": 32}}}]}, name="t")
    ex = RayExecutor(group_size=2, retries=1)
    ex.hung_grace_s = 4.0
    t0 = time.perf_counter()
    df = run_jobs(suite, tmp_path / "run", progress=False, report=False, executor=ex)
    st = dict(zip(df["method"], df["status"]))
    assert st["hbao"].startswith("error: the job ran past its time limit of 8 s and did not return"), st
    assert st["ldm"] == "ok" and time.perf_counter() - t0 < 120, (st, time.perf_counter() - t0)
    assert not list(tmp_path.glob(".run.*"))
