"""``ldbench run --writers N``: N writer processes score finished jobs and save their images
(:func:`~ldbench.harness.runner.finish_job`) while the main thread renders the next jobs on its GL context.

A job's GPU part (set-up, frames, read-back, release: :func:`~ldbench.harness.runner.start_job`) stays on
the main thread, the only one that holds the GL context; what follows is CPU work on numpy arrays (metrics,
image encoding, file writes), handed over as a picklable :class:`~ldbench.harness.runner.Finish`.
Processes, not threads: FLIP (``flip_evaluator``), the largest part of scoring, holds the GIL for its
whole call (1.8 s for an 800² image on a 2-core CPU host), so a thread would stall the main thread's
frames meanwhile.

* **Bounded**: at most N jobs in flight, one per writer (a job is in flight from its hand-off until its
  row is back); when all N are busy the main thread waits for one (the ``wait`` phase). A writer keeps the
  inputs and reference of the last :data:`HELD` prepare keys it was sent: each goes to a writer once, and
  jobs come grouped by key.
* **Rows in job order**, whatever order the writers finish in. A failure is that job's row's status, as on
  the serial path: an exception in scoring or saving and the time limit (``finish_job``, which runs on the
  writer's main thread, where SIGALRM works), a writer process that dies (``error: the writer process
  ended ...``; a new one takes its place). A job whose data cannot be pickled here, or unpickled there (a
  plugin's class the writer cannot import), is finished in this process instead.
* **Closing** (the end, an exception, Ctrl-C, SIGTERM): the jobs in flight are waited for (on an error at
  most :data:`DRAIN_TIMEOUT_S`; a second Ctrl-C stops waiting), then every writer is stopped and joined. So
  no writer writes into the run directory once the pool is closed: a run directory aborted after that
  (:mod:`ldbench.harness.rundir`) is deleted whole, and the rows that came back are complete (their files
  written). Writers ignore SIGINT (Ctrl-C reaches the whole process group; the main process decides) and
  end when the main process dies (Linux ``PR_SET_PDEATHSIG``). While the pool is open, SIGTERM raises
  SystemExit in the main thread (as the Ray executor does), so the run directory is deleted.

Writers are started with ``spawn``: never ``fork`` from a process that holds a GL context and driver
threads. They start with the pool, before the references are prepared, so their imports overlap that; a
job goes to a writer once it has said it started (:data:`READY`). ``spawn`` imports the main module again
in each writer: a script that starts a run needs ``if __name__ == "__main__":``; without it no writer
starts, one warning says so, and every job is finished in this process.
"""
from __future__ import annotations

import ctypes
import logging
import multiprocessing
import os
import pickle
import signal
import threading
import time
from collections.abc import Callable
from contextlib import suppress
from dataclasses import dataclass, field
from multiprocessing.connection import Connection, wait
from typing import Any

from ldbench.core.errors import exit_on_sigterm

from .phases import Phases
from .runner import error_row, error_text, finish_job

# Worker entry: _warm_up() imports the scoring libraries in the writer process, after _writer_main() has set
# OMP_NUM_THREADS for flip_evaluator's libgomp; the main process never loads them for the writers' sake.

#: Prepare keys (inputs + reference) a writer keeps; jobs come grouped by key, so two cover a change of key.
HELD = 2
#: The most seconds the jobs in flight are waited for when the pool closes on an error or Ctrl-C.
DRAIN_TIMEOUT_S = 30.0
#: The largest ``--writers``.
MAX_WRITERS = 64
#: The most writers ``--writers`` picks by itself (:func:`default_writers`).
AUTO_MAX = 8
#: What a writer says once it has started (imported what scoring and saving need).
READY = "ready"
#: How a writer's answer begins when it could not unpickle a job (a plugin's class it cannot import): the
#: main process finishes that job itself.
UNREADABLE = "unreadable: "

log = logging.getLogger(__name__)

#: ``finish(task, prep, phases, row_calls=...) -> row``: what a writer runs for one job
#: (:func:`ldbench.harness.runner.finish_job`; tests give an instrumented one).
Finisher = Callable[..., dict]


