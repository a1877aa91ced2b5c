"""The Ray executor (``ldbench run SUITE --executor ray [--address ADDR] [--retries N]``; docs/how-to/run-on-ray.md).

=====================  ==========================================================================
cluster                ``--address ADDR`` joins a running cluster (``auto``, ``HOST:6379``,
                       ``ray://HOST:10001``); without it a local cluster is started (in a background
                       thread, see *start*) and shut down at the end. A process that already called
                       ``ray.init`` keeps its cluster.
                       A HOST:PORT that accepts no TCP connection within :data:`CONNECT_TIMEOUT_S`
                       is one line, exit 2, before anything is written.
start                  while a local cluster and its workers start (several seconds in which no worker
                       can take a call), the driver renders references itself, one after the other, on
                       the serial run's code path (``driver_references``: by default all of them while
                       no worker is ready, only when this run starts the local cluster; checked after
                       each reference). It stops once a worker is ready; the references it rendered go
                       into the object store like a worker's, and only then is any call given to a
                       worker, so no job is timed while the driver uses the GPU.
workers                one Ray actor per GPU of the cluster (``num_gpus=1``; on a cluster without
                       GPUs, one per CPU: llvmpipe), alive for the whole run. Like the serial run's
                       process, a worker keeps its GL context, compiled shaders and Mitsuba's compiled
                       kernels from one call to the next; its GPU (``CUDA_VISIBLE_DEVICES``, and the
                       EGL device chosen from it) is fixed for its life. It opens its GL context and
                       chooses Mitsuba's variant (a first kernel) when it starts, before its first call.
                       The driver gives each idle worker the next call whose inputs exist: references
                       first, then job groups.
references             one call per (scene, effect, size, spp, seed) builds the effect's inputs and
                       renders (or loads) the reference into the cache (ldbench/references/cache.py, atomic);
                       its job groups are given out once it exists: it is never rendered twice.
job groups             jobs sharing a reference run in one call, at most ``group_size`` per call
                       (default: enough calls for two per worker).
images                 a worker writes into ``<run>/.stage/<id>/`` when it sees the run directory (a
                       shared file system, recognised by a token file), else into a local temporary
                       folder whose files it returns; the driver moves or writes them into place.
faults                 a call that raises or whose worker dies (worker killed, GPU fault, out of memory:
                       Ray restarts the worker, a fresh process on the same GPU) is made again up to
                       ``retries`` times; a group that still fails is re-run job by job, and a job that
                       still fails gets the row ``error: <reason>``. The run completes. A reference that
                       raises in the driver counts as one failed call: a worker makes it again, or its
                       jobs say ``error: reference task failed: ...``, as for a worker's.
Ctrl-C                 kills every worker, waits for their calls to end, and re-raises: the runner
                       deletes the partial run directory.
environment            the driver's ``LDBENCH_*`` variables are set in every worker (reference cache,
                       Mitsuba variant).
priority               a local cluster the run starts runs its workers at niceness 0 (Ray's default, 15, made
                       a worker's CPU side yield to every other process: the driver, Ray's own).
time split             at the end, one line for the driver and one per worker: where its time went, by phase
                       (:mod:`ldbench.harness.phases`, as the serial run logs it), its idle time between calls
                       and its niceness.
=====================  ==========================================================================

The run directory (lock, partial folder, results, commit) stays with the driver
(:func:`ldbench.harness.executors.run_jobs`). Rows come back in suite order, with the local run's schema.

Fault injection for tests: ``LDBENCH_FAULT=KIND:TARGET[:FILE]`` makes a worker about to run a job of method
TARGET (or, with TARGET ``reference``, a reference) ``exit`` (the worker process dies), ``raise``
(RuntimeError), ``sleep`` (ten minutes), ``stuck`` (ten minutes with SIGALRM blocked, as a job stuck in native
code, which the job's own time limit cannot stop) or ``delay`` (two seconds, then on as usual); with FILE, only while FILE does not exist (the worker creates it,
writing its pid), so that a retry succeeds. The driver, rendering a reference, honours ``raise`` and ``sleep``
(``exit`` would end the run's own process).
"""
from __future__ import annotations

import logging
import math
import os
import shutil
import signal
import socket
import sys
import tempfile
import threading
import time
import uuid
from collections import deque
from dataclasses import dataclass
from pathlib import Path
from types import FrameType
from typing import Any, Callable

