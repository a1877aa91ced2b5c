"""Benchmark suites: TOML files (or command-line flags) expanded into a list of validated jobs.

docs/reference/suite-format.md is the reference of the format (every key, its type and default). A suite file::

    [suite]
    name = "default"
    size = "128x128"        # default image size, "WxH" or [W, H]; default: the scene's film, else 128x128
    spp = 256               # reference samples per pixel
    warmup = 2              # warm-up frames
    frames = 5              # measured frames
    job_timeout = 3600      # seconds one job may take; past it the job is an error row and the run goes on
                            # (every value left out takes ldbench/harness/defaults.py's, shown here)

    [[run]]
    scene = "cornell"               # built-in name, XML path or mesh path (relative to the suite file)
    scene_params = { }              # builder parameters
    effect = "ao"                   # one effect, or a list
    d_max = [0.5, inf]              # effect parameters at top level (ao: d_max, falloff); a list is a sweep
    falloff = "step"
    effect_params = { }             # any effect's parameters, e.g. { ray_kind = "glossy", exponent = [8, 64] }
    seed = 0                        # seed of the effect's inputs and of the reference
    methods = "all"                 # "all" = every registered method supporting the effect, or a list
    test = "unbiased"               # optional: test each method's image for bias (only methods that declare
                                    # themselves unbiased, e.g. mc-ao; docs/reference/cli.md, "score --test unbiased")
    size = "64x64"                  # optional overrides of [suite] values
    [run.params.ldm-ao]             # method parameters; a list is a sweep (grid over all lists)
    directions = [32, 64, 128]

Every job is validated (scene builder parameters, method names, effect support, method parameters)
before anything is rendered, so bad input fails before a run directory exists.
"""
from __future__ import annotations

import dataclasses
import itertools
import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

from ldbench.core import gpu
from ldbench.core.effects import Effect
from ldbench.core.effects.base import effects_from_user
from ldbench.core.errors import LdbenchError
from ldbench.methods.base import canonical_name, registry

from . import defaults
from .resources import bundled_suites, suite_path

SUITE_KEYS = {"name", "size", "spp", "warmup", "frames", "description", "job_timeout"}
RUN_KEYS = {"scene", "scene_params", "effect", "d_max", "falloff", "effect_params", "seed", "methods", "params",
            "size", "spp",
            "warmup", "frames", "test"}


@dataclass(frozen=True)
class Job:
    scene: str
    scene_params: tuple  # sorted (key, value) pairs
    method: str
    params: tuple  # sorted (key, value) pairs of the method's parameters as given (not defaults)
    effect: Effect
    width: int | None  # None until resolve_sizes: the scene's film size
    height: int | None
    spp: int
    warmup: int
    frames: int
    seed: int = 0  # seed of the effect's inputs and of the reference
    test: str | None = None  # "unbiased": the [[run]]'s test of methods that declare themselves unbiased

    @property
    def scene_key(self):
        return (self.scene, self.scene_params)


@dataclass
class Suite:
    name: str
    jobs: list = field(default_factory=list)
    source: str = ""
    job_timeout: float = defaults.JOB_TIMEOUT  # seconds (0: no limit)


#: Image sides: SSIM's smallest window is 3 x 3 (:func:`ldbench.core.metrics.ssim_win_size`); 16384 is the
#: largest texture any GL driver we know offers (the GPU's own limits are checked by
#: :meth:`ldbench.core.gpu.Gpu.check_image_size` before rendering).
MIN_SIDE, MAX_SIDE = 3, 16384
#: Reference samples per pixel, at most 2^20 (a 1024^2 reference at that spp is already 2^40 samples).
MAX_SPP = 1 << 20
#: Reference samples (pixels x spp) per job, at most 2^40: about 11 minutes of AO rays at the 1.7 G
#: rays/s Mitsuba reaches on an H200, many hours on a CPU. Beyond it a typo (spp = 10^11) is far likelier
#: than intent.
MAX_REFERENCE_SAMPLES = 1 << 40
#: Measured and warm-up frames per job: [1, 10^4] and [0, 10^4] (10^4 frames of a 100 ms method are
#: already 17 minutes per job; more is a typo, and 10^20 ran until killed).
MAX_FRAMES = MAX_WARMUP = 10_000
#: Seeds are unsigned 32-bit: the GPU's random numbers and Mitsuba's sampler take a uint32, the records
#: an int64 (a larger one rendered, then failed when it was recorded).
MAX_SEED = (1 << 32) - 1


