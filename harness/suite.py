"""Benchmark suites: TOML files (or command-line flags) expanded into a list of validated jobs.

A suite file::

    [suite]
    name = "default"
    size = "128x128"        # default image size, "WxH" or [W, H]
    spp = 256               # reference samples per pixel
    warmup = 2              # warm-up frames
    frames = 5              # measured frames

    [[run]]
    scene = "cornell"               # built-in name, XML path or mesh path (relative to the suite file)
    scene_params = { }              # builder parameters
    effect = "ao"                   # one effect, or a list
    d_max = [0.5, inf]              # ao parameters; a list is a sweep
    falloff = "step"
    methods = "all"                 # "all" = every registered method supporting the effect, or a list
    size = "64x64"                  # optional overrides of [suite] values
    [run.params.ldm-ao]             # method parameters; a list is a sweep (grid over all lists)
    directions = [32, 64, 128]

Every job is validated (scene builder parameters, method names, effect support, method parameters)
before anything is rendered, so bad input fails before a run directory exists.
"""
from __future__ import annotations

import itertools
import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

from .effects import Effect
from .errors import LdbenchError

SUITE_KEYS = {"name", "size", "spp", "warmup", "frames", "description"}
RUN_KEYS = {"scene", "scene_params", "effect", "d_max", "falloff", "methods", "params", "size", "spp",
            "warmup", "frames"}


@dataclass(frozen=True)
class Job:
    scene: str
    scene_params: tuple  # sorted (key, value) pairs
    method: str
    params: tuple  # sorted (key, value) pairs of the method's parameters as given (not defaults)
    effect: Effect
    width: int
    height: int
    spp: int
    warmup: int
    frames: int

    @property
    def scene_key(self):
        return (self.scene, self.scene_params)


@dataclass
class Suite:
    name: str
    jobs: list = field(default_factory=list)
    source: str = ""


def parse_size(v) -> tuple[int, int]:
    try:
        if isinstance(v, str):
            w, h = v.lower().split("x")
            w, h = int(w), int(h)
        else:
            w, h = (int(x) for x in v)
    except (ValueError, TypeError):
        raise LdbenchError(f"size must be WxH (e.g. 256x256), got {v!r}")
    if not (1 <= w <= 16384 and 1 <= h <= 16384):
        raise LdbenchError(f"size {w}x{h} out of range")
    return w, h


def _int(v, name, lo):
    if isinstance(v, bool) or not isinstance(v, (int, float, str)):
        raise LdbenchError(f"{name} must be an integer, got {v!r}")
    try:
        i = int(v)
    except ValueError:
        raise LdbenchError(f"{name} must be an integer, got {v!r}")
    if i < lo:
        raise LdbenchError(f"{name} must be >= {lo}, got {i}")
    return i


def _listify(v):
    return list(v) if isinstance(v, list) else [v]


def _grid(d: dict) -> list[dict]:
    """Cartesian product over every list value of ``d``."""
    keys = sorted(d)
    return [dict(zip(keys, combo)) for combo in itertools.product(*(_listify(d[k]) for k in keys))]


def _frozen(d: dict) -> tuple:
    """Sorted (key, value) pairs with lists turned into tuples, so jobs are hashable."""
    return tuple(sorted((k, tuple(v) if isinstance(v, list) else v) for k, v in d.items()))


def _float_or_inf(v):
    if isinstance(v, str) and v.lower() in ("inf", "infinity", "unbounded"):
        return math.inf
    return v


def expand_run(run: dict, defaults: dict, base_dir: Path | None = None) -> list[Job]:
    """Validate one ``[[run]]`` table and expand it into jobs."""
    from methods.base import registry

    unknown = set(run) - RUN_KEYS
    if unknown:
        raise LdbenchError(f"unknown key {sorted(unknown)[0]!r} in a [[run]] table")
    if "scene" not in run:
        raise LdbenchError("a [[run]] table needs a 'scene'")
    if "effect" not in run:
        raise LdbenchError("a [[run]] table needs an 'effect'")
    scene = str(run["scene"])
    if base_dir is not None and scene.endswith((".xml", ".ply", ".obj")) and not Path(scene).is_absolute():
        scene = str((base_dir / scene).resolve()) if (base_dir / scene).exists() else scene
    w, h = parse_size(run.get("size", defaults["size"]))
    spp = _int(run.get("spp", defaults["spp"]), "spp", 1)
    warmup = _int(run.get("warmup", defaults["warmup"]), "warmup", 0)
    frames = _int(run.get("frames", defaults["frames"]), "frames", 1)
    scene_params = run.get("scene_params", {}) or {}
    if not isinstance(scene_params, dict):
        raise LdbenchError("scene_params must be a table")

    reg = registry()
    effects = []
    for name in _listify(run["effect"]):
        opts = {k: run[k] for k in ("d_max", "falloff") if k in run}
        if name != "ao" and opts:
            raise LdbenchError(f"effect {name!r} takes no d_max/falloff")
        for combo in _grid(opts) if opts else [{}]:
            combo = {k: _float_or_inf(v) for k, v in combo.items()}
            effects.append(Effect.parse(name, combo))

    methods = run.get("methods", "all")
    params = run.get("params", {}) or {}
    for m in params:
        if m not in reg:
            raise LdbenchError(f"unknown method {m!r} in params (known: {', '.join(reg)})")
    jobs = []
    for eff in effects:
        if methods == "all":
            names = [n for n, cls in reg.items() if eff.name in cls.effects]
            if not names:
                raise LdbenchError(f"no registered method supports effect {eff.name!r}")
        else:
            names = _listify(methods)
        for m in names:
            if m not in reg:
                raise LdbenchError(f"unknown method {m!r} (known: {', '.join(reg)})")
            cls = reg[m]
            if eff.name not in cls.effects:
                raise LdbenchError(f"method {m!r} does not support effect {eff.name!r} "
                                   f"(it supports: {', '.join(sorted(cls.effects))})")
            for p in _grid(params.get(m, {})):
                cls.Params.from_dict(p, method=m)  # validate now, before any rendering
                jobs.append(Job(scene, _frozen(scene_params), m, tuple(sorted(p.items())),
                                eff, w, h, spp, warmup, frames))
    return jobs


def load_suite(path) -> Suite:
    """Read and validate a suite TOML file."""
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text())
    except OSError as e:
        raise LdbenchError(f"cannot read suite {path}: {e.strerror}")
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
    defaults = {"size": head.get("size", "128x128"), "spp": head.get("spp", 256),
                "warmup": head.get("warmup", 2), "frames": head.get("frames", 5)}
    runs = data.get("run", [])
    if not runs:
        raise LdbenchError("the suite has no [[run]] tables")
    jobs = [j for r in runs for j in expand_run(r, defaults, base_dir)]
    return Suite(name=str(head.get("name", name)), jobs=jobs, source=source)