from ldbench.core.errors import LdbenchError, exit_on_sigterm
from ldbench.core.files import atomic_write
from ldbench.core.gpu import Gpu
from ldbench.references.variant import choose_variant
from ..phases import Phases
from ..runner import RunContext, failed_row, machine_of, prepare, prepare_key, progress_bar, release_inputs, run_job

# Optional: ray is imported by import_ray() and the worker's jobs() alone; without it, only --executor ray fails (with
# one line).

INSTALL_HINT = "the Ray executor needs Ray: pip install 'ldbench[ray]'"
STAGE = ".stage"  # inside the partial run directory; gone before the commit
TOKEN = "token"
CANCEL_WAIT_S = 20.0
#: How long joining a cluster (``--address``) may take: a TCP connection to its address first, then
#: ``ray.init``; beyond it the run stops with one line (exit 2) before anything is rendered.
CONNECT_TIMEOUT_S = 10.0
#: ``--retries`` at most: a call that failed 100 times will not succeed on the 101st.
MAX_RETRIES = 100
#: Ray settings of a local cluster the run starts. Ray starts its workers at niceness 15 (its
#: ``worker_niceness``), below every other process of the machine: a worker's CPU side (FLIP's OpenMP
#: loops, SSIM, image files) then yields to whatever else runs, the driver and Ray's own processes
#: included, where the serial run's process does not. 0: the driver's priority.
LOCAL_SYSTEM_CONFIG = {"worker_niceness": 0}


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
    job_timeout: float = 0.0  # seconds one job may take (0: no limit)


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


def _inject_fault(name: str, *, driver: bool = False) -> None:
    """Test hook (module docstring): fail like a dying worker, a raising task or a hung one."""
    spec = os.environ.get("LDBENCH_FAULT")
    if not spec:
        return
    kind, target, once = (spec.split(":", 2) + ["", ""])[:3]
    if target != name or (driver and kind == "exit"):
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
    if kind == "stuck":  # like a call that never returns from native code: no alarm reaches Python
        signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGALRM})
        time.sleep(600)
    if kind == "delay":
        time.sleep(2)


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
        self.calls, self.references, self.busy_s = 0, 0, 0.0
        self.phases = Phases()  # where the busy time goes (ldbench/harness/phases.py)
        self.idle_s = 0.0  # between the end of a call and the start of the next
        self.first_wait_s = None  # from the end of the start (__init__) to the first call
        self.warmed: dict = {}  # what _warm opened before the first call
        self._warm()
        self._last = time.perf_counter()

    def _begin(self) -> float:
        """Count one call and the time the worker waited for it; returns the call's start time."""
        t0 = time.perf_counter()
        if self.first_wait_s is None:
            self.first_wait_s = t0 - self._last
        else:
            self.idle_s += t0 - self._last
        self.calls += 1
        return t0

    def _end(self, t0: float) -> None:
        self._last = time.perf_counter()
        self.busy_s += self._last - t0

    def _warm(self) -> None:
        """Open the GL context and choose Mitsuba's variant (its device context, a first kernel) now, while
        the driver renders references, instead of in the first call. Best effort: what fails here is
        tried again, and reported, by the call that needs it."""
        try:
            gpu = Gpu()
        except Exception:  # noqa: BLE001 - the first jobs call opens it again and reports why not
            gpu = None
        if gpu is not None:
            try:
                self.machine, self.gpu = machine_of(gpu), gpu
            except Exception:  # noqa: BLE001 - likewise
                gpu.release()
        self.warmed["gl"] = self.gpu is not None
        try:
            self.warmed["mitsuba"] = choose_variant()
        except Exception:  # noqa: BLE001 - the first reference or trace reports it
            self.warmed["mitsuba"] = None

    def ready(self) -> bool:
        """Answers once the worker has started (its constructor, with :meth:`_warm`, has returned)."""
        return True

    def identity(self) -> dict:
        return {"pid": os.getpid(), "calls": self.calls, "references": self.references, "busy_s": self.busy_s,
                "warmed": self.warmed, "phases": self.phases.as_dict(), "idle_s": self.idle_s,
                "first_wait_s": self.first_wait_s, "nice": os.getpriority(os.PRIO_PROCESS, 0),
                "omp_threads": os.environ.get("OMP_NUM_THREADS"),
                "cuda_visible_devices": os.environ.get("CUDA_VISIBLE_DEVICES")}

    def reference(self, scene, key, cache):
        """Inputs and reference of one prepare key: (small summary for the driver, Prepared for the jobs)."""
        t0 = self._begin()
        _inject_fault("reference")
        try:
            prep = prepare(scene, key, cache=cache, progress=False, phases=self.phases)
        except LdbenchError as e:  # bad input (e.g. the camera sees nothing): returned, never retried
            return {"error": str(e)}, None
        finally:
            self._end(t0)
        self.references += 1
        return {"meta": dict(getattr(prep.reference, "meta", {}) or {})}, prep

    def jobs(self, spec: TaskSpec, prep_ref: list, jobs: list) -> TaskResult:
        """Run ``jobs`` (all sharing the Prepared of ``prep_ref``, ``[object ref]``: taken from the object
        store here, so that the split shows it) on this worker's GL context, opened on its first call."""
        import ray

        t0 = self._begin()
        try:
            with self.phases("receive"):
                prep = ray.get(prep_ref[0])
            return self._jobs(spec, prep, jobs)
        finally:
            self._end(t0)

    def _jobs(self, spec: TaskSpec, prep, jobs: list) -> TaskResult:
        if self.gpu is None:
            try:
                self.gpu = Gpu()
            except LdbenchError as e:
                return TaskResult([], error=f"{socket.gethostname()}: {e}")
            self.machine = machine_of(self.gpu)
        with self.phases("files"):
            stage, shared = _stage_dir(spec)
        try:
            ctx = RunContext(gpu=self.gpu, machine=self.machine, git=spec.git, run_id=spec.run_id,
                             suite_name=spec.suite_name, out=stage, save_arrays=spec.save_arrays,
                             phases=self.phases, job_timeout=spec.job_timeout)
            rows = []
            try:
                for job in jobs:
                    _inject_fault(job.method)
                    rows.append(run_job(ctx, job, prep))
            finally:
                release_inputs([prep])
            files = None
            if not shared:
                with self.phases("files"):
                    files = _read_tree(stage)
        finally:
            if not shared:
                shutil.rmtree(stage, ignore_errors=True)
        return TaskResult(rows, str(stage) if shared else None, files)


