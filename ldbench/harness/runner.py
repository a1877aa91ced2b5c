"""Run a suite: for each job, set the method up, render warm-up and measured frames, score the last
frame against the reference with its effect's metrics, and write records and images.

Frames are timed by the timing protocol of docs/design.md (``setup`` and input uploads untimed, then
``warmup`` and ``frames`` measured frames, stages by :meth:`ldbench.core.gpu.Gpu.stage`).

Per (scene, effect, size, spp, seed) the harness builds the effect's inputs and its reference once
(:class:`Prepared`) and hands the same objects to every method. A method's result is checked against
the invariants it declares (:attr:`ldbench.methods.base.Result.invariants`): a violation makes the row
``degraded: …`` (its metrics are still recorded).

The run directory is written under a temporary name and renamed into place only when complete
(:mod:`ldbench.harness.rundir`), so a failed run never leaves a folder that looks finished.

Who runs the jobs is an executor (:mod:`ldbench.harness.executors`): this process one job after the other
(``local``, the default), or Ray tasks on one or several machines (``ray``). :func:`plan_run`,
:func:`prepare` and :func:`run_job` (with its :class:`RunContext`) are the units both use; the run
directory stays with :func:`ldbench.harness.executors.run_jobs`, in this process.
"""
from __future__ import annotations

import logging
import signal
import sys
import threading
import time
import uuid
from contextlib import contextmanager, suppress
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from ldbench.core.errors import LdbenchError, Terminated
from ldbench.core.plugins import ldbench_info
from ldbench.core.scenes import load_scene
from ldbench.methods.base import View, get_method
from ldbench.references import EXACT, render_effect, trace
from . import records
from .arrays import answer_arrays, save_arrays
from .naming import slug as _slug
from .checks import camera_sees_geometry, finite_reference, unique_scene_names
from .phases import Phases
from .suite import Job, Suite, resolve_sizes
from .unbiased_score import method_test

if TYPE_CHECKING:
    from ldbench.core.effects.base import EffectSpec
    from ldbench.core.gpu import Gpu
    from ldbench.core.scene import Scene
    from ldbench.methods.base import Result

# Heavy: tqdm is imported by progress_bar() alone, and only for a progress bar on a terminal.



def _scene_tag(job: Job, scene) -> str:
    """Distinguishes images of one builder called with different parameters."""
    return f"-s{scene.content_hash()[:6]}" if job.scene_params else ""


def job_label(job: Job, scene) -> str:
    """Image file stem: method, effect, size, method params and (if any) a scene-parameter tag."""
    p = "-".join(f"{k}{v}" for k, v in job.params)
    return _slug(f"{job.method}-{job.effect.label()}-{job.width}x{job.height}" + (f"-{p}" if p else "")
                 + _scene_tag(job, scene) + (f"-seed{job.seed}" if job.seed else ""))


def reference_label(job: Job, scene) -> str:
    return _slug(f"reference-{job.effect.label()}-{job.width}x{job.height}{_scene_tag(job, scene)}"
                 + (f"-seed{job.seed}" if job.seed else ""))


def scene_dir(scene) -> str:
    """The images folder of a scene inside a run (``images/<this>/``)."""
    return _slug(scene.name)


def progress_bar(iterable, total, desc, enabled):
    """``iterable`` with a tqdm bar on stderr when ``enabled``."""
    if not enabled:
        return iterable
    from tqdm import tqdm

    # disable=None: no bar when stderr is not a terminal (CI logs, pipes), where \r updates are noise
    return tqdm(iterable, total=total, desc=desc, file=sys.stderr, leave=False, disable=None)


@dataclass
class RunContext:
    """What every job of one run shares (in one process: each Ray task builds its own)."""

    gpu: Gpu
    machine: dict
    git: dict
    run_id: str
    suite_name: str
    out: Path  # the (temporary) run directory being written, or a task's staging folder
    save_arrays: bool = False  # --save-arrays: per-ray / per-VPL inputs and answers (ldbench/harness/arrays.py)
    job_timeout: float = 0.0  # seconds one job may take (0: no limit; see time_limit)
    phases: Phases | None = None  # where the jobs' time goes (ldbench/harness/phases.py), or not recorded


@dataclass
class Prepared:
    """One (scene, effect, size, spp, seed): the effect's inputs and reference, the same for every method."""

    scene: Scene
    inputs: object
    reference: object


