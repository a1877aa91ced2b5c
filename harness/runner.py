"""Run a suite: for each job, set the method up, render warm-up and measured frames, compare the last
frame with the Mitsuba reference, and write records and images.

Timing protocol (DESIGN.md): upload and compilation (``setup``) are outside the timed region; then
``warmup`` frames, then ``frames`` measured frames, each stage timed by :meth:`harness.gpu.Gpu.stage`
and each frame by wall clock after ``finish()``. Raw samples are kept; median and IQR are reported.
``total_ms`` is the sum of a frame's stage times (GPU timer queries on a GPU, wall clock on llvmpipe);
``wall_ms`` is the frame's wall clock.

The run directory is written under a temporary name and renamed into place only when complete
(:mod:`harness.rundir`), so a failed run never leaves a folder that looks finished.
"""
from __future__ import annotations

import json
import math
import os
import shutil
import sys
import time
import uuid
from pathlib import Path

import numpy as np

from .errors import LdbenchError
from .rundir import RunDir
from .checks import camera_sees_geometry, unique_scene_names
from .suite import Job, Suite, resolve_sizes

REPO = Path(__file__).resolve().parent.parent


def _slug(s: str) -> str:
    return "".join(c if c.isalnum() or c in "-_." else "_" for c in s)[:80]


def _scene_tag(job: Job, scene) -> str:
    """Distinguishes images of one builder called with different parameters."""
    return f"-s{scene.content_hash()[:6]}" if job.scene_params else ""


def job_label(job: Job, scene) -> str:
    """Image file stem: method, effect, size, method params and (if any) a scene-parameter tag."""
    p = "-".join(f"{k}{v}" for k, v in job.params)
    return _slug(f"{job.method}-{job.effect.label()}-{job.width}x{job.height}" + (f"-{p}" if p else "")
                 + _scene_tag(job, scene))


def _progress(iterable, total, desc, enabled):
    if not enabled:
        return iterable
    from tqdm import tqdm

    return tqdm(iterable, total=total, desc=desc, file=sys.stderr, leave=False)


def save_image(path_noext: Path, img: np.ndarray, *, png_scale: float | None = None):
    """EXR (linear float) + PNG preview (sRGB; ``png_scale`` maps that value to white)."""
    from references.exr import write_exr
    import matplotlib.image as mpimg
    from .metrics import to_srgb8

    path_noext.parent.mkdir(parents=True, exist_ok=True)
    chans = {"Y": img[..., 0]} if img.shape[-1] == 1 else dict(zip("RGB", np.moveaxis(img[..., :3], -1, 0)))
    write_exr(str(path_noext) + ".exr", chans)
    disp = img if png_scale in (None, 0) else img / png_scale
    rgb = np.repeat(disp, 3, -1) if disp.shape[-1] == 1 else disp[..., :3]
    mpimg.imsave(str(path_noext) + ".png", to_srgb8(rgb))


def run_jobs(suite: Suite, out_dir, *, progress: bool = True, report: bool = True,
             reference_cache: bool = True) -> "pandas.DataFrame":
    """Execute every job of ``suite``; write ``out_dir`` atomically. Returns the results table."""
    from methods.base import View, get_method
    from references import render_reference
    from . import metrics, records
    from .gpu import Gpu
    from .scenes import load_scene

    out_dir = Path(out_dir)
    rundir = RunDir(out_dir)  # refuses a DIR that is not an ldbench run; lock; partial folder
    tmp = rundir.open()
    try:
        gpu = Gpu()
        machine = records.machine_info(gpu.info)
        git = records.git_info(REPO)
        run_id = time.strftime("%Y%m%dT%H%M%SZ", time.gmtime()) + "-" + uuid.uuid4().hex[:6]
        scenes, refs, rows = {}, {}, []
        # Scenes first (cheap, and the last chance to reject bad input before GPU work).
        for job in suite.jobs:
            if job.scene_key not in scenes:
                scenes[job.scene_key] = load_scene(job.scene, **dict(job.scene_params))
                for w in scenes[job.scene_key].warnings:
                    print(f"ldbench: warning: {w}", file=sys.stderr)
            sc = scenes[job.scene_key]
            from .effects import NEEDS_LIGHT
            if job.effect.name in NEEDS_LIGHT and not sc.lights:
                raise LdbenchError(f"scene {sc.name!r} has no spot or point light; effect "
                                   f"{job.effect.name!r} needs one")
        scenes = unique_scene_names(scenes)  # a/scene.xml and b/scene.xml: two names, two image folders
        suite.jobs = resolve_sizes(suite.jobs, scenes)  # no size given: the XML film's
        for w, h in sorted({(j.width, j.height) for j in suite.jobs}):
            gpu.check_image_size(w, h)  # GL limits and memory, before anything is rendered
        ref_keys = sorted({(j.scene_key, j.effect, j.width, j.height, j.spp) for j in suite.jobs}, key=str)
        for key in _progress(ref_keys, len(ref_keys), "references", progress):
            sk, eff, w, h, spp = key
            refs[key] = render_reference(scenes[sk], eff, width=w, height=h, spp=spp,
                                         cache=reference_cache, progress=progress)
            camera_sees_geometry(scenes[sk], refs[key], w, h)  # else every metric is NaN
        for job in _progress(suite.jobs, len(suite.jobs), "runs", progress):
            sc = scenes[job.scene_key]
            ref = refs[(job.scene_key, job.effect, job.width, job.height, job.spp)]
            rows.append(_run_one(gpu, job, sc, ref, tmp, suite.name, run_id, machine, git,
                                 get_method, View, metrics, records))
        records.write_results(rows, tmp)
        gpu.release()
        (tmp / "suite.json").write_text(json.dumps({"name": suite.name, "source": suite.source,
                                                    "jobs": len(suite.jobs)}, indent=1))
        if report:
            from .report import write_report
            write_report(tmp)
        rundir.commit()  # old run aside, new one in, old one deleted
    except BaseException:
        rundir.abort()
        raise
    return records.read_results(out_dir)


