"""The Ray executor (``ldbench run SUITE --executor ray [--address ADDR] [--retries N]``; docs/ray.md).

=====================  ==========================================================================
cluster                ``--address ADDR`` joins a running cluster (``auto``, ``HOST:6379``,
                       ``ray://HOST:10001``); without it a local cluster is started and shut down
                       at the end. A process that already called ``ray.init`` keeps its cluster.
resources              ``num_gpus=1`` per task when the cluster has GPUs, else ``num_cpus=1`` (a
                       CPU-only cluster: llvmpipe); ``max_calls=1``: every task is a fresh process,
                       with fresh GL and Dr.Jit state.
references             one task per (scene, effect, size, spp, seed) builds the effect's inputs and
                       renders (or loads) the reference into the cache (references/cache.py, atomic);
                       the job tasks that need it take its object ref as an argument, so Ray starts
                       them once it exists: it is never rendered twice.
job groups             jobs sharing a reference run in one task (one process start, one context,
                       shaders compiled once), at most ``group_size`` per task (default: enough tasks
                       for two per worker).
images                 a task writes into ``<run>/.stage/<id>/`` when it sees the run directory (a
                       shared file system, recognised by a token file), else into a local temporary
                       folder whose files it returns; the driver moves or writes them into place.
faults                 a task that dies (worker killed, GPU fault, out of memory) or raises is retried
                       ``retries`` times; a group that still fails is re-run job by job, and a job
                       that still fails gets the row ``error: <reason>``. The run completes.
Ctrl-C                 cancels (kills) every task, waits for them to end, and re-raises: the runner
                       deletes the partial run directory.
environment            the driver's ``LDBENCH_*`` variables are set in every task (reference cache,
                       Mitsuba variant).
=====================  ==========================================================================

The run directory (lock, partial folder, results, commit) stays with the driver
(:func:`harness.runner.run_jobs`). Rows come back in suite order, with the local run's schema.

Fault injection for tests: ``LDBENCH_FAULT=KIND:TARGET[:FILE]`` makes a task about to run a job of method
TARGET (or, with TARGET ``reference``, a reference task) ``exit`` (the worker process dies), ``raise``
(RuntimeError) or ``sleep`` (ten minutes); with FILE, only while FILE does not exist (the task creates it,
writing its pid), so that a retry succeeds.
"""
from __future__ import annotations

import logging
import math
import os
import shutil
import sys
import tempfile
import time
import uuid
from dataclasses import dataclass
from pathlib import Path

from ..errors import LdbenchError

INSTALL_HINT = "the Ray executor needs Ray: pip install 'ldbench[ray]'"
STAGE = ".stage"  # inside the partial run directory; gone before the commit
TOKEN = "token"
CANCEL_WAIT_S = 20.0


def import_ray():
    """The ``ray`` module, or one line saying how to install it (exit 2)."""
    try:
        import ray
    except ImportError:
        raise LdbenchError(INSTALL_HINT) from None
    return ray


@dataclass(frozen=True)
class TaskSpec:
    """What a job task needs besides its jobs and their prepared inputs."""

    run_id: str
    suite_name: str
    git: dict
    out: str  # the driver's partial run directory
    token: str  # content of <out>/.stage/token: seen by the task = shared file system
    env: tuple = ()  # the driver's LDBENCH_* variables, set in the task before anything reads them


def forwarded_env() -> tuple:
    """The driver's ``LDBENCH_*`` variables (reference cache, Mitsuba variant, test faults) as pairs.
    Set by each task itself: a per-task Ray ``runtime_env`` would double a task's start-up time."""
    return tuple(sorted((k, v) for k, v in os.environ.items() if k.startswith("LDBENCH_")))


@dataclass
class TaskResult:
    rows: list
    stage: str | None = None  # shared file system: the folder the task wrote its files into
    files: dict | None = None  # otherwise {relative path: bytes}
    error: str | None = None  # an LdbenchError outside the jobs (no GL context here, ...): not retried


