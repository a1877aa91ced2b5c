"""``ldbench score``: answers computed outside ldbench (another renderer, another tracer) scored against
ldbench's references with ldbench's metrics, as rows of a normal run directory.

A **question** is what ``ldbench export`` writes (:mod:`ldbench.harness.export`): scene (with its builder
parameters), effect with its parameters, size, reference spp and seed. An **answer** is

==============  =========================================================================================
image effects   one image, H×W, row 0 at the top: EXR (linear, channels ``Y`` or ``R,G,B``) or PNG with a
                stated transfer curve (``srgb`` or ``linear``; 8 or 16 bit; ``png_scale`` is the value of
                white); an optional mask (PNG/EXR/.npy, nonzero = the pixel has a value: a missing pixel
                counts as an error, as for a method's mask). A NaN or ±inf pixel (image or mask) is a
                failed pixel: scored as missing, counted in ``nonfinite``, the row ``degraded``
``rays``        the hit distance per ray of the exported batch, in its order (``inf`` = miss, NaN = no
                answer): ``.npy`` (N,), ``.npz`` with ``t``, or ``.csv`` with a column ``t``
``vpl_range``   ``.npz`` with ``range`` (N VPLs) and optionally ``t`` (6N rays), or ``.csv`` with those
                columns (``t`` alone then: six rows per VPL, so use ``.npz``)
==============  =========================================================================================

plus what the user says about the answer: the method's name (``method``, default ``external``), its
parameters (recorded only), version and commit, and optionally per-stage times (ms; recorded with
``timing_source = "user"``) and memory (bytes per buffer). Rows get ``device = "external"``; ldbench's
own version and commit record who computed the metrics.

**Folder layout** (``ldbench score RUN --from FOLDER``): every folder under FOLDER holding a
``question.json`` (as written by ``ldbench export``) and one answer file named ``answer.exr``,
``answer.png``, ``answer.npy``, ``answer.npz`` or ``answer.csv`` is one row; beside them ``mask.png`` /
``mask.exr`` / ``mask.npy`` (optional) and ``answer.json`` (optional: ``method``, ``params``, ``paper``,
``method_version``, ``method_commit``, ``transfer``, ``png_scale``, ``stage_ms`` {stage: ms or [ms, ...]},
``memory`` {buffer: bytes}). A folder with a question and no answer is skipped with a warning.

**Joining a run**: the rows are added to RUN (a run directory, or a new one): the run is rewritten
through :class:`ldbench.harness.rundir.RunDir` (locked, into a partial folder, committed atomically), its rows
and files kept, so ``report``, ``compare``, ``history`` and ``reproduce --from-run`` read them like any
other rows.
"""
from __future__ import annotations

import json
import math
import shutil
import sys
import time
import uuid
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ldbench.core.effects.base import effect_from_key
from ldbench.core.errors import Interrupted, LdbenchError
from ldbench.core.exr import read_answer_channels, read_exr
from ldbench.core.imageio import read_png
from ldbench.core.plugins import ldbench_info
from ldbench.core.scenes import load_scene
from ldbench.methods.base import Result

from . import defaults, records
from .naming import slug
from .records import checked_memory
from .rundir import MARKER, STALE_NAME, RunDir, is_run_dir
from .runner import Prepared, job_label, prepare, progress_bar, reference_label, release_inputs, scene_dir
from .suite import MAX_SEED, MAX_SPP, Job, check_budget, checked_int, parse_size
from .unbiased_score import VARIANCE_NAMES, check_test_args, run_test, save_maps

# Heavy: pandas (a CSV answer) and the report module (scipy) are imported where used.

TRANSFERS = ("srgb", "linear")
ANSWER_NAMES = ("answer.exr", "answer.png", "answer.npy", "answer.npz", "answer.csv")
MASK_NAMES = ("mask.png", "mask.exr", "mask.npy")
EXTERNAL = "external"


