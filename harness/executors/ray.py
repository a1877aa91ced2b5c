"""The Ray executor (``ldbench run SUITE --executor ray [--address ADDR] [--retries N]``; docs/ray.md).

=====================  ==========================================================================
cluster                ``--address ADDR`` joins a running cluster (``auto``, ``HOST:6379``,
                       ``ray://HOST:10001``); without it a local cluster is started and shut down
                       at the end. A process that already called ``ray.init`` keeps its cluster.
                       A HOST:PORT that accepts no TCP connection within :data:`CONNECT_TIMEOUT_S`
                       is one line, exit 2, before anything is written.
workers                one Ray actor per GPU of the cluster (``num_gpus=1``; on a cluster without
                       GPUs, one per CPU: llvmpipe), alive for the whole run. Like the serial run's
                       process, a worker keeps its GL context, compiled shaders and Mitsuba's compiled
                       kernels from one call to the next; its GPU (``CUDA_VISIBLE_DEVICES``, and the
                       EGL device chosen from it) is fixed for its life. The driver gives each idle
                       worker the next call whose inputs exist: references first, then job groups.
references             one call per (scene, effect, size, spp, seed) builds the effect's inputs and
                       renders (or loads) the reference into the cache (references/cache.py, atomic);
                       its job groups are given out once it exists: it is never rendered twice.
job groups             jobs sharing a reference run in one call, at most ``group_size`` per call
                       (default: enough calls for two per worker).
images                 a worker writes into ``<run>/.stage/<id>/`` when it sees the run directory (a
                       shared file system, recognised by a token file), else into a local temporary
                       folder whose files it returns; the driver moves or writes them into place.
faults                 a call that raises or whose worker dies (worker killed, GPU fault, out of memory:
                       Ray restarts the worker, a fresh process on the same GPU) is made again up to
                       ``retries`` times; a group that still fails is re-run job by job, and a job that
                       still fails gets the row ``error: <reason>``. The run completes.
Ctrl-C                 kills every worker, waits for their calls to end, and re-raises: the runner
                       deletes the partial run directory.
environment            the driver's ``LDBENCH_*`` variables are set in every worker (reference cache,
                       Mitsuba variant).
=====================  ==========================================================================

The run directory (lock, partial folder, results, commit) stays with the driver
(:func:`ldbench.harness.executors.run_jobs`). Rows come back in suite order, with the local run's schema.

Fault injection for tests: ``LDBENCH_FAULT=KIND:TARGET[:FILE]`` makes a worker about to run a job of method
TARGET (or, with TARGET ``reference``, a reference) ``exit`` (the worker process dies), ``raise``
(RuntimeError) or ``sleep`` (ten minutes); with FILE, only while FILE does not exist (the worker creates it,
writing its pid), so that a retry succeeds.
"""
from __future__ import annotations

import logging
import math
import os
import shutil
import tempfile
import time
import uuid
from dataclasses import dataclass
from pathlib import Path

from ldbench.core.errors import LdbenchError

INSTALL_HINT = "the Ray executor needs Ray: pip install 'ldbench[ray]'"
STAGE = ".stage"  # inside the partial run directory; gone before the commit
TOKEN = "token"
CANCEL_WAIT_S = 20.0
#: How long joining a cluster (``--address``) may take: a TCP connection to its address first, then
#: ``ray.init``; beyond it the run stops with one line (exit 2) before anything is rendered.
CONNECT_TIMEOUT_S = 10.0
#: ``--retries`` at most: a call that failed 100 times will not succeed on the 101st.
MAX_RETRIES = 100


def import_ray():
    """The ``ray`` module, or one line saying how to install it (exit 2)."""
    try:
        import ray
    except ImportError:
        raise LdbenchError(INSTALL_HINT) from None
    return ray


@dataclass(frozen=True)
class TaskSpec:
    """What a call that runs jobs needs besides its jobs and their prepared inputs."""

    run_id: str
    suite_name: str
    git: dict
    out: str  # the driver's partial run directory
    token: str  # content of <out>/.stage/token: seen by the worker = shared file system
    save_arrays: bool = False  # --save-arrays


def forwarded_env() -> tuple:
    """The driver's ``LDBENCH_*`` variables (reference cache, Mitsuba variant, test faults) as pairs.
    Set by each worker itself: a Ray ``runtime_env`` would double a worker's start-up time."""
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