#: Method parameters without a declared maximum: an integer (seeds, pool sizes, 0 = auto) is at most
#: 2^31 - 1 (GLSL ints and buffer offsets hold no more), a float (biases, in pixels or texels) is finite.
MAX_INT_PARAM = (1 << 31) - 1


def method_params(cls, values: dict, method: str):
    """``cls.Params`` from ``values`` (validated by the adapter's declared ranges), with every parameter
    without a declared maximum checked as :data:`MAX_INT_PARAM` says."""
    params = cls.Params.from_dict(values, method=method)
    todo = [(params, "")]
    while todo:  # a parameter group (structure.source) is checked as its own fields, named group.field
        obj, prefix = todo.pop()
        for f in dataclasses.fields(obj):
            v, name = getattr(obj, f.name), prefix + f.name
            if "group" in f.metadata:
                todo.append((v, name + "."))
                continue
            if f.metadata.get("hi") is not None:
                continue
            if _is_int(v) and v > MAX_INT_PARAM:
                raise LdbenchError(f"parameter {name}={v} of method {method!r} above its maximum {MAX_INT_PARAM}")
            if isinstance(v, float) and not math.isfinite(v):
                raise LdbenchError(f"parameter {name}={v} of method {method!r} must be finite")
    return params


def _is_int(v) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


def parse_size(v) -> tuple[int, int]:
    """``"WxH"`` or ``[W, H]`` (integers; no floats, no booleans) as (W, H), each in [3, 16384]."""
    w: int | None = None
    h: int | None = None
    if isinstance(v, str) and v.lower().count("x") == 1:
        a, b = v.lower().split("x")
        if a.strip().isdigit() and b.strip().isdigit():
            w, h = int(a), int(b)
    elif isinstance(v, (list, tuple)) and len(v) == 2 and all(_is_int(x) for x in v):
        w, h = v
    if w is None or h is None:  # set together
        raise LdbenchError(f"size must be WxH (e.g. 256x256), got {v!r}")
    if not (MIN_SIDE <= w <= MAX_SIDE and MIN_SIDE <= h <= MAX_SIDE):
        raise LdbenchError(f"size {w}x{h} out of range: each side must be in [{MIN_SIDE}, {MAX_SIDE}] "
                           f"(SSIM needs at least {MIN_SIDE}x{MIN_SIDE})")
    return w, h


def checked_int(v, name, lo, hi=None):
    """An integer (a bool or a float is not one, even 2.0) in [lo, hi]."""
    if not _is_int(v):
        raise LdbenchError(f"{name} must be an integer, got {v!r}")
    if v < lo:
        raise LdbenchError(f"{name} must be >= {lo}, got {v}")
    if hi is not None and v > hi:
        raise LdbenchError(f"{name} must be <= {hi}, got {v}")
    return v


def _str(v, name):
    if not isinstance(v, str):
        raise LdbenchError(f"{name} must be a string, got {v!r}")
    return v


def _names(v, name) -> list:
    """A string or a list of strings (effect, methods)."""
    vs = _listify(v)
    if not vs or not all(isinstance(x, str) for x in vs):
        raise LdbenchError(f"{name} must be a string or a list of strings, got {v!r}")
    return vs