@dataclass
class RunPlan:
    """A checked suite, ready for an executor (:mod:`ldbench.harness.executors`): jobs in suite order with their
    sizes resolved, their scenes by ``job.scene_key``, and what every row of the run shares."""

    suite_name: str
    jobs: list
    scenes: dict
    run_id: str
    git: dict
    machine: dict  # the driver's (rows of jobs that never ran get it)
    reference_cache: bool = True
    save_arrays: bool = False
    job_timeout: float = 0.0  # seconds one job may take (0: no limit); the suite's job_timeout

    def keys(self) -> list:
        """The distinct :func:`prepare_key` of the jobs (one inputs + reference each), in a fixed order."""
        return sorted({prepare_key(j) for j in self.jobs}, key=str)


def prepare_key(job: Job) -> tuple:
    return (job.scene_key, job.effect, job.width, job.height, job.spp, job.seed)


def machine_of(gpu) -> dict:
    """:func:`records.machine_info` of this process's context, with the device it opened on."""
    return {**records.machine_info(gpu.info), **gpu.device_columns}


def plan_run(suite: Suite, gpu, *, reference_cache: bool = True) -> RunPlan:
    """Load and check every scene, resolve sizes and check them against ``gpu``: the last chance to
    reject bad input (one line, exit 2) before anything is rendered."""
    scenes = {}
    for job in suite.jobs:
        if job.scene_key not in scenes:
            scenes[job.scene_key] = load_scene(job.scene, **dict(job.scene_params))
            for w in scenes[job.scene_key].warnings:
                logging.getLogger(__name__).warning(w)
        job.effect.check_scene(scenes[job.scene_key])
    scenes = unique_scene_names(scenes)  # a/scene.xml and b/scene.xml: two names, two image folders
    jobs = resolve_sizes(suite.jobs, scenes)  # no size given: the XML film's
    for w, h in sorted({(j.width, j.height) for j in jobs}):
        gpu.check_image_size(w, h)  # GL limits and memory, before anything is rendered
    return RunPlan(suite_name=suite.name, jobs=jobs, scenes=scenes,
                   run_id=time.strftime("%Y%m%dT%H%M%SZ", time.gmtime()) + "-" + uuid.uuid4().hex[:6],
                   git=_ldbench_git(), machine=machine_of(gpu), reference_cache=reference_cache)


def _ldbench_git() -> dict:
    """ldbench's commit: git in a checkout, else the one an installed wheel's build recorded."""
    info = ldbench_info()
    return {"commit": info["commit"], "dirty": info["dirty"], "branch": None}


def prepare(scene, key: tuple, *, cache: bool = True, progress: bool = False, phases: Phases | None = None) -> Prepared:
    """The effect's inputs and reference of one :func:`prepare_key` (the reference from the cache, or
    rendered into it); its phases timed into ``phases`` (ldbench/harness/phases.py) when given."""
    ph = phases if phases is not None else Phases()
    _, effect, w, h, spp, seed = key
    with ph("inputs"):
        inputs = effect.spec.inputs(scene, w, h, effect.params, seed, exact=EXACT)
    t0, ref = time.perf_counter(), None
    try:
        ref = render_effect(scene, effect, width=w, height=h, spp=spp, seed=seed, inputs=inputs, cache=cache,
                            progress=progress)
    finally:
        cached = ref is not None and (getattr(ref, "meta", None) or {}).get("cached")
        ph.add("reference cache" if cached else "reference render", time.perf_counter() - t0)
    with ph("checks"):
        camera_sees_geometry(scene, ref, w, h)  # else every metric is NaN
        finite_reference(scene, ref, f"{effect.label()} at {w}x{h}")  # likewise
    return Prepared(scene, inputs, ref)


def release_inputs(prepared) -> None:
    """Release the GPU side of effect inputs (``Prepared`` values of a dict, or an iterable of them)."""
    for p in (prepared.values() if isinstance(prepared, dict) else prepared):
        if hasattr(p.inputs, "release"):
            p.inputs.release()