@dataclass
class Question:
    """What was asked: the same fields as an ldbench job's (scene, effect, size, spp, seed)."""

    scene: str
    effect: object  # ldbench.core.effects.Effect
    width: int
    height: int
    spp: int = defaults.SPP
    seed: int = defaults.SEED
    scene_params: dict = field(default_factory=dict)

    @classmethod
    def from_json(cls, d: dict, where: str = "question.json") -> "Question":
        """The question of a ``question.json`` object, its values checked as the command line's are (sizes,
        spp and seed whole numbers in range: ``256.5``, ``"256"`` or ``true`` is no size) and its size within
        this machine's budget (:func:`~ldbench.harness.suite.check_budget`), before any work: one line naming
        ``where``."""
        if not isinstance(d, dict):
            raise LdbenchError(f"{where}: not an ldbench question (a JSON object with scene, effect, width, height)")
        try:
            scene, scene_params = d["scene"], d.get("scene_params") or {}
            if not isinstance(scene, str) or not isinstance(scene_params, dict):
                raise TypeError("scene must be a string, scene_params an object")
            effect = effect_from_key(d["effect"])
            w, h = parse_size([checked_int(d["width"], "width", 1), checked_int(d["height"], "height", 1)])
            spp = checked_int(d.get("spp", defaults.SPP), "spp", 1, MAX_SPP)
            seed = checked_int(d.get("seed", defaults.SEED), "seed", 0, MAX_SEED)
            check_budget(w, h, spp, effect)
        except LdbenchError as e:
            raise LdbenchError(f"{where}: {e}") from None
        except (KeyError, TypeError, ValueError) as e:
            raise LdbenchError(f"{where}: not an ldbench question ({type(e).__name__}: {e})") from None
        return cls(scene=scene, effect=effect, width=w, height=h, spp=spp, seed=seed, scene_params=dict(scene_params))


@dataclass
class Answer:
    """An answer file and what the user states about it."""

    path: Path
    method: str = EXTERNAL
    params: dict = field(default_factory=dict)
    paper: str = ""
    mask: Path | None = None
    transfer: str | None = None
    png_scale: float = 1.0
    stage_ms: dict = field(default_factory=dict)  # {stage: [ms, ...]}
    memory: dict = field(default_factory=dict)    # {buffer: bytes}
    method_version: str | None = None
    method_commit: str | None = None
    test: str | None = None                # "unbiased": ldbench/harness/unbiased_score.py
    variance: Path | None = None           # EXR of the answer's variance of the mean
    second_moment: Path | None = None      # EXR of the mean of the squared samples (with ``samples``)
    samples: int | None = None             # the answer's samples per pixel
    alpha: float = 0.01
    correction: str = "sidak"


# ---- reading answers ---------------------------------------------------------------------------------
def srgb_to_linear(v: np.ndarray) -> np.ndarray:
    """The sRGB transfer curve inverted (IEC 61966-2-1)."""
    v = np.asarray(v, np.float64)
    return np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4)


def read_image(path: Path, channels: int, *, transfer: str | None, png_scale: float = 1.0) -> np.ndarray:
    """H×W×channels float32, row 0 at the top, from an EXR (linear) or a PNG (``transfer`` required)."""
    path = Path(path)
    if not path.is_file():
        raise LdbenchError(f"answer image not found: {path}")
    suffix = path.suffix.lower()
    if suffix == ".exr":
        if transfer not in (None, "linear"):
            raise LdbenchError(f"{path.name}: an EXR is linear; --transfer {transfer} applies to PNG only")

        img = read_answer_channels(path)
    elif suffix == ".png":
        if transfer not in TRANSFERS:
            raise LdbenchError(f"{path.name}: a PNG answer needs its transfer curve: --transfer srgb|linear")

        try:
            raw = read_png(path)  # [0, 1], exact for 8- and 16-bit PNGs
        except (OSError, ValueError, SyntaxError) as e:
            raise LdbenchError(f"cannot read {path}: {e}") from None
        raw = raw[..., None] if raw.ndim == 2 else raw[..., :1] if raw.shape[-1] == 2 else raw[..., :3]  # no alpha
        img = (srgb_to_linear(raw) if transfer == "srgb" else raw) * float(png_scale)
        img = img.astype(np.float32)
    else:
        raise LdbenchError(f"{path.name}: answer images are .exr or .png")
    if channels == 1 and img.shape[-1] == 3:
        with np.errstate(invalid="ignore", over="ignore"):  # NaN/inf pixels: failed pixels, scored as such
            grey = all(np.allclose(img[..., 0], img[..., c], equal_nan=True) for c in (1, 2))
        if not grey:
            raise LdbenchError(f"{path.name}: a one-channel effect needs a grey image (R = G = B) or a Y channel")
        img = img[..., :1]
    elif channels == 3 and img.shape[-1] == 1:
        img = np.repeat(img, 3, -1)
    return img