def check_budget(width: int, height: int, spp: int, effect=None) -> None:
    """Refuse, before any work, a reference of more than :data:`MAX_REFERENCE_SAMPLES` samples and an image
    this machine's memory cannot hold (:data:`ldbench.core.gpu.HOST_BYTES_PER_PIXEL`, measured, against
    ``MemAvailable``), with the inputs ``effect`` builds for that size (its spec's ``input_bytes``: the rays of
    ``rays_per_pixel`` for every pixel, the VPLs of an RSM). Every command checks the sizes it accepts here,
    from a flag or from a file; the GPU's own limits are checked when its context exists
    (:meth:`ldbench.core.gpu.Gpu.check_image_size`)."""
    if width * height * spp > MAX_REFERENCE_SAMPLES:
        raise LdbenchError(f"a {width}x{height} reference at spp {spp} is {width * height * spp:.3g} samples, "
                           f"more than the limit of 2^40 ({MAX_REFERENCE_SAMPLES:.3g}); lower --spp or --size")
    inputs = effect.spec.input_bytes(effect.params, width, height) if effect is not None else 0
    need, host = width * height * gpu.HOST_BYTES_PER_PIXEL + inputs, gpu.host_available_bytes()
    if host is not None and need > host:
        what = f" with the inputs of {effect.text()} ({inputs / 2**30:.1f} GiB)" if inputs else ""
        raise LdbenchError(f"size {width}x{height}{what} needs about {need / 2**30:.1f} GiB of memory, this machine "
                           f"has {host / 2**30:.1f} GiB available; lower --size"
                           + (" or the effect's parameters" if inputs else ""))


def resolve_sizes(jobs: list, scenes: dict) -> list:
    """Jobs with no size (none in the suite or on the command line) take their scene's film size
    (``scene.params['film']``, Mitsuba XML scenes), else the default size
    (:func:`ldbench.harness.defaults.image_size`). ``scenes`` maps ``job.scene_key`` to the loaded scene."""
    out = []
    for j in jobs:
        if j.width is None or j.height is None:
            size = defaults.image_size(scenes[j.scene_key]) if j.scene_key in scenes else defaults.SIZE
            w, h = parse_size(list(size))
            check_budget(w, h, j.spp, j.effect)
            j = dataclasses.replace(j, width=w, height=h)
        out.append(j)
    return out


def override(suite: "Suite", *, size=None, spp=None, warmup=None, frames=None, job_timeout=None) -> "Suite":
    """``suite`` with the command line's --size/--spp/--warmup/--frames/--job-timeout (None = keep), validated
    as strictly as the suite file's own values."""
    wh = parse_size(size) if size is not None else None
    spp = None if spp is None else checked_int(spp, "spp", 1, MAX_SPP)
    warmup = None if warmup is None else checked_int(warmup, "warmup", 0, MAX_WARMUP)
    frames = None if frames is None else checked_int(frames, "frames", 1, MAX_FRAMES)
    jobs = []
    for j in suite.jobs:
        j = dataclasses.replace(
            j, width=wh[0] if wh else j.width, height=wh[1] if wh else j.height,
            spp=j.spp if spp is None else spp, warmup=j.warmup if warmup is None else warmup,
            frames=j.frames if frames is None else frames)
        if j.width is not None:
            check_budget(j.width, j.height, j.spp, j.effect)
        jobs.append(j)
    suite.jobs = jobs
    if job_timeout is not None:
        suite.job_timeout = checked_timeout(job_timeout, "--job-timeout")
    return suite


def _listify(v):
    return list(v) if isinstance(v, list) else [v]


def _grid(d: dict) -> list[dict]:
    """Cartesian product over every list value of ``d``."""
    keys = sorted(d)
    return [dict(zip(keys, combo)) for combo in itertools.product(*(_listify(d[k]) for k in keys))]


def _dotted(d: dict, prefix: str = "") -> dict:
    """Nested tables (TOML's ``structure.source = ...``) as flat dotted names (``structure.source``)."""
    out = {}
    for k, v in d.items():
        if isinstance(v, dict):
            out.update(_dotted(v, f"{prefix}{k}."))
        else:
            out[f"{prefix}{k}"] = v
    return out