def run_job(ctx: RunContext, job: Job, prep: Prepared) -> dict:
    """One job: set up, time the frames, score the last one; returns its record row.

    Whatever the job raises (bad input, a driver fault, a bug in an adapter, in scoring or in saving
    its images) becomes that row's ``error: ...`` status, so one job never loses the others' rows: the
    run completes, as it does on the Ray executor; so does a plugin's ``sys.exit()``. Only KeyboardInterrupt
    and SIGTERM (:class:`~ldbench.core.errors.Terminated`) pass.

    :func:`start_job` and :func:`finish_job` one after the other, in this process (the local executor
    with ``--writers N`` hands the second to a writer process instead: ldbench/harness/writers.py)."""
    out = start_job(ctx, job, prep)
    if isinstance(out, Finish):
        out = finish_job(out, prep, ctx.phases, row_calls=0)  # the same row as start_job's: counted once
    return out


@dataclass
class Finish:
    """A job whose frames are done: what :func:`finish_job` needs to score it and save its images, on CPU
    arrays only (no GL object), so that another process can do it (ldbench/harness/writers.py)."""

    spec: EffectSpec  # the effect's spec
    result: Result  # the method's resolved Result of the last frame
    fields: dict  # the job's columns (:func:`_job_fields`): all that its row has when finishing fails
    timing: dict  # the timing columns (:func:`~ldbench.harness.records.timing_fields`)
    memory: dict  # the method's checked ``memory_bytes``
    folder: Path  # the row's images folder
    label: str  # the image file stem (:func:`job_label`)
    ref_label: str  # the reference's (:func:`reference_label`)
    save_arrays: bool = False
    test: str | None = None  # the suite's test ("unbiased") or None
    seconds_left: float = 0.0  # of the job's time limit (0: no limit)


def start_job(ctx: RunContext, job: Job, prep: Prepared) -> dict | Finish:
    """The part of a job that needs the GL context: set up, time the frames, read the last one back,
    release. Returns the job's row when it ends there (an error), else its :class:`Finish`. Errors become
    the row's status, as in :func:`run_job`; the time limit covers this part, and what is left of it goes
    to :func:`finish_job` (``Finish.seconds_left``)."""
    ph = ctx.phases if ctx.phases is not None else Phases()
    t0, before = time.perf_counter(), ph.total()
    try:
        with time_limit(ctx.job_timeout):
            out = _start_job(ctx, job, prep, ph)
        if isinstance(out, Finish) and ctx.job_timeout:  # > 0 even when spent: 0 would mean no limit
            out.seconds_left = max(ctx.job_timeout - (time.perf_counter() - t0), 1e-3)
        return out
    except LdbenchError as e:
        status = f"error: {e}"
    except Exception as e:  # noqa: BLE001 - recorded in the row, not lost
        status = f"error: {error_text(e)}"
    except SystemExit as e:  # a plugin's sys.exit() ends its job, never the run
        if isinstance(e, Terminated):
            raise
        status = f"error: {exit_text(e)}"
    finally:  # what the phases inside did not time
        ph.add("row", time.perf_counter() - t0 - (ph.total() - before))
    return records.make_row(**_job_fields(ctx.run_id, ctx.suite_name, ctx.git, ctx.machine, job, prep.scene,
                                          getattr(prep.reference, "meta", {}), status))


def finish_job(task: Finish, prep: Prepared, phases: Phases | None = None, *, row_calls: int = 1) -> dict:
    """The rest of a job, CPU work only: score the result against the reference, save the images (and
    ``--save-arrays``), make the row. Whatever it raises becomes the row's ``error: ...`` status (the
    columns of :func:`_job_fields`, as :func:`run_job` has always written them), within
    ``task.seconds_left`` (when this runs on its process's main thread: :func:`time_limit`).
    ``row_calls``: the calls to count under ``row`` (0 when the job's :func:`start_job` counted it)."""
    ph = phases if phases is not None else Phases()
    t0, before = time.perf_counter(), ph.total()
    try:
        with time_limit(task.seconds_left):
            return _finish_job(task, prep, ph)
    except LdbenchError as e:
        status = f"error: {e}"
    except Exception as e:  # noqa: BLE001 - recorded in the row, not lost
        status = f"error: {error_text(e)}"
    except SystemExit as e:  # a plugin's sys.exit() (e.g. in its result's image callable)
        if isinstance(e, Terminated):
            raise
        status = f"error: {exit_text(e)}"
    finally:
        ph.add("row", time.perf_counter() - t0 - (ph.total() - before), calls=row_calls)
    return error_row(task, status)