# ---- driver ----------------------------------------------------------------------------------------
def _cause(e: BaseException) -> BaseException:
    """The exception a task raised (Ray wraps it in a RayTaskError)."""
    return getattr(e, "cause", None) or e


def _died(e: BaseException) -> bool:
    """Whether a call failed because its worker's process ended (not because the task raised)."""
    return any(b.__name__ == "RayActorError" for b in type(_cause(e)).__mro__)


def _reason(e: BaseException) -> str:
    """One line: what failed a call. A worker whose process ended is reported as such: Ray's own
    message (ActorDiedError, ActorUnavailableError, depending on timing) is about Ray's state."""
    c = _cause(e)
    if _died(e):
        return f"worker died: its process ended during the call ({type(c).__name__})"
    lines = [ln.strip() for ln in str(c).splitlines() if ln.strip()]
    text = f"{type(c).__name__}: {lines[0] if lines else ''}".rstrip(": ")
    return text[:300]


class _LocalCluster:
    """A local Ray cluster started by a background thread, so that the driver renders references while
    it starts. The thread lives until :meth:`stop` and shuts the cluster down itself: Ray's processes end
    when the thread that started them ends (seen with Ray 2.60: the GCS died with the thread)."""

    def __init__(self, ray, init_kw: dict):
        self.up = threading.Event()
        self.error: BaseException | None = None
        self._stop = threading.Event()
        # the handler start() replaced, given back by stop()
        self._sigterm: Callable[[int, FrameType | None], Any] | int | None = None
        self._thread = threading.Thread(target=self._main, args=(ray, init_kw), name="ldbench-ray-cluster",
                                        daemon=True)

    def start(self) -> "_LocalCluster":
        if threading.current_thread() is threading.main_thread():
            # what ray.init does on the main thread (it cannot on this one): SIGTERM -> SystemExit, so
            # that a terminated run still deletes its partial run directory
            self._sigterm = signal.signal(signal.SIGTERM, exit_on_sigterm)
        self._thread.start()
        return self

    def _main(self, ray, init_kw: dict) -> None:
        quiet = _DropRecords("SIGTERM handler is not set")  # handled by start()
        log = logging.getLogger("ray._private.worker")
        log.addFilter(quiet)
        try:
            ray.init(**init_kw)
        except BaseException as e:  # noqa: BLE001 - raised in the driver by wait()
            self.error = e
            self.up.set()
            return
        finally:
            log.removeFilter(quiet)
        self.up.set()
        self._stop.wait()
        ray.shutdown()

    def wait(self, timeout: float | None = None) -> bool:
        """True once the cluster is up (False: not yet, after ``timeout`` seconds); a failed start is
        one line (exit 2)."""
        if not self.up.wait(timeout):
            return False
        if self.error is not None:
            e, self.error = self.error, None  # reported once
            raise LdbenchError(f"cannot start or join the Ray cluster (local): {_reason(e)}") from None
        return True

    def stop(self, timeout: float = 60.0) -> None:
        """Shut the cluster down (in its thread) and wait for it, bounded."""
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(timeout)
        if self._sigterm is not None:
            signal.signal(signal.SIGTERM, self._sigterm)
            self._sigterm = None