def _frozen(d: dict) -> tuple:
    """Sorted (key, value) pairs with lists turned into tuples, so jobs are hashable."""
    return tuple(sorted((k, tuple(v) if isinstance(v, list) else v) for k, v in d.items()))


def float_or_inf(v):
    if isinstance(v, str) and v.lower() in ("inf", "infinity", "unbounded"):
        return math.inf
    return v


def expand_run(run: dict, suite_values: dict, base_dir: Path | None = None) -> list[Job]:
    """Validate one ``[[run]]`` table and expand it into jobs; ``suite_values``: the ``[suite]`` table's size,
    spp, warmup and frames (the defaults where it gives none), which the run's own values override."""
    unknown = set(run) - RUN_KEYS
    if unknown:
        raise LdbenchError(f"unknown key {sorted(unknown)[0]!r} in a [[run]] table")
    if "scene" not in run:
        raise LdbenchError("a [[run]] table needs a 'scene'")
    if "effect" not in run:
        raise LdbenchError("a [[run]] table needs an 'effect'")
    scene = _str(run["scene"], "scene")
    if base_dir is not None and scene.endswith((".xml", ".ply", ".obj")) and not Path(scene).is_absolute():
        scene = str((base_dir / scene).resolve()) if (base_dir / scene).exists() else scene
    size = run.get("size", suite_values["size"])
    w, h = parse_size(size) if size is not None else (None, None)  # None: the scene's (resolve_sizes)
    spp = checked_int(run.get("spp", suite_values["spp"]), "spp", 1, MAX_SPP)
    if w is not None and h is not None:  # both or neither
        check_budget(w, h, spp)
    warmup = checked_int(run.get("warmup", suite_values["warmup"]), "warmup", 0, MAX_WARMUP)
    frames = checked_int(run.get("frames", suite_values["frames"]), "frames", 1, MAX_FRAMES)
    scene_params = run.get("scene_params", {}) or {}
    if not isinstance(scene_params, dict):
        raise LdbenchError("scene_params must be a table")

    reg = registry()
    effects = []
    effect_params = run.get("effect_params", {}) or {}
    if not isinstance(effect_params, dict):
        raise LdbenchError("effect_params must be a table")
    top = {k: run[k] for k in ("d_max", "falloff") if k in run}
    both = set(top) & set(effect_params)
    if both:
        raise LdbenchError(f"effect parameter {sorted(both)[0]!r} given twice (top level and effect_params)")
    opts = {**top, **effect_params}
    for name in _names(run["effect"], "effect"):
        effects += effects_from_user(name, [{k: float_or_inf(v) for k, v in combo.items()}
                                            for combo in (_grid(opts) if opts else [{}])])
    if w is not None and h is not None:
        for e in effects:  # the inputs of each (rays per pixel, RSM size) with the image's own
            check_budget(w, h, spp, e)
    seed = checked_int(run.get("seed", defaults.SEED), "seed", 0, MAX_SEED)
    test = run.get("test")
    if test is not None and test != "unbiased":
        raise LdbenchError(f"test must be \"unbiased\", got {test!r}")

    methods = run.get("methods", "all")
    if methods != "all":
        _names(methods, "methods")
    params = run.get("params", {}) or {}
    if not isinstance(params, dict) or not all(isinstance(v, dict) for v in params.values()):
        raise LdbenchError("params must be a table of tables ([run.params.METHOD])")

    if methods != "all":
        methods = [canonical_name(m) for m in _listify(methods)]
    params = {canonical_name(m): v for m, v in params.items()}
    reg = registry()  # again: a package.module:Class name has just been registered
    for m in params:
        if m not in reg:
            raise LdbenchError(f"unknown method {m!r} in params (known: {', '.join(reg)})")
    used = set()
    jobs = []
    for eff in effects:
        if methods == "all":
            names = [n for n, cls in reg.items() if eff.name in cls.effects and getattr(cls, "in_all", True)]
            if not names:
                raise LdbenchError(f"no registered method supports effect {eff.name!r}")
        else:
            names = _listify(methods)
        used.update(names)
        for m in names:
            if m not in reg:
                raise LdbenchError(f"unknown method {m!r} (known: {', '.join(reg)})")
            cls = reg[m]
            if eff.name not in cls.effects:
                raise LdbenchError(f"method {m!r} does not support effect {eff.name!r} "
                                   f"(it supports: {', '.join(sorted(cls.effects))})")
            if test is not None and not getattr(cls, "unbiased", False):
                raise LdbenchError(f"test = {test!r}: method {m!r} does not declare itself unbiased (no variance "
                                   "of its image); list only unbiased methods in this [[run]]")
            for p in _grid(_dotted(params.get(m, {}))):
                method_params(cls, p, m)  # validate now, before any rendering
                jobs.append(Job(scene, _frozen(scene_params), m, tuple(sorted(p.items())),
                                eff, w, h, spp, warmup, frames, seed, test))
    for m in params:
        if m not in used:  # as on the command line (--set): parameters nothing uses are a mistake
            raise LdbenchError(f"params for method {m!r}, which this [[run]] does not run "
                               f"(it runs: {', '.join(sorted(used))})")
    return jobs