def error_row(task: Finish, status: str) -> dict:
    """The row of a job whose :func:`finish_job` failed: the job's columns and ``status``, no metrics."""
    return records.make_row(**{**task.fields, "status": status})


class JobTimeout(LdbenchError):
    """A job ran past its time limit (the suite's ``job_timeout``, ``run --job-timeout``)."""


@contextmanager
def time_limit(seconds: float):
    """Raise :class:`JobTimeout` inside the block once it has run ``seconds`` (0: no limit), through SIGALRM:
    a method stuck in Python code (a plugin's endless loop) is stopped there and its row says so. Where no
    signal can be delivered (not the main thread, no SIGALRM) the block runs unlimited; a call blocked inside
    the GPU driver is stopped only when it returns to Python."""
    if not seconds or not hasattr(signal, "setitimer") or threading.current_thread() is not threading.main_thread():
        yield
        return

    def on_alarm(signum, frame):
        raise JobTimeout(f"the job ran past its time limit of {seconds:g} s (job_timeout, --job-timeout)")

    def stuck():  # the alarm is handled only once the job is back in Python: say why the run waits
        print(f"ldbench: a job has run {seconds + STUCK_NOTICE_S:g} s, past its time limit of {seconds:g} s, "
              f"inside native code (the GPU driver?) that this process cannot stop; it goes on waiting. "
              f"With --executor ray such a job's worker is killed and the run goes on", file=sys.stderr, flush=True)

    notice = threading.Timer(seconds + STUCK_NOTICE_S, stuck)
    notice.daemon = True
    old = signal.signal(signal.SIGALRM, on_alarm)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    notice.start()
    try:
        yield
    finally:
        notice.cancel()
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)


#: Seconds past a job's time limit after which a local run says on stderr that the job is stuck outside Python.
STUCK_NOTICE_S = 60.0


def exit_text(e: SystemExit) -> str:
    """A plugin's ``sys.exit(code)`` inside a job or a reference, in words (its row's error; the run goes on)."""
    return f"sys.exit({e.code!r}) called inside the job (SystemExit): plugin code must raise an exception, not exit"


def error_text(e: BaseException) -> str:
    """One line naming an unexpected exception: its type and the first line of its message."""
    lines = [ln.strip() for ln in str(e).splitlines() if ln.strip()]
    return f"{type(e).__name__}: {lines[0] if lines else ''}".rstrip(": ")[:300]


def _start_job(ctx: RunContext, job: Job, prep: Prepared, ph: Phases) -> dict | Finish:
    cls = get_method(job.method)
    params = cls.Params.from_dict(dict(job.params), method=job.method)
    method = cls(params)
    method.oracle = trace  # the exact baselines some adapters offer (never timed)
    method.exact = EXACT   # the exact primary hits and epsilons, as effects get them (mc-ao builds rays)
    method.run_seed = int(job.seed)  # before setup: a method may draw its random tables there
    scene = prep.scene
    assert job.width is not None and job.height is not None  # plan_run resolved every job's size
    view = View(scene.camera, job.width, job.height, seed=int(job.seed))
    samples: dict = {}
    totals, walls = [], []
    status = "ok"
    result: Result | None = None  # the last frame's
    try:
        with ph("setup"):
            method.setup(ctx.gpu, scene)
            if hasattr(prep.inputs, "upload"):
                prep.inputs.upload(ctx.gpu)  # harness inputs on the GPU, before the timed frames
        with ph("frames"):
            for i in range(job.warmup + job.frames):
                ctx.gpu.begin_frame()
                result = method.frame(view, job.effect, prep.inputs)
                stages, wall = ctx.gpu.end_frame()
                result.stages_ms = stages
                if i >= job.warmup:
                    for k, v in stages.items():
                        samples.setdefault(k, []).append(v)
                    totals.append(sum(stages.values()))
                    walls.append(wall)
            assert result is not None  # frames >= 1 (the suite checks it)
            result.resolve()
    except LdbenchError as e:
        status = f"error: {e}"
    except BaseException:  # Ctrl-C, a bug: what stopped the job, not a release that fails after a half set-up
        with ph("release"), suppress(Exception):
            method.release()
        raise
    with ph("release"):
        method.release()

    row = _job_fields(ctx.run_id, ctx.suite_name, ctx.git, ctx.machine, job, scene,
                      getattr(prep.reference, "meta", {}), status)
    if status != "ok":
        return records.make_row(**row)
    assert result is not None  # status "ok": the frames ran
    timing = records.timing_fields({**samples, "total": totals, "wall": walls})
    mem = records.checked_memory(result.memory_bytes, "the method's memory_bytes")
    return Finish(spec=job.effect.spec, result=result, fields=row, timing=timing, memory=mem,
                  folder=ctx.out / "images" / scene_dir(scene), label=job_label(job, scene),
                  ref_label=reference_label(job, scene), save_arrays=ctx.save_arrays,
                  test=getattr(job, "test", None))