def read_mask(path: Path, shape: tuple) -> np.ndarray:
    """H×W mask from PNG, EXR or .npy: bool (nonzero = the pixel has a value) for integer and bool files;
    for float files float32 1 (value > 0.5), 0, or NaN where the mask is NaN or ±inf (a failed pixel,
    counted in the row's ``nonfinite``). Anything else (0-d, 1-d, object arrays, empty or broken files)
    is one line."""
    path = Path(path)
    if not path.is_file():
        raise LdbenchError(f"mask not found: {path}")
    s = path.suffix.lower()
    try:
        if s == ".npy":
            m = np.load(path, allow_pickle=False)
        elif s == ".png":
            m = read_png(path)
        elif s == ".exr":
            ch = read_exr(path)
            m = np.asarray(ch.get("Y", next(iter(ch.values()))))
        else:
            raise LdbenchError(f"{path.name}: masks are .png, .exr or .npy")
    except (OSError, ValueError, EOFError, SyntaxError) as e:  # zero bytes, not a PNG, an object array, ...
        raise LdbenchError(f"cannot read mask {path}: {(str(e).strip().splitlines() or [type(e).__name__])[0]}") \
            from None
    m = np.asarray(m)
    if m.dtype.kind not in "biuf":
        raise LdbenchError(f"{path.name}: a mask holds numbers or booleans, not {m.dtype}")
    if m.ndim == 3:
        m = m[..., 0]
    if m.shape != tuple(shape):
        got = f"{m.shape[1]}x{m.shape[0]}" if m.ndim == 2 else f"of shape {m.shape}"
        raise LdbenchError(f"{path.name}: mask is {got}, the question is {shape[1]}x{shape[0]}")
    if m.dtype.kind != "f":
        return m != 0
    # 1 = has a value, 0 = missing, NaN where the mask itself is not finite (a failed pixel, counted)
    finite = np.isfinite(m)
    return np.where(finite, np.where(finite & (np.nan_to_num(m) > 0.5), 1.0, 0.0), np.nan).astype(np.float32)


def read_arrays(path: Path) -> dict:
    """Per-ray / per-VPL answers: {"t": ..., "range": ...} from .npy (t), .npz or .csv."""
    path = Path(path)
    if not path.is_file():
        raise LdbenchError(f"answer file not found: {path}")
    s = path.suffix.lower()
    try:
        if s == ".npy":
            return _numeric(path, {"t": np.load(path, allow_pickle=False)})
        if s == ".npz":
            with np.load(path, allow_pickle=False) as z:
                return _numeric(path, {k: z[k] for k in z.files if k in ("t", "range")})
        if s == ".csv":
            import pandas as pd

            df = pd.read_csv(path)
            out = {k: pd.to_numeric(df[k], errors="coerce").to_numpy(np.float32) for k in ("t", "range") if k in df}
            if not out:
                raise LdbenchError(f"{path.name}: no column t or range (has {', '.join(df.columns)})")
            return out
    except (OSError, ValueError, EOFError, zipfile.BadZipFile) as e:  # zero bytes, pickled, broken
        raise LdbenchError(f"cannot read {path}: {(str(e).strip().splitlines() or [type(e).__name__])[0]}") \
            from None
    raise LdbenchError(f"{path.name}: per-ray answers are .npy, .npz or .csv")


def _numeric(path: Path, arrays: dict) -> dict:
    """``arrays`` if every one holds numbers, else one line."""
    for k, a in arrays.items():
        if a.dtype.kind not in "biuf":
            raise LdbenchError(f"{path.name}: {k!r} must hold numbers, not {a.dtype}")
    return arrays