def load_suite(path) -> Suite:
    """Read and validate a suite TOML file: a path, or a bundled suite by name (``default``)."""
    path = suite_path(path)
    if not path.exists():  # neither a file nor a bundled suite: say which names would work
        raise LdbenchError(f"no suite file {str(path)!r} and no bundled suite of that name "
                           f"(bundled: {', '.join(bundled_suites())})")
    try:
        data = tomllib.loads(path.read_bytes().decode("utf-8"))  # TOML is UTF-8, whatever the locale
    except OSError as e:
        raise LdbenchError(f"cannot read suite {path}: {e.strerror}")
    except UnicodeDecodeError as e:
        raise LdbenchError(f"suite {path} is not UTF-8 text (TOML): byte {e.start} cannot be decoded")
    except tomllib.TOMLDecodeError as e:
        raise LdbenchError(f"malformed TOML in {path}: {e}")
    return suite_from_dict(data, name=path.stem, base_dir=path.parent, source=str(path))


def suite_from_dict(data: dict, *, name: str, base_dir: Path | None = None, source: str = "") -> Suite:
    head = data.get("suite", {})
    unknown = set(head) - SUITE_KEYS
    if unknown:
        raise LdbenchError(f"unknown key {sorted(unknown)[0]!r} in [suite]")
    extra = set(data) - {"suite", "run"}
    if extra:
        raise LdbenchError(f"unknown table {sorted(extra)[0]!r} in suite (expected [suite] and [[run]])")
    for k in ("name", "description"):
        if k in head:
            _str(head[k], k)
    suite_values = {"size": head.get("size"), "spp": head.get("spp", defaults.SPP),
                    "warmup": head.get("warmup", defaults.WARMUP), "frames": head.get("frames", defaults.FRAMES)}
    runs = data.get("run", [])
    if not runs:
        raise LdbenchError("the suite has no [[run]] tables")
    jobs = [j for r in runs for j in expand_run(r, suite_values, base_dir)]
    timeout = checked_timeout(head.get("job_timeout", defaults.JOB_TIMEOUT), "job_timeout")
    return Suite(name=head.get("name", name), jobs=jobs, source=source, job_timeout=timeout)


def checked_timeout(v, name: str) -> float:
    """A time limit in seconds: a finite number ≥ 0 (0 = none)."""
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v < 0:
        raise LdbenchError(f"{name} must be a number of seconds ≥ 0 (0: no limit), got {v!r}")
    return float(v)
