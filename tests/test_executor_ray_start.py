"""The Ray executor starting its own local cluster (no ``ray.init`` before the run, unlike
tests/test_executor_ray.py): the cluster starts in a background thread while the driver renders the
references, and is shut down at the end, also after Ctrl-C."""
import os
import signal
import threading
import time

import pytest

# Slow tier: each test starts its own local Ray cluster (a few seconds each on two cores).
pytestmark = pytest.mark.slow
ray = pytest.importorskip("ray", reason="the test extra installs ray (pip install -e '.[test]')")

from ldbench.harness.executors import run_jobs  # noqa: E402
from ldbench.harness.executors.check import differences  # noqa: E402
from ldbench.harness.executors.ray import RayExecutor  # noqa: E402
from ldbench.harness.suite import suite_from_dict  # noqa: E402


def _suite():
    return suite_from_dict({"suite": {"name": "ray-start", "size": "24x24", "spp": 8, "warmup": 0, "frames": 1},
                            "run": [{"scene": "cornell", "effect": "ao", "d_max": [0.5, "inf"],
                                     "methods": ["hbao"]}]}, name="ray-start")


def _cluster_threads():
    return [t for t in threading.enumerate() if t.name == "ldbench-ray-cluster"]


@pytest.fixture(autouse=True)
def no_cluster():
    if ray.is_initialized():
        pytest.skip("a Ray cluster is already running in this process")
    yield
    assert not ray.is_initialized() and not _cluster_threads(), "the run's local cluster was not shut down"


def test_driver_renders_references_while_the_local_cluster_starts(tmp_path, caplog, monkeypatch):
    """No worker is ready before the driver's first reference: the driver renders at least that one, the
    rows and images equal the serial run's, and the SIGTERM handler is given back. The workers run at the
    driver's priority: no warning about their niceness."""
    import logging

    monkeypatch.setattr(logging.getLogger("ldbench"), "propagate", True)
    caplog.set_level(logging.INFO, logger="ldbench")
    serial = tmp_path / "serial"
    run_jobs(_suite(), serial, progress=False, report=False)
    term = signal.getsignal(signal.SIGTERM)
    ex = RayExecutor()
    out = tmp_path / "ray"
    df = run_jobs(_suite(), out, progress=False, report=False, executor=ex)
    assert (df["status"] == "ok").all() and differences(serial, out) == []
    assert ex.stats["driver_references"] >= 1, ex.stats
    assert ex.stats["driver_references"] + sum(p["references"] for p in ex.stats["processes"]) == 2, ex.stats
    assert signal.getsignal(signal.SIGTERM) is term
    # the workers run at the driver's priority, not Ray's worker niceness (15)
    nice = os.getpriority(os.PRIO_PROCESS, 0)
    assert ex.stats["processes"] and all(p["nice"] == nice for p in ex.stats["processes"]), ex.stats
    assert any(r.getMessage().startswith("ray: worker ") for r in caplog.records)  # the lines are seen here
    assert not [r for r in caplog.records if "niceness" in r.getMessage() and r.levelname == "WARNING"]


def test_ctrl_c_while_the_driver_renders_and_the_cluster_starts(tmp_path, monkeypatch):
    """SIGINT while the driver is inside its first reference: KeyboardInterrupt, no run directory left,
    the cluster (started meanwhile in its thread) shut down."""
    fired = tmp_path / "sleeping"
    monkeypatch.setenv("LDBENCH_FAULT", f"sleep:reference:{fired}")
    out = tmp_path / "run"

    main = threading.main_thread().ident

    def interrupt():
        deadline = time.monotonic() + 60
        while not fired.is_file() and time.monotonic() < deadline:
            time.sleep(0.05)
        # to the main thread, which sleeps in the fault: os.kill may hand the signal to one of Ray's threads,
        # and the main thread's sleep (ten minutes) would not wake for it (seen once)
        signal.pthread_kill(main, signal.SIGINT)

    t = threading.Thread(target=interrupt, daemon=True)
    t.start()
    with pytest.raises(KeyboardInterrupt):
        run_jobs(_suite(), out, progress=False, report=False, executor=RayExecutor())
    t.join()
    assert int(fired.read_text()) == os.getpid(), "the driver, not a worker, was rendering"
    assert not out.exists() and not list(tmp_path.glob(".run*")), list(tmp_path.iterdir())