def group_jobs(jobs: list, workers: int, group_size: int | None = None) -> list:
    """Jobs as ``[(prepare_key, [(index, job), ...]), ...]``: jobs sharing a reference together, in suite
    order, at most ``group_size`` per group (default: ceil(jobs / (2 * workers)), so that every worker
    gets about two tasks and a slow group does not leave the others idle)."""
    from ..runner import prepare_key

    if group_size is None:
        group_size = max(1, math.ceil(len(jobs) / (2 * max(1, workers))))
    by_key: dict = {}
    for i, job in enumerate(jobs):
        by_key.setdefault(prepare_key(job), []).append((i, job))
    return [(key, items[s:s + group_size]) for key, items in by_key.items()
            for s in range(0, len(items), group_size)]


# ---- tasks (run in Ray workers) ---------------------------------------------------------------------
def _reference_task(scene, key, cache, env=()):
    """Inputs and reference of one prepare key: (small summary for the driver, Prepared for the jobs)."""
    from ..runner import prepare

    os.environ.update(dict(env))
    _inject_fault("reference")
    try:
        prep = prepare(scene, key, cache=cache, progress=False)
    except LdbenchError as e:  # bad input (e.g. the camera sees nothing): returned, never retried
        return {"error": str(e)}, None
    return {"meta": dict(getattr(prep.reference, "meta", {}) or {})}, prep