class _DropRecords(logging.Filter):
    def __init__(self, prefix: str):
        super().__init__()
        self.prefix = prefix

    def filter(self, record) -> bool:
        return not str(record.msg).startswith(self.prefix)


@dataclass
class _Work:
    """One call to a worker: a reference (``items`` None) or a group of jobs sharing ``key``'s reference."""

    key: tuple
    items: list | None = None
    tries: int = 0


class RayExecutor:
    """Runs a plan's jobs on Ray workers (see the module docstring)."""

    uses_driver_gpu = False
    #: Seconds past its jobs' time limits (``job_timeout`` each) after which a call whose worker never came
    #: back to Python (a job stuck in native code, e.g. the GPU driver, where the worker's own alarm cannot
    #: stop it) has its worker killed and restarted; the margin covers the worker's GL start-up.
    hung_grace_s = 60.0

    def __init__(self, address: str | None = None, retries: int = 1, group_size: int | None = None,
                 stage_in_run_dir: bool = True, driver_references: int | None = None):
        if driver_references is not None and (not isinstance(driver_references, int)
                                              or isinstance(driver_references, bool) or driver_references < 0):
            raise LdbenchError(f"driver references must be an integer >= 0, got {driver_references!r}")
        self.driver_references = driver_references  # most references the driver renders while workers
        # start; None: all, when this run starts the local cluster, else none
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

    def _init_kw(self) -> dict:
        kw = dict(address=self.address, log_to_driver=False, logging_level=logging.WARNING)
        if self.address is None:
            kw["include_dashboard"] = False
        return kw

    def _connect(self, ray) -> bool:
        """Join or start a cluster; True when this call started (and so must shut down) one."""
        if ray.is_initialized():
            return False
        kw = self._init_kw()
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
        ray = import_ray()
        out = Path(out)
        keys = plan.keys()
        cluster = None
        if self.address is None and not os.environ.get("RAY_ADDRESS") and not ray.is_initialized():
            # a local cluster: started by a thread while the driver renders references
            cluster = _LocalCluster(ray, {**self._init_kw(), "_system_config": dict(LOCAL_SYSTEM_CONFIG)}).start()
            started = True
        else:
            started = self._connect(ray)
        limit = self.driver_references
        if limit is None:
            limit = len(keys) if cluster is not None else 0
        workers: list = []
        running: dict = {}  # object ref -> (worker index, _Work, prep ref of a reference call)
        try:
            root = out / STAGE
            root.mkdir()
            token = uuid.uuid4().hex
            (root / TOKEN).write_text(token)
            spec = TaskSpec(plan.run_id, plan.suite_name, plan.git, str(out), token if self.stage_in_run_dir else "",
                            save_arrays=plan.save_arrays, job_timeout=plan.job_timeout)
            start: dict = {}  # once the workers are asked for: their job groups, kind and `ready` refs

            def start_workers(block: bool) -> bool:
                """Ask for the workers once the cluster is up (their processes then start on their own)."""
                if not workers:
                    if cluster is not None and not cluster.wait(None if block else 0):
                        return False
                    opts, slots, kind = self._worker_options(ray)
                    groups = group_jobs(plan.jobs, slots, self.group_size)
                    n = max(1, min(slots, len(keys) + len(groups)))
                    worker_cls = ray.remote(**opts)(Worker)
                    env = forwarded_env()
                    workers.extend(worker_cls.remote(env) for _ in range(n))
                    start.update(groups=groups, kind=kind, ready=[a.ready.remote() for a in workers])
                return True

            def worker_ready() -> bool:
                """Has a worker answered ``ready``? (Asks for the workers first, once the cluster is up.)"""
                if not start_workers(block=False):
                    return False
                done, _ = ray.wait(start["ready"], num_returns=1, timeout=0)
                return bool(done)

            phases = Phases()  # the driver's references, and what it puts into the object store
            local, local_failed = self._render_in_driver(plan, keys[:limit], worker_ready, phases)
            start_workers(block=True)
            groups, kind, n = start["groups"], start["kind"], len(workers)
            with phases("put"):
                scenes = {sk: ray.put(sc) for sk, sc in plan.scenes.items()}
            logging.getLogger(__name__).info(f"ray: {len(plan.jobs)} jobs in {len(groups)} groups, "
                                             f"{len(keys)} references ({len(local) + len(local_failed)} in the "
                                             f"driver while the workers started), {n} {kind} workers")

            rows: list = [None] * len(plan.jobs)
            metas: dict = {}
            preps: dict = {}  # key -> prep object ref, once its reference is done
            for key, prep in local.items():
                with phases("put"):
                    metas[key], preps[key] = dict(getattr(prep.reference, "meta", {}) or {}), ray.put(prep)
            n_local = len(local)
            local.clear()
            if n_local or local_failed:
                self._free_driver_memory()
            # references not done yet first (each unlocks its jobs), then the groups in suite order
            queue = deque([_Work(k) for k in keys if k not in preps and k not in local_failed]
                          + [_Work(k, items) for k, items in groups])
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
                        ref = workers[w].jobs.remote(spec, [preps[work.key]], [j for _, j in work.items])
                        running[ref] = (w, work, None)
                        if plan.job_timeout:
                            deadlines[ref] = (time.monotonic() + plan.job_timeout * len(work.items)
                                              + self.hung_grace_s)
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

            for key, e in local_failed.items():  # the driver's attempt was the first call
                failed(_Work(key), e)
            # A worker whose process died is restarted by Ray; a call sent to it before the restart fails too
            # (ActorUnavailableError), and a job that never ran would be charged with it. So it takes calls
            # again only once it answers `ready`; a worker that never comes back leaves the others the queue.
            probing: dict = {}  # ready() ref -> (worker, attempts)
            deadlines: dict = {}  # a jobs call's ref -> when its worker is deemed stuck (with a job_timeout)
            hung: set = set()  # refs whose worker was killed for it

            def kill_hung():
                now = time.monotonic()
                for ref, t in list(deadlines.items()):
                    if now > t:
                        del deadlines[ref]
                        hung.add(ref)
                        ray.kill(workers[running[ref][0]], no_restart=False)  # restarted; the call fails

            def timed_out(work):
                """A call whose worker was killed past its jobs' time limits: its jobs again one by one, the
                stuck one (alone) an error row; never retried (it would hang again)."""
                if len(work.items) > 1:
                    for item in reversed(work.items):
                        queue.appendleft(_Work(work.key, [item], work.tries))
                else:
                    settle(work.items, work.key, status=f"error: the job ran past its time limit of "
                           f"{plan.job_timeout:g} s and did not return (stuck outside Python, e.g. in the GPU "
                           f"driver): its Ray worker was killed and restarted (job_timeout, --job-timeout)")

            def probe(w, attempts=0):
                if attempts < 60:
                    probing[workers[w].ready.remote()] = (w, attempts + 1)

            dispatch()
            while running or (probing and queue):
                done, _ = ray.wait(list(running) + list(probing), num_returns=1, timeout=1.0)
                for ref in done:
                    if ref in probing:
                        w, attempts = probing.pop(ref)
                        try:
                            ray.get(ref)
                            idle.append(w)
                        except Exception:  # still restarting
                            time.sleep(0.5)
                            probe(w, attempts)
                        continue
                    w, work, prep = running.pop(ref)
                    deadlines.pop(ref, None)
                    killed = ref in hung
                    hung.discard(ref)
                    try:
                        value = ray.get(ref)
                    except Exception as e:  # raised, or the worker died (Ray restarts it)
                        if _died(e) or killed:
                            probe(w)
                        else:
                            idle.append(w)
                        if killed:
                            timed_out(work)
                        else:
                            failed(work, e)
                        continue
                    if killed:  # returned just as it was killed: its answer stands, its worker restarts
                        probe(w)
                    else:
                        idle.append(w)
                    if work.items is None:
                        if "error" in value:  # bad input, as in a local run: the run stops
                            raise LdbenchError(value["error"])
                        metas[work.key], preps[work.key] = value["meta"], prep
                    elif value.error is not None:
                        settle(work.items, work.key, status=f"error: {value.error}")
                    else:
                        with phases("merge"):
                            self._merge(value, out)
                        settle(work.items, work.key, new_rows=value.rows)
                kill_hung()
                dispatch()
            for work in queue:  # every worker died and none came back
                if work.items is not None:
                    settle(work.items, work.key, status="error: no worker left to run it (every worker died)")
            if bar is not None:
                bar.close()
            self.stats = {"workers": n, "calls": calls, "references": len(keys), "groups": len(groups),
                          "driver_references": n_local, "processes": self._processes(ray, workers)}
            self._log_times(n_local, phases)
            shutil.rmtree(root, ignore_errors=True)
            return rows
        except BaseException:
            if ray.is_initialized():
                self._cancel(ray, workers, running)
            workers = []
            raise
        finally:
            if ray.is_initialized():
                for a in workers:
                    ray.kill(a, no_restart=True)
            if cluster is not None:
                cluster.stop()
            elif started:
                ray.shutdown()

    def _log_times(self, n_local: int, phases) -> None:
        """The run's last lines: each worker's calls and busy time, then where the driver's and each worker's
        time went (ldbench/harness/phases.py), and a warning when the workers ran at a lower priority than this
        process (Ray's ``worker_niceness``, on a cluster joined with ``--address``)."""
        log = logging.getLogger(__name__)
        log.info("ray: " + "; ".join(
            [f"driver: {n_local} references"] +
            [f"worker {p['pid']} ({'GPU ' + p['cuda_visible_devices'] if p['cuda_visible_devices'] else 'CPU'}, "
             f"{p['omp_threads']} OpenMP threads): "
             f"{p['calls']} calls, busy {p['busy_s']:.1f} s" for p in self.stats["processes"]]))
        log.info(f"ray: driver split: {Phases.text(phases.as_dict())}")
        for p in self.stats["processes"]:  # where each worker's time went (ldbench/harness/phases.py)
            log.info(f"ray: worker {p['pid']} split: {Phases.text(p.get('phases') or {})}; idle between "
                     f"calls {p.get('idle_s', 0.0):.1f} s, {p.get('first_wait_s') or 0.0:.1f} s before its "
                     f"first; niceness {p.get('nice')}")
        mine = os.getpriority(os.PRIO_PROCESS, 0)
        niced = sorted({p["nice"] for p in self.stats["processes"] if p.get("nice") is not None and p["nice"] > mine})
        if niced:
            log.warning(f"ray: the workers ran at niceness {', '.join(map(str, niced))}, below this process ({mine}): "
                        f"their CPU side yields to every other process of their node; start the cluster with "
                        f"RAY_worker_niceness=0 ray start ... to run them as a serial run does")

    @staticmethod
    def _free_driver_memory() -> None:
        """Give back the device memory Dr.Jit keeps cached after the driver's references (on a GPU that a
        worker uses for the rest of the run)."""
        dr = sys.modules.get("drjit")
        if dr is not None:
            try:
                dr.flush_malloc_cache()
            except Exception:  # noqa: BLE001 - only memory held longer
                pass

    @staticmethod
    def _render_in_driver(plan, keys: list, worker_ready, phases=None) -> tuple[dict, dict]:
        """References rendered here, one after the other, while the cluster and the workers start (nothing
        else runs meanwhile): ``keys`` in order until ``worker_ready()`` (asked before each, so that it asks
        for the workers as soon as the cluster is up; the first is always rendered). Returns ({key: Prepared}, {key: the exception of a reference that failed}); bad input
        (LdbenchError) stops the run, as in a local run."""
        local: dict = {}
        local_failed: dict = {}
        for key in keys:
            if worker_ready() and (local or local_failed):
                break
            try:
                _inject_fault("reference", driver=True)
                local[key] = prepare(plan.scenes[key[0]], key, cache=plan.reference_cache, progress=False,
                                     phases=phases)
            except LdbenchError:
                raise
            except Exception as e:  # noqa: BLE001 - counts as a failed reference call
                local_failed[key] = e
        return local, local_failed

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
            atomic_write(dst, lambda t, data=data: t.write_bytes(data))

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