# ---- scoring -----------------------------------------------------------------------------------------
def _result(question, answer: Answer, spec):
    if spec.output == "image":
        img = read_image(answer.path, spec.channels, transfer=answer.transfer, png_scale=answer.png_scale)
        if img.shape[:2] != (question.height, question.width):
            raise LdbenchError(f"{answer.path.name}: the image is {img.shape[1]}x{img.shape[0]}, the question is "
                               f"{question.width}x{question.height}")
        mask = None if answer.mask is None else read_mask(answer.mask, img.shape[:2])
        return Result(image=img, mask=mask)
    if answer.mask is not None:
        raise LdbenchError(f"effect {question.effect.name!r}: a mask goes with images, not per-ray answers")
    arrays = read_arrays(answer.path)
    key = spec.answer_key
    if key not in arrays:
        raise LdbenchError(f"{answer.path.name}: effect {question.effect.name!r} needs {key!r} in the answer")
    return Result(arrays=arrays)


def score_rows(items, out, *, run_id: str, suite_name: str, progress: bool = False) -> list:
    """Rows of (question, answer) pairs, images written under ``out``; references shared by equal questions."""
    info = ldbench_info()
    git = {"commit": info["commit"], "dirty": info["dirty"]}
    scenes, prepared, rows = {}, {}, []
    try:
        for q, a in progress_bar(items, len(items), "answers", progress):
            skey = (q.scene, tuple(sorted(q.scene_params.items())))
            if skey not in scenes:
                scenes[skey] = load_scene(q.scene, **q.scene_params)
            scene = scenes[skey]
            q.effect.check_scene(scene)
            key = (skey, q.effect, q.width, q.height, q.spp, q.seed)
            if key not in prepared:
                prepared[key] = prepare(scene, key, progress=progress)
            prep: Prepared = prepared[key]
            spec = q.effect.spec
            method = slug(a.method) if a.method != EXTERNAL else EXTERNAL
            job = Job(q.scene, skey[1], method, tuple(sorted(a.params.items())), q.effect, q.width, q.height,
                      q.spp, 0, 0, q.seed)
            result = _result(q, a, spec)
            samples = {k: [float(x) for x in (v if isinstance(v, (list, tuple)) else [v])]
                       for k, v in a.stage_ms.items()}
            timing = records.timing_fields(samples) if samples else {"stage_ms": {}}
            scores = spec.score(result, prep.reference, scene=scene, inputs=prep.inputs,
                                stage_ms=timing.get("stage_ms") or {})
            folder = Path(out) / "images" / scene_dir(scene)
            label = _free_label(folder, job_label(job, scene))
            images = spec.save(result, prep.reference, prep.inputs, folder, label, reference_label(job, scene))
            rel = f"images/{scene_dir(scene)}/"
            images = {k: (rel + v if isinstance(v, str) and v.endswith((".png", ".exr")) else v)
                      for k, v in images.items()}
            images["answer_source"] = str(Path(a.path).resolve())  # the user's file, where it was scored from
            if a.test:  # --test unbiased: columns and maps of ldbench/harness/unbiased_score.py
                ures, ucols = run_test(a.test, q, a, result, prep.reference, spec, alpha=a.alpha,
                                       correction=a.correction)
                scores = {**scores, **ucols}
                images.update({k: rel + v for k, v in save_maps(ures, folder, label).items()})
            meta = getattr(prep.reference, "meta", {}) or {}
            mem = {str(k): int(v) for k, v in a.memory.items()}
            row = dict(run_id=run_id, suite=suite_name, **git, ldbench_version=info["version"], scene=scene.name,
                       scene_hash=scene.content_hash(), triangles=scene.triangle_count,
                       scene_params=dict(q.scene_params), method=method, paper=a.paper or None,
                       effect=q.effect.name, effect_params=q.effect.key(), params=dict(a.params),
                       width=q.width, height=q.height, seed=q.seed,
                       **records.machine_columns({"device": EXTERNAL}),
                       method_module=None, method_dist=None, method_version=a.method_version,
                       method_commit=a.method_commit, method_dirty=None,
                       timing_source="user" if samples else None, ref_spp=meta.get("spp"),
                       ref_variant=meta.get("variant"), ref_key=meta.get("key"), ref_noise=spec.noise(prep.reference),
                       images=images, counters={}, **(timing if samples else {}), **scores)
            if mem:
                row.update(memory=mem, memory_bytes=sum(mem.values()))
            problems = spec.problems(scores)  # e.g. non-finite pixels: never ok
            if problems:
                row["status"] = "degraded: " + "; ".join(problems)
            rows.append(records.make_row(**row))
    finally:
        release_inputs(prepared)
    return rows


