"""Executors: who runs the jobs of a :class:`~ldbench.harness.runner.RunPlan`.

An executor has ``uses_driver_gpu`` (whether the jobs use the GL context of the process that holds the
run directory) and ``run(plan, out, *, gpu, progress) -> rows`` (one record row per ``plan.jobs``
entry, in that order; images written under ``out``). The run directory itself (lock, partial folder,
results files, commit or abort) stays with :func:`run_jobs`, whatever the executor.

================  ==================================================================================
``local``         this process, one job after the other (the default; :mod:`.local`); ``writers=N``: N
                  writer processes score and save while it renders (:mod:`ldbench.harness.writers`)
``ray``           one Ray task per job group on a local or remote Ray cluster (:mod:`.ray`,
                  ``pip install 'ldbench[ray]'``; docs/how-to/run-on-ray.md)
================  ==================================================================================
"""
from __future__ import annotations

import json
import signal
import threading
from typing import TYPE_CHECKING

from ldbench.core.errors import LdbenchError
from ldbench.core.gpu import Gpu

from .. import records
from ..rundir import RunDir
from ..runner import plan_run
from .local import LocalExecutor
from .ray import RayExecutor

if TYPE_CHECKING:  # pandas is imported where the table is built (a fast CLI start)
    import pandas as pd

    from ..suite import Suite

# Heavy: run_jobs imports the report module (scipy) only when it writes a report.

EXECUTORS = ("local", "ray")


def get_executor(executor=None, **options):
    """An executor object from a name (None = ``local``) and its options, or ``executor`` itself."""
    if executor is None or executor == "local":
        writers = options.pop("writers", None)
        if options:
            raise LdbenchError(f"--executor local takes no {', '.join('--' + k for k in options)}")
        return LocalExecutor(writers=writers)
    if executor == "ray":
        if options.get("writers") is not None:
            raise LdbenchError("--writers goes with the local executor; Ray workers score and save their own jobs")
        options.pop("writers", None)
        return RayExecutor(**options)
    if isinstance(executor, str):
        raise LdbenchError(f"unknown executor {executor!r} (known: {', '.join(EXECUTORS)})")
    return executor


def run_jobs(suite: "Suite", out_dir, *, progress: bool = True, report: bool = True,
             reference_cache: bool = True, executor=None, save_arrays: bool = False) -> "pd.DataFrame":
    """Execute every job of ``suite``; write ``out_dir`` atomically. Returns the results table.

    ``executor``: None or ``"local"`` (this process, one job after the other), ``"ray"``, or an
    executor object (:mod:`ldbench.harness.executors`). Whatever runs the jobs, this process holds the run
    directory's lock, writes the results and commits the folder, or deletes it on any failure.
    """
    ex = get_executor(executor)  # before the run directory: a missing extra is one line, nothing written
    rundir = RunDir(out_dir)  # refuses a DIR that is not an ldbench run; lock; partial folder
    tmp = rundir.open()
    gpu = None
    interrupts = _Interrupts()
    try:
        interrupts.__enter__()
        gpu = Gpu()
        plan = plan_run(suite, gpu, reference_cache=reference_cache)
        plan.save_arrays = bool(save_arrays or getattr(ex, "save_arrays", False))
        plan.job_timeout = float(getattr(suite, "job_timeout", 0.0) or 0.0)
        suite.jobs = plan.jobs
        if not ex.uses_driver_gpu:  # jobs open their own contexts elsewhere: hold no GPU here
            gpu.release()
            gpu = None
        rows = ex.run(plan, tmp, gpu=gpu, progress=progress)
        records.write_results(rows, tmp)
        if gpu is not None:
            gpu.release()
            gpu = None
        (tmp / "suite.json").write_text(json.dumps({"name": suite.name, "source": suite.source,
                                                    "jobs": len(suite.jobs)}, indent=1))
        if report:
            from ldbench.reports.report import build_report
            build_report(tmp, records.read_results(tmp, unfinished=True))
        if interrupts.seen:  # a Ctrl-C whose KeyboardInterrupt some library caught: still no commit
            raise KeyboardInterrupt
        rundir.commit()  # old run aside, new one in, old one deleted
    except BaseException:
        try:
            if gpu is not None:
                gpu.release()
        finally:
            rundir.abort()
        raise
    finally:
        interrupts.__exit__()
    return records.read_results(out_dir)


class _Interrupts:
    """Remembers a SIGINT (Ctrl-C) received while a run directory is written, so that a run is never
    committed after one, even when code between the signal and the commit (a report library, a
    cluster client) caught the KeyboardInterrupt. The signal itself still raises as before."""

    def __init__(self):
        self.seen = False
        self._prev = None

    def __enter__(self):
        prev = signal.getsignal(signal.SIGINT)
        if threading.current_thread() is threading.main_thread() and callable(prev):
            self._prev = prev
            signal.signal(signal.SIGINT, self._handler)
        return self

    def _handler(self, signum, frame):
        self.seen = True
        self._prev(signum, frame)  # Python's default handler raises KeyboardInterrupt

    def __exit__(self, *exc):
        if self._prev is not None:
            signal.signal(signal.SIGINT, self._prev)
            self._prev = None
        return False