def default_writers(device: str | None, cpus: int | None = None) -> int:
    """The writer count of ``ldbench run`` without ``--writers``: 0 (serial) on a CPU renderer (llvmpipe:
    the frames run on the same cores, so writers would slow them and disturb their times; measured in
    docs/reference/cli.md), else half the CPU cores, at most :data:`AUTO_MAX`."""
    if device == "cpu-software":
        return 0
    n = cpus if cpus is not None else usable_cpus()
    return max(0, min(AUTO_MAX, n // 2))


def usable_cpus() -> int:
    """The CPU cores this process may run on (its affinity: a container's share, not the host's count)."""
    try:
        return len(os.sched_getaffinity(0)) or 1
    except (AttributeError, OSError):  # not Linux
        return os.cpu_count() or 1


def _finish_job(task, prep, phases: Phases, *, row_calls: int = 1) -> dict:
    return finish_job(task, prep, phases, row_calls=row_calls)


@dataclass
class _Writer:
    proc: Any  # multiprocessing's SpawnProcess
    conn: Connection
    held: list = field(default_factory=list)  # prepare key ids it holds, the latest last
    job: int | None = None  # the job (its index) it is finishing
    ready: bool = False  # it said it started (imports done)


class Writers:
    """A pool of ``n`` writer processes (see the module docstring). Use as a context manager::

        with Writers(n, phases=phases) as pool:
            for i, job in enumerate(jobs):
                out = start_job(ctx, job, prep)
                pool.submit(i, key, prep, out) if isinstance(out, Finish) else pool.put(i, out)
            rows = pool.rows()

    ``phases`` gets the main thread's ``handoff`` and ``wait`` (and ``score``/``save`` of a job finished
    here); :attr:`writer_phases` the writers' own, summed over them."""

    def __init__(self, n: int, *, phases: Phases | None = None, finish: Finisher | None = None):
        if not 1 <= n <= MAX_WRITERS:
            raise ValueError(f"writers must be in [1, {MAX_WRITERS}], got {n}")
        self.n = n
        self.phases = phases if phases is not None else Phases()
        self.writer_phases = Phases()
        self.finish = finish or _finish_job
        self.max_in_flight = 0  # the most jobs in flight at once, as this process counted them
        self.inline = 0  # jobs finished in this process: data that cannot be pickled, writers that cannot start
        self.broken: str | None = None  # why no writer could start
        self._mp = multiprocessing.get_context("spawn")
        self._rows: dict[int, dict] = {}
        self._tasks: dict[int, tuple] = {}  # the jobs in flight: (Finish, Prepared), for an error row
        self._key_ids: dict = {}
        self._blob: tuple[int, bytes | None] | None = None  # the last prepare key id and its pickle
        self._sigterm: Any = None
        self._writers: list[_Writer] = []
        try:
            for _ in range(n):
                self._writers.append(self._start())
        except BaseException:
            self._stop(kill=True)
            raise

    # ---- life cycle ---------------------------------------------------------------------------------
    def _start(self) -> _Writer:
        here, there = self._mp.Pipe()
        threads = max(1, usable_cpus() // self.n)  # FLIP's OpenMP threads: the cores shared out
        proc = self._mp.Process(target=_writer_main, args=(there, self.finish, os.getpid(), threads),
                                name="ldbench-writer", daemon=True)
        proc.start()
        there.close()
        return _Writer(proc, here)

    def __enter__(self) -> Writers:
        if threading.current_thread() is threading.main_thread() and \
                signal.getsignal(signal.SIGTERM) is signal.SIG_DFL:
            # SIGTERM -> SystemExit: the pool closes and the partial run directory is deleted
            self._sigterm = signal.signal(signal.SIGTERM, exit_on_sigterm)
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        try:
            if exc_type is not None:
                self._drain(DRAIN_TIMEOUT_S)
        finally:
            self._stop(kill=exc_type is not None)
            if self._sigterm is not None:
                signal.signal(signal.SIGTERM, self._sigterm)
                self._sigterm = None

    def _drain(self, timeout: float | None) -> None:
        """Wait for the jobs in flight (``timeout`` seconds at most; None: no limit, else a Ctrl-C stops
        waiting)."""
        t0 = time.perf_counter()
        try:
            while self._busy():
                left = None if timeout is None else timeout - (time.perf_counter() - t0)
                if left is not None and left <= 0:
                    break
                self._collect(left)
        except KeyboardInterrupt:
            if timeout is None:
                raise
        finally:
            self.phases.add("wait", time.perf_counter() - t0)

    def _stop(self, kill: bool) -> None:
        """End every writer (``kill``: at once, whatever it is doing) and wait for it."""
        for w in self._writers:
            if kill:
                w.proc.terminate()
            else:
                with suppress(OSError):
                    w.conn.send(None)
        for w in self._writers:
            w.proc.join(None if kill else 10.0)
            if w.proc.is_alive():  # pragma: no cover - a writer that does not end when asked
                w.proc.kill()
                w.proc.join()
            w.conn.close()
        self._writers = []

    # ---- jobs ---------------------------------------------------------------------------------------
    def put(self, i: int, row: dict) -> None:
        """Job ``i``'s row, made without a writer (an error before its frames ended)."""
        self._rows[i] = row

    def submit(self, i: int, key, prep, task) -> None:
        """Hand job ``i`` (its :class:`~ldbench.harness.runner.Finish` ``task``, and ``prep``, the
        :class:`~ldbench.harness.runner.Prepared` of its prepare ``key``) to a writer; waits while all
        are busy. Finished in this process when ``task`` or ``prep`` cannot be pickled, or when no writer
        could start."""
        kid = self._key_ids.setdefault(key, len(self._key_ids))
        t0 = time.perf_counter()
        job_blob = _pickled(task)
        prep_blob = self._prep_blob(kid, prep) if job_blob is not None else None
        handoff = time.perf_counter() - t0
        blobs = (prep_blob, job_blob) if prep_blob is not None and job_blob is not None else None
        w = self._free(kid) if blobs is not None else None
        while w is not None and blobs is not None:
            t0 = time.perf_counter()
            try:
                if kid not in w.held:
                    w.conn.send(("prep", kid, None))
                    w.conn.send_bytes(blobs[0])
                    keep = [k for k in w.held if k != kid]  # as the writer keeps them (_writer_main)
                    w.held = keep[max(0, len(keep) - HELD + 1):] + [kid]
                w.conn.send(("job", kid, i))
                w.conn.send_bytes(blobs[1])
            except OSError:  # a broken pipe: it is gone; another one
                handoff += time.perf_counter() - t0
                self._lost(w)
                w = self._free(kid)
                continue
            handoff += time.perf_counter() - t0
            self.phases.add("handoff", handoff)
            w.job = i
            self._tasks[i] = (task, prep)
            self.max_in_flight = max(self.max_in_flight, len(self._busy()))
            self._collect(0)  # rows that are back already
            return
        self.phases.add("handoff", handoff)
        self.inline += 1
        self._rows[i] = self.finish(task, prep, self.phases, row_calls=0)

    def rows(self) -> list[dict]:
        """Every row, in job order, once the jobs in flight are back."""
        self._drain(None)
        return self.done()

    def done(self) -> list[dict]:
        """The rows back so far, in job order (after the pool closed on an error or Ctrl-C: every job handed
        over before it, unless a writer was stopped while finishing one, or the drain ran out of time)."""
        return [self._rows[i] for i in sorted(self._rows)]

    def text(self) -> str:
        """The writers' part of the time split line (module docstring of ldbench/harness/phases.py)."""
        extra = f", {self.inline} finished in the main process" if self.inline else ""
        extra += f" ({self.broken})" if self.broken else ""
        return (f"{self.n} writer process{'es' if self.n > 1 else ''} beside the main thread, at most "
                f"{self.max_in_flight} job{'s' if self.max_in_flight != 1 else ''} in flight{extra} (their own "
                f"seconds, overlapping the above): {Phases.text(self.writer_phases.as_dict())}")

    # ---- inside -------------------------------------------------------------------------------------
    def _prep_blob(self, kid: int, prep) -> bytes | None:
        if self._blob is None or self._blob[0] != kid:  # jobs come grouped by key: keep the last one's
            self._blob = (kid, _pickled(prep))
        return self._blob[1]

    def _busy(self) -> list[_Writer]:
        return [w for w in self._writers if w.job is not None]

    def _free(self, kid: int) -> _Writer | None:
        """A started writer with no job, one that holds ``kid`` if any; waits for one while all are busy or
        starting. None when no writer could start (:attr:`broken`)."""
        free = [w for w in self._writers if w.job is None and w.ready]
        if not free and self._writers:
            t0 = time.perf_counter()
            while not free and self._writers:
                self._collect(None)
                free = [w for w in self._writers if w.job is None and w.ready]
            self.phases.add("wait", time.perf_counter() - t0)
        return next((w for w in free if kid in w.held), free[0]) if free else None

    def _collect(self, timeout: float | None) -> None:
        """Take what the writers said: that they started, the rows that are back (waiting up to ``timeout``
        seconds for one message; None: until one comes); a writer that ended is :meth:`_lost`."""
        watch = [w for w in self._writers if w.job is not None or not w.ready]
        if not watch:
            return
        ready = set(wait([w.conn for w in watch] + [w.proc.sentinel for w in watch], timeout))
        for w in watch:
            if w.conn not in ready and w.proc.sentinel not in ready:
                continue
            try:
                msg = w.conn.recv()
            except (EOFError, OSError):  # the process ended without an answer
                self._lost(w)
                continue
            if msg == READY:
                w.ready = True
                continue  # its answer, if there is one already, on the next call
            i, row, split, error = msg
            task, prep = self._tasks.pop(i)
            w.job = None
            if error is not None and error.startswith(UNREADABLE):  # a class it cannot import: finished here
                log.debug(f"job {i} finished in the main process: {error}")
                self.inline += 1
                self._rows[i] = self.finish(task, prep, self.phases, row_calls=0)
                continue
            self._rows[i] = row if error is None else _error_row(task, error)
            self.writer_phases.merge(split)

    def _lost(self, w: _Writer) -> None:
        """``w``'s process ended. Its job becomes an error row, and a new writer takes its place; but a
        writer that never started (a script that starts a run without ``if __name__ == "__main__":``, which
        ``spawn`` needs) means none will: its job, and every later one, is finished in this process."""
        if w.proc.is_alive():
            w.proc.terminate()
        w.proc.join()
        w.conn.close()
        k = self._writers.index(w)
        if w.ready:
            self._writers[k] = self._start()
        else:
            del self._writers[k]
            if self.broken is None:
                self.broken = f"the writer processes could not start: exit code {w.proc.exitcode}"
                log.warning(f"{self.broken}; jobs are scored and saved in the main process")
        if w.job is not None:
            task, prep = self._tasks.pop(w.job)
            if w.ready:
                self._rows[w.job] = _error_row(task, "error: the writer process ended while scoring and saving "
                                                     f"this job (exit code {w.proc.exitcode})")
            else:
                self.inline += 1
                self._rows[w.job] = self.finish(task, prep, self.phases, row_calls=0)


def _pickled(obj) -> bytes | None:
    """``obj`` pickled, or None when it cannot be (a GL object, a lambda inside a plugin's result)."""
    try:
        return pickle.dumps(obj, protocol=pickle.HIGHEST_PROTOCOL)
    except Exception as e:  # noqa: BLE001 - pickling raises many kinds (TypeError, PicklingError, ...)
        log.debug(f"finished in the main process: {type(e).__name__}: {e}")
        return None


def _error_row(task, status: str) -> dict:
    return error_row(task, status)


class _Unreadable:
    """Data a writer could not unpickle (a plugin module it cannot import): the main process finishes the job."""

    def __init__(self, why: str):
        self.why = why


def _end_with_parent(parent: int) -> None:
    """Ask Linux to send this process SIGTERM when its parent dies (a killed run leaves no writer behind)."""
    try:
        ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGTERM)  # 1: PR_SET_PDEATHSIG
    except (OSError, AttributeError):  # not Linux: the writer ends when its pipe closes
        pass
    if os.getppid() != parent:  # the parent died before the request
        os._exit(0)


def _warm_up() -> None:
    """Score and make a row of a tiny image once, so that the first job does not pay the imports (SciPy,
    scikit-image, FLIP, pandas: one to two seconds on a 2-core host)."""
    import numpy as np
    import OpenEXR  # noqa: F401 (the image writers' libraries)
    from PIL import PngImagePlugin  # noqa: F401

    from ldbench.core import metrics
    from . import records

    a = np.linspace(0, 1, 8 * 8, dtype=np.float32).reshape(8, 8, 1)
    metrics.all_metrics(a, a[::-1].copy(), data_range=1.0)
    records.make_row(scene="x", psnr=1.0, width=1)  # a number: pandas tells missing values


def _writer_main(conn: Connection, finish: Finisher, parent: int, threads: int) -> None:
    """A writer process: ``("prep", key id, None)`` + data keeps a prepare key's inputs and reference,
    ``("job", key id, i)`` + a Finish answers ``(i, row, phases, None)`` (or ``(i, None, {}, status)``);
    None or a closed pipe ends it. ``threads``: OpenMP threads (FLIP), unless the environment sets them."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C reaches the whole process group: the main process decides
    _end_with_parent(parent)
    os.environ.setdefault("OMP_NUM_THREADS", str(threads))  # before flip_evaluator loads libgomp

    with suppress(Exception):
        _warm_up()
    try:
        conn.send(READY)
    except OSError:
        return
    held: dict[int, Any] = {}
    while True:
        try:
            head = conn.recv()
            if head is None:
                return
            kind, kid, i = head
            blob = conn.recv_bytes()
        except (EOFError, OSError, KeyboardInterrupt):
            return
        try:
            obj = pickle.loads(blob)
        except Exception as e:  # noqa: BLE001 - the job's row says why
            obj = _Unreadable(error_text(e))
        del blob
        if kind == "prep":
            held.pop(kid, None)
            held[kid] = obj
            while len(held) > HELD:
                held.pop(next(iter(held)))
            continue
        prep = held.get(kid, _Unreadable("its inputs and reference were not sent"))
        bad = obj if isinstance(obj, _Unreadable) else prep if isinstance(prep, _Unreadable) else None
        ph = Phases()
        answer: tuple[int, dict | None, dict, str | None]
        if bad is not None:
            answer = (i, None, {}, UNREADABLE + bad.why)
        else:
            try:
                answer = (i, finish(obj, prep, ph), ph.as_dict(), None)
            except Exception as e:  # noqa: BLE001 - finish_job makes its own error rows; another finisher may not
                answer = (i, None, ph.as_dict(), f"error: {error_text(e)}")
        del obj
        try:
            conn.send(answer)
        except (OSError, KeyboardInterrupt):
            return