def score_into_run(items, run_dir, *, report: bool = True, progress: bool = False) -> list:
    """Score ``items`` and add their rows to the run directory ``run_dir`` (created when missing);
    returns the new rows."""
    run_dir = Path(run_dir)
    rd = RunDir(run_dir)
    rd.check()  # a path no write can succeed at (too long, under a file) before reading it
    joining = is_run_dir(run_dir)
    tmp = rd.open()
    try:
        old_rows, suite_name, version = [], "score", None
        if joining:
            for p in run_dir.iterdir():  # the run's files as they are (images, report, suite.json)
                dst = tmp / p.name
                if p.is_dir() and not p.is_symlink():
                    shutil.copytree(p, dst, symlinks=True, dirs_exist_ok=True)
                else:
                    shutil.copy2(p, dst, follow_symlinks=False)
            old = records.read_results(run_dir)
            old_rows, version = old.to_dict("records"), old.attrs.get("schema_version")
            try:
                suite_name = json.loads((run_dir / "suite.json").read_text()).get("name") or suite_name
            except (OSError, ValueError):
                pass
        run_id = time.strftime("%Y%m%dT%H%M%SZ", time.gmtime()) + "-score-" + uuid.uuid4().hex[:6]
        rows = score_rows(items, tmp, run_id=run_id, suite_name=suite_name, progress=progress)
        records.write_results(old_rows + rows, tmp, schema_version=version)  # a 1.7 run stays 1.7
        if not joining:
            (tmp / "suite.json").write_text(json.dumps({"name": suite_name, "source": "ldbench score",
                                                        "jobs": len(rows)}, indent=1))
        rd.commit()
    except BaseException:
        rd.abort()
        raise
    if report:  # as `ldbench report RUN` would, over the old rows and the new
        from ldbench.reports.report import write_report

        try:
            write_report(run_dir)
        except KeyboardInterrupt:
            raise Interrupted(f"the {len(rows)} scored row(s) are kept in {run_dir} (do not score them again); "
                              f"its report was not written: ldbench report {run_dir}") from None
    return rows


def _free_label(folder: Path, label: str) -> str:
    """``label``, or ``label-2``, ``label-3``, ...: the first stem whose image (``STEM.exr``, which every effect
    writes) is not in ``folder`` yet, so that a second answer to one question (same method, effect, size and
    parameters) never overwrites the images the first row points at."""
    n, out = 1, label
    while (folder / f"{out}.exr").exists() or (folder / f"{out}.png").exists():
        n += 1
        out = f"{label}-{n}"
    return out


# ---- the folder layout and the command line -------------------------------------------------------------
def _answer_meta(folder: Path) -> dict:
    p = folder / "answer.json"
    if not p.is_file():
        return {}
    try:
        d = json.loads(p.read_text())
    except ValueError as e:
        raise LdbenchError(f"{p}: not JSON ({e})") from None
    if not isinstance(d, dict):
        raise LdbenchError(f"{p}: must be a JSON object")
    known = {"method", "params", "paper", "method_version", "method_commit", "transfer", "png_scale", "stage_ms",
             "memory", "test", "samples", "alpha", "correction"}
    unknown = set(d) - known
    if unknown:
        raise LdbenchError(f"{p}: unknown key {sorted(unknown)[0]!r} (known: {', '.join(sorted(known))})")
    return d