def _run_one(gpu, job, scene, ref, out, suite_name, run_id, machine, git, get_method, View, metrics,
             records):
    cls = get_method(job.method)
    params = cls.Params.from_dict(dict(job.params), method=job.method)
    method = cls(params)
    view = View(scene.camera, job.width, job.height)
    label = job_label(job, scene)
    samples: dict = {}
    totals, walls = [], []
    status, result = "ok", None
    try:
        method.setup(gpu, scene)
        for i in range(job.warmup + job.frames):
            gpu.begin_frame()
            result = method.frame(view, job.effect)
            stages, wall = gpu.end_frame()
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

    row = dict(run_id=run_id, suite=suite_name, **records.git_columns(git), scene=scene.name,
               scene_hash=scene.content_hash(), triangles=scene.triangle_count,
               scene_params=dict(job.scene_params), method=job.method, paper=cls.paper,
               effect=job.effect.name, effect_params=job.effect.key(), params=params.to_dict(),
               width=job.width, height=job.height, **records.machine_columns(machine),
               warmup=job.warmup, frames=job.frames, ref_spp=ref.meta.get("spp"),
               ref_variant=ref.meta.get("variant"), ref_key=ref.meta.get("key"), status=status)
    if status == "ok":
        mem = {k: int(v) for k, v in result.memory_bytes.items()}
        mask = ref.mask if result.mask is None else (ref.mask & result.mask)
        img = np.asarray(result.image, np.float32)
        if img.shape != ref.mean.shape:
            raise LdbenchError(f"method {job.method!r} returned an image of shape {img.shape}, "
                               f"the reference has {ref.mean.shape}")
        m = metrics.all_metrics(img, ref.mean, mask=mask)
        idir = out / "images" / _slug(scene.name)
        scale = None if job.effect.name == "ao" else float(np.percentile(ref.mean[ref.mask], 99) or 1.0)
        ref_name = _slug(f"reference-{job.effect.label()}-{job.width}x{job.height}{_scene_tag(job, scene)}")
        if not (idir / f"{ref_name}.exr").exists():
            save_image(idir / ref_name, ref.mean, png_scale=scale)
        save_image(idir / label, img, png_scale=scale)
        emap = metrics.error_map(img, ref.mean, mask=mask)
        vmax = float(np.percentile(emap[mask], 99)) if mask.any() else 1.0
        import matplotlib.image as mpimg
        from references.exr import write_exr
        write_exr(str(idir / f"{label}-error.exr"), {"Y": emap.astype(np.float32)})
        mpimg.imsave(str(idir / f"{label}-error.png"), metrics.colorize(emap, vmax=max(vmax, 1e-6)))
        noise = float(np.sqrt(np.mean(ref.variance[ref.mask]))) if ref.mask.any() else 0.0
        row.update(**records.timing_fields({**samples, "total": totals, "wall": walls}),
                   memory_bytes=int(sum(mem.values())), memory=mem,
                   counters={k: (v.item() if hasattr(v, "item") else v) for k, v in result.counters.items()},
                   psnr=m["psnr"], ssim=m["ssim"], flip=m["flip"], relmse=m["relmse"],
                   metric_settings=m["metric_settings"],
                   ref_noise={"rms_std_of_mean": noise, "spp": ref.meta.get("spp")},
                   images={"image": f"images/{_slug(scene.name)}/{label}.png",
                           "exr": f"images/{_slug(scene.name)}/{label}.exr",
                           "error": f"images/{_slug(scene.name)}/{label}-error.png",
                           "error_exr": f"images/{_slug(scene.name)}/{label}-error.exr",
                           "reference": f"images/{_slug(scene.name)}/{ref_name}.png",
                           "error_vmax": vmax})
    return records.make_row(**row)