def _inject_fault(name: str) -> None:
    """Test hook (module docstring): fail like a dying worker, a raising task or a hung one."""
    spec = os.environ.get("LDBENCH_FAULT")
    if not spec:
        return
    kind, target, once = (spec.split(":", 2) + ["", ""])[:3]
    if target != name:
        return
    if once:
        try:
            fd = os.open(once, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
        except FileExistsError:
            return  # fired once already
        os.write(fd, f"{os.getpid()}\n".encode())
        os.close(fd)
    if kind == "exit":
        os._exit(3)
    if kind == "raise":
        raise RuntimeError(f"injected fault in {name}")
    if kind == "sleep":
        time.sleep(600)


def _stage_dir(spec: TaskSpec) -> tuple[Path, bool]:
    root = Path(spec.out) / STAGE
    try:
        if spec.token and (root / TOKEN).read_text() == spec.token:
            d = root / uuid.uuid4().hex
            d.mkdir()  # not parents=True: a run that was aborted meanwhile is not recreated
            return d, True
    except OSError:
        pass
    return Path(tempfile.mkdtemp(prefix="ldbench-task-")), False


def _read_tree(folder: Path) -> dict:
    return {f.relative_to(folder).as_posix(): f.read_bytes() for f in sorted(folder.rglob("*")) if f.is_file()}


def _group_task(spec: TaskSpec, prep, jobs: list) -> TaskResult:
    """Run ``jobs`` (all sharing ``prep``) on a fresh GL context of this worker's GPU."""
    import socket

    from ..gpu import Gpu
    from ..runner import RunContext, machine_of, release_inputs, run_job

    os.environ.update(dict(spec.env))
    if prep is None:  # its reference is bad input; the driver stops the run
        return TaskResult([], error="no reference")
    stage, shared = _stage_dir(spec)
    try:
        try:
            gpu = Gpu()
        except LdbenchError as e:
            return TaskResult([], error=f"{socket.gethostname()}: {e}")
        try:
            ctx = RunContext(gpu=gpu, machine=machine_of(gpu), git=spec.git, run_id=spec.run_id,
                             suite_name=spec.suite_name, out=stage)
            rows = []
            for job in jobs:
                _inject_fault(job.method)
                rows.append(run_job(ctx, job, prep))
        finally:
            release_inputs([prep])
            gpu.release()
        files = None if shared else _read_tree(stage)
    finally:
        if not shared:
            shutil.rmtree(stage, ignore_errors=True)
    return TaskResult(rows, str(stage) if shared else None, files)


# ---- driver ----------------------------------------------------------------------------------------
def _cause(e: BaseException) -> BaseException:
    """The exception a task raised (Ray wraps it in a RayTaskError)."""
    return getattr(e, "cause", None) or e


def _reason(e: BaseException) -> str:
    """One line: what killed a task."""
    c = _cause(e)
    lines = [ln.strip() for ln in str(c).splitlines() if ln.strip()]
    text = f"{type(c).__name__}: {lines[0] if lines else ''}".rstrip(": ")
    return text[:300]


class RayExecutor:
    """Runs a plan's jobs as Ray tasks (see the module docstring)."""

    uses_driver_gpu = False

    def __init__(self, address: str | None = None, retries: int = 1, group_size: int | None = None,
                 stage_in_run_dir: bool = True):
        if not isinstance(retries, int) or isinstance(retries, bool) or retries < 0:
            raise LdbenchError(f"--retries must be an integer >= 0, got {retries!r}")
        if group_size is not None and (not isinstance(group_size, int) or group_size < 1):
            raise LdbenchError(f"group size must be an integer >= 1, got {group_size!r}")
        self.address, self.retries, self.group_size = address, retries, group_size
        self.stage_in_run_dir = stage_in_run_dir  # False: tasks always return their files (tests)
        import_ray()  # before anything is written: a missing extra is one line

    # -- cluster
    def _connect(self, ray) -> bool:
        """Join or start a cluster; True when this call started (and so must shut down) one."""
        if ray.is_initialized():
            return False
        kw = dict(address=self.address, log_to_driver=False, logging_level=logging.WARNING)
        if self.address is None:
            kw["include_dashboard"] = False
        try:
            ray.init(**kw)
        except (ConnectionError, RuntimeError, ValueError) as e:
            where = f"at {self.address}" if self.address else "(local)"
            raise LdbenchError(f"cannot start or join the Ray cluster {where}: {_reason(e)}") from None
        return True

    def _task_options(self, ray) -> tuple[dict, int, str]:
        total = ray.cluster_resources()
        gpus = int(total.get("GPU", 0))
        common = dict(max_calls=1, max_retries=self.retries, retry_exceptions=True)
        if gpus:
            return {**common, "num_gpus": 1}, gpus, "GPU"
        return {**common, "num_cpus": 1}, max(1, int(total.get("CPU", 1))), "CPU"

    # -- run
    def run(self, plan, out, *, gpu=None, progress: bool = True) -> list[dict]:
        from ..runner import _progress, failed_row

        ray = import_ray()
        out = Path(out)
        started = self._connect(ray)
        pending: dict = {}  # object ref -> ("reference", key, None) | ("jobs", key, [(index, job)])
        try:
            opts, workers, kind = self._task_options(ray)
            root = out / STAGE
            root.mkdir()
            token = uuid.uuid4().hex
            (root / TOKEN).write_text(token)
            env = forwarded_env()
            spec = TaskSpec(plan.run_id, plan.suite_name, plan.git, str(out),
                            token if self.stage_in_run_dir else "", env)
            ref_task = ray.remote(num_returns=2, **opts)(_reference_task)
            job_task = ray.remote(**opts)(_group_task)

            scenes = {sk: ray.put(sc) for sk, sc in plan.scenes.items()}
            meta_refs, prep_refs = {}, {}
            for key in plan.keys():
                meta_refs[key], prep_refs[key] = ref_task.remote(scenes[key[0]], key, plan.reference_cache, env)
                pending[meta_refs[key]] = ("reference", key, None)
            groups = group_jobs(plan.jobs, workers, self.group_size)
            for key, items in groups:
                pending[job_task.remote(spec, prep_refs[key], [j for _, j in items])] = ("jobs", key, items)
            print(f"ldbench: ray: {len(plan.jobs)} jobs in {len(groups)} tasks, {len(meta_refs)} references, "
                  f"{workers} {kind} workers", file=sys.stderr)

            rows: list = [None] * len(plan.jobs)
            metas: dict = {}
            bar = _progress(None, len(plan.jobs), "runs", progress) if progress else None

            def settle(items, key, new_rows=None, status=None):
                for n, (i, job) in enumerate(items):
                    rows[i] = new_rows[n] if new_rows is not None else failed_row(plan, job, status, metas.get(key))
                if bar is not None:
                    bar.update(len(items))

            while pending:
                done, _ = ray.wait(list(pending), num_returns=1, timeout=1.0)
                for ref in done:
                    what, key, items = pending.pop(ref)
                    try:
                        value = ray.get(ref)
                    except Exception as e:  # the task failed after its retries, or its reference did
                        if what == "reference":
                            continue  # its jobs say so
                        ref_error = self._reference_error(ray, meta_refs[key])
                        if ref_error is None and len(items) > 1:  # find the job that fails, spare the others
                            print(f"ldbench: ray: a task of {len(items)} jobs failed ({_reason(e)}); "
                                  f"running them one by one", file=sys.stderr)
                            for item in items:
                                pending[job_task.remote(spec, prep_refs[key], [item[1]])] = ("jobs", key, [item])
                        elif ref_error is not None:
                            settle(items, key, status=f"error: reference task failed: {_reason(ref_error)}")
                        else:
                            n = self.retries + 1
                            settle(items, key, status=f"error: {_reason(e)} (task failed {n} time{'s' * (n > 1)})")
                        continue
                    if what == "reference":
                        if "error" in value:  # bad input, as in a local run: the run stops
                            raise LdbenchError(value["error"])
                        metas[key] = value["meta"]
                    elif value.error is not None:
                        settle(items, key, status=f"error: {value.error}")
                    else:
                        self._merge(value, out)
                        settle(items, key, new_rows=value.rows)
            if bar is not None:
                bar.close()
            shutil.rmtree(root, ignore_errors=True)
            return rows
        except BaseException:
            self._cancel(ray, pending)
            raise
        finally:
            if started:
                ray.shutdown()

    @staticmethod
    def _reference_error(ray, meta_ref):
        """The exception of a reference task that has failed, else None (also while it still runs)."""
        ready, _ = ray.wait([meta_ref], timeout=0)
        if not ready:
            return None
        try:
            ray.get(meta_ref)
        except Exception as e:
            return e
        return None

    @staticmethod
    def _merge(result: TaskResult, out: Path) -> None:
        """Move (shared file system) or write a task's files into the run directory."""
        if result.stage is not None:
            src = Path(result.stage)
            for f in sorted(src.rglob("*")):
                if f.is_file():
                    dst = out / f.relative_to(src)
                    dst.parent.mkdir(parents=True, exist_ok=True)
                    os.replace(f, dst)
            shutil.rmtree(src, ignore_errors=True)
            return
        for rel, data in (result.files or {}).items():
            parts = Path(rel).parts
            if Path(rel).is_absolute() or ".." in parts or not parts:
                raise LdbenchError(f"a Ray task returned a file outside the run directory: {rel!r}")
            dst = out.joinpath(*parts)
            dst.parent.mkdir(parents=True, exist_ok=True)
            tmp = dst.with_name(f".{dst.name}.tmp-{os.getpid()}")
            tmp.write_bytes(data)
            os.replace(tmp, dst)

    @staticmethod
    def _cancel(ray, pending: dict) -> None:
        """Kill every task still pending or running and wait (bounded) until they have ended, so that
        none writes into the run directory after the runner deletes it."""
        refs = list(pending)
        for r in refs:
            try:
                ray.cancel(r, force=True)
            except Exception:
                pass
        deadline = time.monotonic() + CANCEL_WAIT_S
        while refs and time.monotonic() < deadline:
            try:
                _, refs = ray.wait(refs, num_returns=len(refs), timeout=1.0)
            except Exception:
                break
