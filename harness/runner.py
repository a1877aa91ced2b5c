"""Run a suite: for each job, set the method up, render warm-up and measured frames, score the last
frame against the reference with its effect's metrics, and write records and images.

Timing protocol (docs/design.md): upload and compilation (``setup``, and the upload of the effect's
inputs) are outside the timed region; then ``warmup`` frames, then ``frames`` measured frames, each
stage timed by :meth:`harness.gpu.Gpu.stage` and each frame by wall clock after ``finish()``. Raw samples
are kept; median and IQR are reported. ``total_ms`` is the sum of a frame's stage times (GPU timer
queries on a GPU, wall clock on llvmpipe); ``wall_ms`` is the frame's wall clock.

Per (scene, effect, size, spp, seed) the harness builds the effect's inputs and its reference once
(:class:`Prepared`) and hands the same objects to every method. A method's result is checked against
the invariants it declares (:attr:`methods.base.Result.invariants`): a violation makes the row
``degraded: …`` (its metrics are still recorded).

The run directory is written under a temporary name and renamed into place only when complete
(:mod:`harness.rundir`), so a failed run never leaves a folder that looks finished.
"""
from __future__ import annotations

import json
import sys
import time
import uuid
from dataclasses import dataclass
from pathlib import Path

from .errors import LdbenchError
from .naming import slug as _slug
from .rundir import RunDir
from .checks import camera_sees_geometry, unique_scene_names
from .suite import Job, Suite, resolve_sizes

REPO = Path(__file__).resolve().parent.parent


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


def _progress(iterable, total, desc, enabled):
    if not enabled:
        return iterable
    from tqdm import tqdm

    return tqdm(iterable, total=total, desc=desc, file=sys.stderr, leave=False)


@dataclass
class RunContext:
    """What every job of one run shares."""

    gpu: object
    machine: dict
    git: dict
    run_id: str
    suite_name: str
    out: Path  # the (temporary) run directory being written


@dataclass
class Prepared:
    """One (scene, effect, size, spp, seed): the effect's inputs and reference, the same for every method."""

    scene: object
    inputs: object
    reference: object


def prepare_key(job: Job) -> tuple:
    return (job.scene_key, job.effect, job.width, job.height, job.spp, job.seed)


def run_jobs(suite: Suite, out_dir, *, progress: bool = True, report: bool = True,
             reference_cache: bool = True) -> "pandas.DataFrame":
    """Execute every job of ``suite``; write ``out_dir`` atomically. Returns the results table."""
    from . import records
    from .gpu import Gpu
    from .scenes import load_scene

    out_dir = Path(out_dir)
    rundir = RunDir(out_dir)  # refuses a DIR that is not an ldbench run; lock; partial folder
    tmp = rundir.open()
    prepared: dict = {}
    try:
        gpu = Gpu()
        ctx = RunContext(gpu=gpu, machine=records.machine_info(gpu.info), git=records.git_info(REPO),
                         run_id=time.strftime("%Y%m%dT%H%M%SZ", time.gmtime()) + "-" + uuid.uuid4().hex[:6],
                         suite_name=suite.name, out=tmp)
        # Scenes first (cheap, and the last chance to reject bad input before GPU work).
        scenes = {}
        for job in suite.jobs:
            if job.scene_key not in scenes:
                scenes[job.scene_key] = load_scene(job.scene, **dict(job.scene_params))
                for w in scenes[job.scene_key].warnings:
                    print(f"ldbench: warning: {w}", file=sys.stderr)
            job.effect.check_scene(scenes[job.scene_key])
        scenes = unique_scene_names(scenes)  # a/scene.xml and b/scene.xml: two names, two image folders
        suite.jobs = resolve_sizes(suite.jobs, scenes)  # no size given: the XML film's
        for w, h in sorted({(j.width, j.height) for j in suite.jobs}):
            gpu.check_image_size(w, h)  # GL limits and memory, before anything is rendered
        keys = sorted({prepare_key(j) for j in suite.jobs}, key=str)
        for key in _progress(keys, len(keys), "references", progress):
            (sk, effect, w, h, spp, seed), sc = key, scenes[key[0]]
            inputs = effect.spec.inputs(sc, w, h, effect.params, seed)
            ref = effect.spec.reference(sc, effect, width=w, height=h, spp=spp, seed=seed, inputs=inputs,
                                        cache=reference_cache, progress=progress)
            camera_sees_geometry(sc, ref, w, h)  # else every metric is NaN
            prepared[key] = Prepared(sc, inputs, ref)
        rows = [run_job(ctx, job, prepared[prepare_key(job)])
                for job in _progress(suite.jobs, len(suite.jobs), "runs", progress)]
        records.write_results(rows, tmp)
        _release_inputs(prepared)
        gpu.release()
        (tmp / "suite.json").write_text(json.dumps({"name": suite.name, "source": suite.source,
                                                    "jobs": len(suite.jobs)}, indent=1))
        if report:
            from .report import write_report
            write_report(tmp)
        rundir.commit()  # old run aside, new one in, old one deleted
    except BaseException:
        _release_inputs(prepared)
        rundir.abort()
        raise
    return records.read_results(out_dir)