def items_from_folder(root) -> list:
    """(question, answer) pairs of every answered question under ``root`` (module docstring)."""
    root = Path(root)
    if not root.is_dir():
        raise LdbenchError(f"not a folder: {root}")

    out = []
    for qf in sorted(root.rglob("question.json")):
        folder = qf.parent
        if (folder / MARKER).exists() or any(STALE_NAME.match(p) for p in folder.relative_to(root).parts):
            # an export killed or still writing (.Q.partial-PID), or the previous one it moved aside
            # (.Q.old-PID): never a question of its own
            print(f"ldbench: warning: {folder}: an unfinished or replaced export, skipped", file=sys.stderr)
            continue
        try:
            q = Question.from_json(json.loads(qf.read_text()), str(qf))
        except ValueError as e:
            raise LdbenchError(f"{qf}: not JSON ({e})") from None
        found = [folder / n for n in ANSWER_NAMES if (folder / n).is_file()]
        if not found:
            print(f"ldbench: warning: {folder}: a question without an answer file ({', '.join(ANSWER_NAMES)})",
                  file=sys.stderr)
            continue
        if len(found) > 1:
            raise LdbenchError(f"{folder}: more than one answer ({', '.join(p.name for p in found)})")
        meta = _answer_meta(folder)
        masks = [folder / n for n in MASK_NAMES if (folder / n).is_file()]
        extra = {k: folder / f for k, f in VARIANCE_NAMES.items() if (folder / f).is_file()}
        out.append((q, make_answer(found[0], mask=masks[0] if masks else None, **extra, **meta)))
    if not out:
        raise LdbenchError(f"no answered question under {root} (a folder with question.json and "
                           f"{' | '.join(ANSWER_NAMES)})")
    return out


def make_answer(path, *, method=EXTERNAL, params=None, paper="", mask=None, transfer=None, png_scale=1.0,
                stage_ms=None, memory=None, method_version=None, method_commit=None, test=None, variance=None,
                second_moment=None, samples=None, alpha=0.01, correction="sidak") -> Answer:
    """An :class:`Answer` with its values checked (one line for each bad one: a wrong type too)."""
    for name, v in (("method", method), ("paper", paper), ("method_version", method_version),
                    ("method_commit", method_commit)):
        if v is not None and not isinstance(v, str):
            raise LdbenchError(f"{name} must be a string, got {v!r}")
    for name, v in (("params", params), ("stage_ms", stage_ms), ("memory", memory)):
        if v is not None and not isinstance(v, dict):
            raise LdbenchError(f"{name} must be a table of NAME = VALUE, got {v!r}")
    if transfer is not None and not (isinstance(transfer, str) and transfer in TRANSFERS):
        raise LdbenchError(f"transfer must be one of {', '.join(TRANSFERS)}, got {transfer!r}")
    if isinstance(png_scale, bool):
        raise LdbenchError(f"png_scale must be a number, got {png_scale!r}")
    try:
        scale = float(png_scale)
    except (TypeError, ValueError):
        raise LdbenchError(f"png_scale must be a number, got {png_scale!r}") from None
    if not (math.isfinite(scale) and scale > 0):
        raise LdbenchError(f"png_scale must be a positive number, got {png_scale!r}")
    stages = {}
    for k, v in (stage_ms or {}).items():
        vals = v if isinstance(v, (list, tuple)) else [v]
        try:
            if any(isinstance(x, bool) for x in vals):
                raise TypeError
            vals = [float(x) for x in vals]
        except (TypeError, ValueError):
            raise LdbenchError(f"stage time {k!r} must be milliseconds (a number or a list), got {v!r}") from None
        if not vals or not all(math.isfinite(x) and x >= 0 for x in vals):
            raise LdbenchError(f"stage time {k!r} must be finite and >= 0, got {v!r}")
        stages[str(k)] = vals
    if len({len(v) for v in stages.values()}) > 1:
        raise LdbenchError("stage times: give every stage the same number of frames "
                           f"({', '.join(f'{k}: {len(v)}' for k, v in stages.items())})")

    mem = checked_memory(memory or {})  # whole bytes, >= 0, within the int64 of the memory columns
    return Answer(Path(path), method=str(method or EXTERNAL), params=dict(params or {}), paper=str(paper or ""),
                  mask=None if mask is None else Path(mask), transfer=transfer, png_scale=scale, stage_ms=stages,
                  memory=mem, method_version=None if method_version is None else str(method_version),
                  method_commit=None if method_commit is None else str(method_commit),
                  **check_test_args(test, variance, second_moment, samples, alpha, correction))