def _finish_job(task: Finish, prep: Prepared, ph: Phases) -> dict:
    spec, result, ref, folder = task.spec, task.result, prep.reference, task.folder
    row = dict(task.fields)
    with ph("score"):
        scores = spec.score(result, ref, scene=prep.scene, inputs=prep.inputs, stage_ms=task.timing["stage_ms"])
    problems = list(result.invariants) + spec.problems(scores)  # e.g. non-finite pixels: never ok
    if problems:
        row["status"] = "degraded: " + "; ".join(problems)
    with ph("save"):
        images = spec.save(result, ref, prep.inputs, folder, task.label, task.ref_label)
        rel = f"images/{folder.name}/"
        images = {k: (rel + v if isinstance(v, str) and v.endswith((".png", ".exr")) else v)
                  for k, v in images.items()}
        if task.save_arrays:
            arrays = answer_arrays(spec, result, ref, prep.inputs)
            if arrays is not None:
                name = f"{task.label}-arrays.npz"
                save_arrays(folder / name, arrays)
                images["arrays"] = rel + name
    mem = task.memory
    row.update(**task.timing, memory_bytes=int(sum(mem.values())), memory=mem,
               counters={k: (v.item() if hasattr(v, "item") else v) for k, v in result.counters.items()},
               ref_noise=spec.noise(ref), images=images, **scores)
    if task.test:  # a suite's test = "unbiased" (ldbench/harness/unbiased_score.py)
        with ph("score"):
            cols, maps = method_test(task.test, result, ref, spec, folder, task.label)
        row.update(cols)
        images.update({k: rel + v for k, v in maps.items()})
    return records.make_row(**row)


def _job_fields(run_id, suite_name, git, machine, job: Job, scene, ref_meta, status) -> dict:
    """The columns that name a job and where it ran (every row has them, failed ones too)."""
    cls = get_method(job.method)
    params = cls.Params.from_dict(dict(job.params), method=job.method)
    meta = ref_meta or {}
    return dict(run_id=run_id, suite=suite_name, **records.git_columns(git), scene=scene.name,
                scene_hash=scene.content_hash(), triangles=scene.triangle_count,
                scene_params=dict(job.scene_params), method=job.method, paper=cls.paper,
                effect=job.effect.name, effect_params=job.effect.key(),
                params=params_used(cls, params, job.effect),
                width=job.width, height=job.height, seed=job.seed, **records.machine_columns(machine),
                warmup=job.warmup, frames=job.frames, ref_spp=meta.get("spp"),
                ref_variant=meta.get("variant"), ref_key=meta.get("key"), status=status,
                **records.method_columns(cls, git), timing_source="measured")


def params_used(cls, params, effect) -> dict:
    """The method's parameters as the job ran: those the effect supersedes (``EffectSpec.supersedes``,
    e.g. cdi-vpl's rsm and miss_range on ``vpl_range``, whose VPLs the harness builds) carry the
    effect's values, not the method's unused ones. Flat dict; a grouped parameter is found through
    ``Params.renamed``."""
    out = params.to_dict()
    renamed = getattr(cls.Params, "renamed", None) or {}
    ep = effect.params.to_dict()
    for k in effect.spec.supersedes:
        name = renamed.get(k, k)
        if name in out:
            out[name] = ep[k]
    return out


def failed_row(plan: RunPlan, job: Job, status: str, ref_meta: dict | None = None) -> dict:
    """The row of a job that could not run to its end elsewhere (a Ray task that died): ``status``
    says why; the machine columns are the driver's, the device columns empty."""
    machine = {**plan.machine, "egl_device": None, "cuda_device": None, "pci_bus_id": None}
    return records.make_row(**_job_fields(plan.run_id, plan.suite_name, plan.git, machine, job,
                                          plan.scenes[job.scene_key], ref_meta, status))