def _release_inputs(prepared: dict):
    for p in prepared.values():
        if hasattr(p.inputs, "release"):
            p.inputs.release()


def run_job(ctx: RunContext, job: Job, prep: Prepared) -> dict:
    """One job: set up, time the frames, score the last one; returns its record row."""
    from methods.base import View, get_method

    from . import records

    cls = get_method(job.method)
    params = cls.Params.from_dict(dict(job.params), method=job.method)
    method = cls(params)
    scene, spec, ref = prep.scene, job.effect.spec, prep.reference
    view = View(scene.camera, job.width, job.height)
    samples: dict = {}
    totals, walls = [], []
    status, result = "ok", None
    try:
        method.setup(ctx.gpu, scene)
        if hasattr(prep.inputs, "upload"):
            prep.inputs.upload(ctx.gpu)  # harness inputs on the GPU, before the timed frames
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
        result.resolve()
    except LdbenchError as e:
        status = f"error: {e}"
    finally:
        method.release()

    meta = getattr(ref, "meta", {}) or {}
    row = dict(run_id=ctx.run_id, suite=ctx.suite_name, **records.git_columns(ctx.git), scene=scene.name,
               scene_hash=scene.content_hash(), triangles=scene.triangle_count,
               scene_params=dict(job.scene_params), method=job.method, paper=cls.paper,
               effect=job.effect.name, effect_params=job.effect.key(), params=params.to_dict(),
               width=job.width, height=job.height, seed=job.seed, **records.machine_columns(ctx.machine),
               warmup=job.warmup, frames=job.frames, ref_spp=meta.get("spp"),
               ref_variant=meta.get("variant"), ref_key=meta.get("key"), status=status)
    if status != "ok":
        return records.make_row(**row)
    if result.invariants:
        row["status"] = "degraded: " + "; ".join(result.invariants)
    timing = records.timing_fields({**samples, "total": totals, "wall": walls})
    scores = spec.score(result, ref, scene=scene, inputs=prep.inputs, stage_ms=timing["stage_ms"])
    folder = ctx.out / "images" / scene_dir(scene)
    images = spec.save(result, ref, prep.inputs, folder, job_label(job, scene), reference_label(job, scene))
    rel = f"images/{scene_dir(scene)}/"
    images = {k: (rel + v if isinstance(v, str) and v.endswith((".png", ".exr")) else v) for k, v in images.items()}
    mem = {k: int(v) for k, v in result.memory_bytes.items()}
    row.update(**timing, memory_bytes=int(sum(mem.values())), memory=mem,
               counters={k: (v.item() if hasattr(v, "item") else v) for k, v in result.counters.items()},
               ref_noise=spec.noise(ref), images=images, **scores)
    return records.make_row(**row)