def cpus_per_gpu(nodes: list) -> int:
    """CPUs a GPU worker asks for: each GPU's share of its node's cores, the smallest over the nodes
    with GPUs (so that every GPU's worker fits), at least 1. Ray sets a worker's ``OMP_NUM_THREADS`` to
    its CPUs, 1 by default, which made the CPU side of a job (FLIP's OpenMP loops) several times slower
    than in a serial run."""
    shares = [int(r.get("CPU", 0) // r["GPU"]) for r in nodes if r.get("GPU", 0) >= 1]
    return max(1, min(shares)) if shares else 1


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


# ---- the worker (a Ray actor: one per GPU, alive for the whole run) ---------------------------------
class Worker:
    """One long-lived process per GPU (or per CPU slot on a cluster without GPUs). Like the serial run's
    process it keeps its GL context, compiled shaders and Mitsuba's compiled kernels from one call to the
    next; Ray restarts it (a fresh process, same GPU) when it dies."""

    def __init__(self, env=()):
        os.environ.update(dict(env))  # before anything reads them: reference cache, Mitsuba variant
        self.gpu = self.machine = None
        self.calls, self.busy_s = 0, 0.0

    def identity(self) -> dict:
        return {"pid": os.getpid(), "calls": self.calls, "busy_s": self.busy_s,
                "omp_threads": os.environ.get("OMP_NUM_THREADS"),
                "cuda_visible_devices": os.environ.get("CUDA_VISIBLE_DEVICES")}

    def reference(self, scene, key, cache):
        """Inputs and reference of one prepare key: (small summary for the driver, Prepared for the jobs)."""
        from ..runner import prepare

        self.calls += 1
        t0 = time.perf_counter()
        _inject_fault("reference")
        try:
            prep = prepare(scene, key, cache=cache, progress=False)
        except LdbenchError as e:  # bad input (e.g. the camera sees nothing): returned, never retried
            return {"error": str(e)}, None
        finally:
            self.busy_s += time.perf_counter() - t0
        return {"meta": dict(getattr(prep.reference, "meta", {}) or {})}, prep

    def jobs(self, spec: TaskSpec, prep, jobs: list) -> TaskResult:
        """Run ``jobs`` (all sharing ``prep``) on this worker's GL context, opened on its first call."""
        self.calls += 1
        t0 = time.perf_counter()
        try:
            return self._jobs(spec, prep, jobs)
        finally:
            self.busy_s += time.perf_counter() - t0

    def _jobs(self, spec: TaskSpec, prep, jobs: list) -> TaskResult:
        import socket

        from ldbench.core.gpu import Gpu
        from ..runner import RunContext, machine_of, release_inputs, run_job

        if self.gpu is None:
            try:
                self.gpu = Gpu()
            except LdbenchError as e:
                return TaskResult([], error=f"{socket.gethostname()}: {e}")
            self.machine = machine_of(self.gpu)
        stage, shared = _stage_dir(spec)
        try:
            ctx = RunContext(gpu=self.gpu, machine=self.machine, git=spec.git, run_id=spec.run_id,
                             suite_name=spec.suite_name, out=stage, save_arrays=spec.save_arrays)
            rows = []
            try:
                for job in jobs:
                    _inject_fault(job.method)
                    rows.append(run_job(ctx, job, prep))
            finally:
                release_inputs([prep])
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
    """One line: what failed a call. A worker whose process ended is reported as such: Ray's own
    message (ActorDiedError, ActorUnavailableError, depending on timing) is about Ray's state."""
    c = _cause(e)
    if any(b.__name__ == "RayActorError" for b in type(c).__mro__):
        return f"worker died: its process ended during the call ({type(c).__name__})"
    lines = [ln.strip() for ln in str(c).splitlines() if ln.strip()]
    text = f"{type(c).__name__}: {lines[0] if lines else ''}".rstrip(": ")
    return text[:300]


@dataclass
class _Work:
    """One call to a worker: a reference (``items`` None) or a group of jobs sharing ``key``'s reference."""

    key: tuple
    items: list | None = None
    tries: int = 0


class RayExecutor:
    """Runs a plan's jobs on Ray workers (see the module docstring)."""

    uses_driver_gpu = False

    def __init__(self, address: str | None = None, retries: int = 1, group_size: int | None = None,
                 stage_in_run_dir: bool = True):
        if not isinstance(retries, int) or isinstance(retries, bool) or retries < 0:
            raise LdbenchError(f"--retries must be an integer >= 0, got {retries!r}")
        if retries > MAX_RETRIES:
            raise LdbenchError(f"--retries must be <= {MAX_RETRIES}, got {retries}")
        if group_size is not None and (not isinstance(group_size, int) or group_size < 1):
            raise LdbenchError(f"group size must be an integer >= 1, got {group_size!r}")
        self.address, self.retries, self.group_size = address, retries, group_size
        self.stage_in_run_dir = stage_in_run_dir  # False: workers always return their files (tests)
        self.stats: dict = {}  # of the last run: workers, their processes, calls
        import_ray()  # before anything is written: a missing extra is one line
        self._reachable()  # likewise a cluster address nothing answers at

    # -- cluster
    def _reachable(self) -> None:
        """Refuse an ``--address HOST:PORT`` (or ``ray://HOST:PORT``) nothing answers within
        :data:`CONNECT_TIMEOUT_S`: ``ray.init`` would otherwise retry for minutes."""
        import socket

        addr = self.address or ""
        hostport = addr[len("ray://"):] if addr.startswith("ray://") else addr
        host, sep, port = hostport.rpartition(":")
        if not sep or not port.isdigit():
            return  # "auto", or a form Ray resolves itself
        try:
            socket.create_connection((host.strip("[]") or "127.0.0.1", int(port)), timeout=CONNECT_TIMEOUT_S).close()
        except (OSError, ValueError, OverflowError) as e:
            why = "no answer" if isinstance(e, TimeoutError) else (getattr(e, "strerror", None) or str(e))
            raise LdbenchError(f"cannot join the Ray cluster at {addr}: {why} within {CONNECT_TIMEOUT_S:.0f} s "
                               f"(is a head node running there? ray start --head)") from None

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

    @staticmethod
    def _worker_options(ray) -> tuple[dict, int, str]:
        """Ray options of a worker, how many (one per GPU, else one per CPU) and of what kind.
        ``max_restarts=-1``: a worker that dies is restarted; what bounds the attempts is ``retries``."""
        total = ray.cluster_resources()
        gpus = int(total.get("GPU", 0))
        common = dict(max_restarts=-1, max_task_retries=0)
        if gpus:
            cpus = cpus_per_gpu([n.get("Resources", {}) for n in ray.nodes() if n.get("Alive", True)])
            return {**common, "num_gpus": 1, "num_cpus": cpus}, gpus, "GPU"
        return {**common, "num_cpus": 1}, max(1, int(total.get("CPU", 1))), "CPU"

    # -- run
    def run(self, plan, out, *, gpu=None, progress: bool = True) -> list[dict]:
        from collections import deque

        from ..runner import failed_row, progress_bar

        ray = import_ray()
        out = Path(out)
        started = self._connect(ray)
        workers: list = []
        running: dict = {}  # object ref -> (worker index, _Work, prep ref of a reference call)
        try:
            opts, slots, kind = self._worker_options(ray)
            root = out / STAGE
            root.mkdir()
            token = uuid.uuid4().hex
            (root / TOKEN).write_text(token)
            spec = TaskSpec(plan.run_id, plan.suite_name, plan.git, str(out), token if self.stage_in_run_dir else "",
                            save_arrays=plan.save_arrays)
            keys = plan.keys()
            groups = group_jobs(plan.jobs, slots, self.group_size)
            # references first (each unlocks its jobs), then the groups in suite order
            queue = deque([_Work(k) for k in keys] + [_Work(k, items) for k, items in groups])
            n = max(1, min(slots, len(queue)))
            worker_cls = ray.remote(**opts)(Worker)
            env = forwarded_env()
            workers = [worker_cls.remote(env) for _ in range(n)]
            scenes = {sk: ray.put(sc) for sk, sc in plan.scenes.items()}
            logging.getLogger(__name__).info(f"ray: {len(plan.jobs)} jobs in {len(groups)} groups, "
                                             f"{len(keys)} references, {n} {kind} workers")

            rows: list = [None] * len(plan.jobs)
            metas: dict = {}
            preps: dict = {}  # key -> prep object ref, once its reference is done
            idle = list(range(n))
            calls = 0
            bar = progress_bar(None, len(plan.jobs), "runs", progress) if progress else None

            def settle(items, key, new_rows=None, status=None):
                for m, (i, job) in enumerate(items):
                    rows[i] = new_rows[m] if new_rows is not None else failed_row(plan, job, status, metas.get(key))
                if bar is not None:
                    bar.update(len(items))

            def dispatch():
                nonlocal calls
                while idle:
                    work = next((w for w in queue if w.items is None or w.key in preps), None)
                    if work is None:
                        return
                    queue.remove(work)
                    w = idle.pop(0)
                    if work.items is None:
                        meta, prep = workers[w].reference.options(num_returns=2).remote(
                            scenes[work.key[0]], work.key, plan.reference_cache)
                        running[meta] = (w, work, prep)
                    else:
                        ref = workers[w].jobs.remote(spec, preps[work.key], [j for _, j in work.items])
                        running[ref] = (w, work, None)
                    calls += 1

            def failed(work, e):
                """A call that raised or whose worker died: again, job by job, or an error row."""
                if work.tries < self.retries:
                    queue.appendleft(_Work(work.key, work.items, work.tries + 1))
                elif work.items is None:  # the reference: its jobs say so
                    for w in [w for w in queue if w.key == work.key]:
                        queue.remove(w)
                        settle(w.items, w.key, status=f"error: reference task failed: {_reason(e)}")
                elif len(work.items) > 1:  # find the job that fails, spare the others
                    logging.getLogger(__name__).warning(f"ray: a group of {len(work.items)} jobs failed "
                                                        f"({_reason(e)}); running them one by one")
                    for item in reversed(work.items):
                        queue.appendleft(_Work(work.key, [item]))
                else:
                    t = self.retries + 1
                    settle(work.items, work.key, status=f"error: {_reason(e)} (task failed {t} time{'s' * (t > 1)})")

            dispatch()
            while running:
                done, _ = ray.wait(list(running), num_returns=1, timeout=1.0)
                for ref in done:
                    w, work, prep = running.pop(ref)
                    idle.append(w)
                    try:
                        value = ray.get(ref)
                    except Exception as e:  # raised, or the worker died (Ray restarts it)
                        failed(work, e)
                        continue
                    if work.items is None:
                        if "error" in value:  # bad input, as in a local run: the run stops
                            raise LdbenchError(value["error"])
                        metas[work.key], preps[work.key] = value["meta"], prep
                    elif value.error is not None:
                        settle(work.items, work.key, status=f"error: {value.error}")
                    else:
                        self._merge(value, out)
                        settle(work.items, work.key, new_rows=value.rows)
                dispatch()
            if bar is not None:
                bar.close()
            self.stats = {"workers": n, "calls": calls, "references": len(keys), "groups": len(groups),
                          "processes": self._processes(ray, workers)}
            logging.getLogger(__name__).info("ray: " + "; ".join(
                f"worker {p['pid']} ({'GPU ' + p['cuda_visible_devices'] if p['cuda_visible_devices'] else 'CPU'}, "
                f"{p['omp_threads']} OpenMP threads): "
                f"{p['calls']} calls, busy {p['busy_s']:.1f} s" for p in self.stats["processes"]))
            shutil.rmtree(root, ignore_errors=True)
            return rows
        except BaseException:
            self._cancel(ray, workers, running)
            workers = []
            raise
        finally:
            for a in workers:
                ray.kill(a, no_restart=True)
            if started:
                ray.shutdown()

    @staticmethod
    def _processes(ray, workers) -> list:
        """Each worker's process id and GPU, asked at the end (a process that served every call)."""
        try:
            return ray.get([a.identity.remote() for a in workers], timeout=30)
        except Exception:
            return []

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
    def _cancel(ray, workers: list, running: dict) -> None:
        """Kill every worker (and so its running call) and wait (bounded) until the calls have ended, so
        that none writes into the run directory after the runner deletes it."""
        for a in workers:
            try:
                ray.kill(a, no_restart=True)
            except Exception:
                pass
        refs = list(running)
        deadline = time.monotonic() + CANCEL_WAIT_S
        while refs and time.monotonic() < deadline:
            try:
                _, refs = ray.wait(refs, num_returns=len(refs), timeout=1.0)
            except Exception:
                break
