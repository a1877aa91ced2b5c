"""The ``ldbench`` command line (docs/design.md, "Command line"; exit codes in docs/reference/cli.md).

Every user error is an :class:`~ldbench.core.errors.LdbenchError`: one line on stderr, exit status 2, no
traceback. Sub-commands are registered in :data:`COMMANDS` (name → (add_arguments, handler)).
Progress and information go through :mod:`logging` to stderr (``-v`` adds debug messages, ``-q``
keeps only warnings and errors, ``-qq`` only errors); what a command answers (tables, listings,
summaries, the files it wrote) is printed on stdout.
"""
from __future__ import annotations

import argparse
import ast
import dataclasses
import errno
import logging
import sys
import time
from pathlib import Path

from ldbench.core.effects import EFFECTS
from ldbench.core.effects.base import effects_from_user
from ldbench.core.errors import LdbenchError
from ldbench.core.files import TEMP_EXTRA, check_output_path, check_replaceable
from ldbench.core.plugins import ldbench_info

from . import defaults
from .resources import bundled_suites

# Start-up: each subcommand's handler imports the modules it runs (the runner, the references, the scenes, the report,
# compare, ...), so `ldbench --help` and a short command load only their own part; importing them all here would add
# about 0.12 s to a 0.17 s start (2 cores). What the parser itself needs is imported here.

#: The package's logger tree, ``ldbench``: every layer's loggers (``ldbench.core.gpu``, ``ldbench.references...``),
#: not only this sub-package's; from ``__package__`` also under ``python -m ldbench.harness.cli`` (``__name__`` is
#: then ``"__main__"``, whose logger would not be the parent of the other modules' loggers).
_LOG_ROOT = (__package__ or __name__).split(".")[0]
log = logging.getLogger(f"{__package__ or _LOG_ROOT + '.harness'}.cli")


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # argparse's own errors: one line, exit 2
        raise LdbenchError(message)


# ---- scenes / methods -----------------------------------------------------------------------------
def _scenes_args(p):
    p.add_argument("action", nargs="?", default="list", choices=("list", "fetch"),
                   help="list (default) | fetch: put registered real scenes into the scene cache")
    p.add_argument("names", nargs="*", metavar="NAME", help="fetch: registered scene names, or 'all'")
    p.add_argument("--from", dest="source", metavar="MIRROR",
                   help="fetch: copy from a local mirror (one folder per scene) instead of downloading")


def _scenes(args):
    from ldbench.core import scene_registry
    from ldbench.core.scenes import list_scenes

    reg = scene_registry.registry()
    if args.action == "fetch":
        if not args.names:
            raise LdbenchError(f"ldbench scenes fetch needs scene names or 'all' (registered: {', '.join(reg)})")
        names = list(reg) if "all" in args.names else args.names
        for n in names:
            scene_registry.get(n)  # every name checked before anything is fetched
        for n in names:
            scene_registry.fetch(n, source=args.source)
        return 0
    if args.names or args.source:
        raise LdbenchError("ldbench scenes lists scenes; to fetch: ldbench scenes fetch NAME|all [--from MIRROR]")
    print("built-in:")
    for s in list_scenes():
        params = ", ".join(f"{k}={v!r}" for k, v in s.get("parameters", {}).items())
        print(f"  {s['name']:<17} {s.get('description', '')}")
        if params:
            print(f"  {'':<17} parameters: {params}")
    root = scene_registry.scenes_dir()
    print(f"registered real scenes (cache {root}; LDBENCH_SCENES sets it):")
    for name, e in reg.items():
        print(f"  {name:<17} {scene_registry.status(e, root):<12} {e.triangles:>7,} triangles  {e.title}")
    print("Fetch with: ldbench scenes fetch NAME|all [--from MIRROR]. Any Mitsuba 3 XML file path, or a "
          ".ply/.obj mesh path (mesh-in-a-box), is also a scene.")
    return 0


def _methods_args(p):
    p.add_argument("name", nargs="?", default=None,
                   help="one method (or an alias): its parameters as a Markdown table (docs/reference/parameters.md "
                        "holds every method's); without it, every method in one line each")


def _methods(args):
    from ldbench.core.paramdoc import markdown
    from ldbench.methods.base import canonical_name, registry

    reg = registry()
    if args.name is None:
        for name, cls in reg.items():
            also = f" (also: {', '.join(cls.aliases)})" if cls.aliases else ""
            print(f"{name}{also}  [{cls.paper}]  effects: {', '.join(sorted(cls.effects))}")
        return 0
    name = canonical_name(args.name)
    if name not in reg:
        raise LdbenchError(f"unknown method {args.name!r} (known: {', '.join(reg)})")
    cls = reg[name]
    also = f" (also: {', '.join(cls.aliases)})" if cls.aliases else ""
    print(f"{name}{also}  [{cls.paper}]  effects: {', '.join(sorted(cls.effects))}")
    print(markdown(cls.Params) or "(no parameters)")
    return 0


# ---- reference -------------------------------------------------------------------------------------
# Effect parameters with flags of their own; any other one: --effect-set NAME=VALUE.
EFFECT_FLAGS = (("d_max", "--d-max", "ao, rays (kind ao): maximum distance (world units, or 'inf'; default inf)"),
                ("falloff", "--falloff", "ao: step | quadratic"),
                ("ray_kind", "--ray-kind", "rays: diffuse | glossy | shadow | ao"),
                ("rays_per_pixel", "--rays-per-pixel", "rays: rays per hit pixel"))


#: what `run` adds to --d-max's help: its ad-hoc AO run picks a finite d_max (unbounded AO blackens enclosed scenes)
RUN_D_MAX = ("ao, rays (kind ao): maximum distance (world units, or 'inf'); without it, `run --effect ao` takes "
             "the scene's registered d_max, else 5%% of the scene's largest bounding-box extent (a warning on stderr "
             "says which)")


def _effect_args(p, required=True, d_max_help=None):
    p.add_argument("--effect", required=required, help="the effect to compute: " + " | ".join(EFFECTS))
    for name, flag, helptext in EFFECT_FLAGS:
        p.add_argument(flag, default=None, help=d_max_help if name == "d_max" and d_max_help else helptext)
    p.add_argument("--effect-set", action="append", metavar="PARAM=VALUE",
                   help="effect parameter (e.g. exponent=64, light_radius=0.2)")


def _effect_opts(args) -> dict:
    """Effect parameters given on the command line (flags and --effect-set)."""
    from .suite import float_or_inf

    opts = {}
    for name, flag, _ in EFFECT_FLAGS:
        v = getattr(args, name)
        if v is not None:
            opts[name] = float_or_inf(_literal(v))
    for kv in args.effect_set or []:
        if "=" not in kv:
            raise LdbenchError(f"--effect-set expects PARAM=VALUE, got {kv!r}")
        k, v = kv.split("=", 1)
        if k in opts:
            raise LdbenchError(f"effect parameter {k!r} given twice")
        opts[k] = float_or_inf(_literal(v))
    return opts


def _effect_from(args):
    return effects_from_user(args.effect, [_effect_opts(args)])[0]


def _scene_params(pairs):
    out = {}
    for kv in pairs or []:
        if "=" not in kv:
            raise LdbenchError(f"--scene-set expects key=value, got {kv!r}")
        k, v = kv.split("=", 1)
        out[k] = _literal(v)
    return out


def _literal(v: str):
    if v.lower() in ("inf", "infinity"):
        return float("inf")
    if v.lower() in ("true", "false"):
        return v.lower() == "true"
    try:
        return ast.literal_eval(v)
    except (ValueError, SyntaxError):
        return v


#: --size of reference, export and score: their default is run's (ldbench/harness/defaults.py)
_SIZE_HELP = (f"image size WxH (default: a Mitsuba XML scene's film, else {defaults.SIZE[0]}x{defaults.SIZE[1]}, "
              "as run's)")


def _reference_args(p):
    p.add_argument("--scene", help="built-in or registered scene name (ldbench scenes), a Mitsuba 3 .xml file, "
                                   "or a .ply/.obj mesh")
    p.add_argument("scene_arg", nargs="?", metavar="SCENE", help="the scene as a positional argument: deprecated, "
                   "use --scene as run and export do")
    _effect_args(p)
    p.add_argument("--spp", type=int, default=None, help=f"samples per pixel (default {defaults.SPP}, as run's)")
    p.add_argument("--size", default=None, metavar="WxH", help=_SIZE_HELP)
    p.add_argument("--scene-set", action="append", metavar="KEY=VALUE",
                   help="scene builder parameter (repeatable)")
    p.add_argument("--out", default=None, metavar="FILE.exr",
                   help="also write the mean as this EXR file (only this file: no preview beside it)")
    p.add_argument("--no-cache", action="store_true",
                   help="render again instead of using (and without storing into) the reference cache")


def _reference(args):
    from ldbench.core.scenes import load_scene
    from .suite import parse_size

    if args.scene_arg is not None:
        if args.scene is not None and args.scene != args.scene_arg:
            raise LdbenchError(f"two scenes given: --scene {args.scene} and {args.scene_arg}")
        log.warning(f"`ldbench reference {args.scene_arg}` is deprecated: write `ldbench reference --scene "
                    f"{args.scene_arg}` (as run and export)")
        args.scene = args.scene_arg
    if args.scene is None:
        raise LdbenchError("reference needs --scene SCENE")

    from .suite import MAX_SPP, checked_int, check_budget
    size = parse_size(args.size) if args.size is not None else None
    spp = checked_int(defaults.SPP if args.spp is None else args.spp, "--spp", 1, MAX_SPP)
    if size is not None:  # checked before the scene is loaded; the default size once it is (a film's)
        check_budget(*size, spp)
    out = _reference_out(args.out)
    effect = _effect_from(args)
    spec = effect.spec
    if spec.output != "image":
        raise LdbenchError(f"ldbench reference writes images; effect {effect.name!r} is answered per "
                           f"{spec.output[:-1]} by its oracle inside `ldbench run`")
    scene = load_scene(args.scene, **_scene_params(args.scene_set))
    for w_ in scene.warnings:
        log.warning(w_)
    effect.check_scene(scene)
    w, h = size if size is not None else parse_size(list(defaults.image_size(scene)))
    check_budget(w, h, spp)
    from ldbench.references import EXACT, render_effect

    seed = defaults.SEED
    ref = render_effect(scene, effect, width=w, height=h, spp=spp, seed=seed,
                        inputs=spec.inputs(scene, w, h, effect.params, seed, exact=EXACT), cache=not args.no_cache)
    m = ref.meta
    took = "cached" if m.get("cached") else f"{m.get('seconds', 0):.2f} s"
    print(f"{scene.name} {effect.label()} {w}x{h} spp={spp} variant={m.get('variant')} {took} "
          f"key={m.get('key')}")
    if out is not None:
        from ldbench.core.exr import write_exr
        from ldbench.core.exr import image_channels
        tag = {REFERENCE_EXR_TAG.decode(): f"{scene.name} {effect.label()}"}  # what makes it ours to replace
        write_exr(out, image_channels(ref.mean), header=tag)
        print(f"wrote {out}")
    return 0


def _reference_out(out):
    """``reference --out``: the one EXR file to write (atomically), checked before rendering. Nothing
    else is written beside it (a preview would replace the user's FILE.png)."""
    if out is None:
        return None

    p = Path(out)
    if p.suffix.lower() != ".exr":
        raise LdbenchError(f"--out {out}: must name an .exr file (the reference's mean, linear float)")
    check_output_path(p, extra=TEMP_EXTRA + len(".exr"))  # write_exr's temporary ends in .exr
    if p.is_dir() or p.is_symlink():
        raise LdbenchError(f"--out {out} is a directory or a symbolic link; give a file name")
    check_replaceable(p, lambda head: REFERENCE_EXR_TAG in head)  # only an EXR `reference --out` wrote
    return p


#: The EXR header attribute ``reference --out`` writes (name and value): the file is ldbench's to replace.
REFERENCE_EXR_TAG = b"ldbench_reference"


# ---- run / report ---------------------------------------------------------------------------------
def _run_args(p):
    p.add_argument("suite", nargs="?", metavar="SUITE",
                   help="suite TOML file, or a bundled suite by name: " + ", ".join(bundled_suites()))
    p.add_argument("--scene", help="instead of a suite: built-in or registered scene name (ldbench scenes), "
                                   "a Mitsuba 3 .xml file or a .ply/.obj mesh")
    p.add_argument("--method", action="append",
                   help="instead of a suite: method adapter (ldbench methods); repeat for several")
    _effect_args(p, required=False, d_max_help=RUN_D_MAX)
    p.add_argument("--save-arrays", action="store_true",
                   help="rays, vpl_range: write each job's per-ray/per-VPL inputs and answers (method and oracle) "
                        "as .npz beside its images (about 60 bytes per ray)")
    p.add_argument("--seed", type=int, default=None, help="seed of the effect's inputs and the reference")
    p.add_argument("--size", default=None, metavar="WxH",
                   help="image size (overrides the suite's; default: the suite's, else an XML scene's film, "
                        f"else {defaults.SIZE[0]}x{defaults.SIZE[1]})")
    p.add_argument("--spp", type=int, default=None,
                   help=f"reference samples per pixel (default: the suite's, {defaults.SPP})")
    p.add_argument("--warmup", type=int, default=None,
                   help=f"frames run before timing starts (default: the suite's, {defaults.WARMUP})")
    p.add_argument("--frames", type=int, default=None,
                   help=f"timed frames per job (default: the suite's, {defaults.FRAMES})")
    p.add_argument("--job-timeout", type=float, default=None, metavar="SECONDS",
                   help="seconds one job may take before it becomes an error row and the run goes on "
                        f"(default: the suite's job_timeout, {defaults.JOB_TIMEOUT:g}; 0: no limit)")
    p.add_argument("--set", action="append", metavar="METHOD.PARAM=VALUE",
                   help="method parameter (repeatable; with a suite it overrides the suite's value)")
    p.add_argument("--scene-set", action="append", metavar="KEY=VALUE",
                   help="scene builder parameter (repeatable)")
    p.add_argument("--out", default=None, help="run directory (default runs/<suite>-<time>)")
    p.add_argument("--no-report", action="store_true", help="write results only, no HTML/Markdown report")
    p.add_argument("--no-progress", action="store_true",
                   help="no progress bar (it is shown only when stderr is a terminal anyway)")
    p.add_argument("--writers", type=_writers_arg, default=None, metavar="N",
                   help="local executor: N writer processes score the jobs and save their images while the next "
                        "jobs render (0: one job after the other; default: half the CPU cores, at most 8, and 0 "
                        "on a CPU renderer such as llvmpipe; docs/reference/cli.md)")
    p.add_argument("--executor", default="local", choices=("local", "ray"),
                   help="local: this process (default); ray: one task per job group on a Ray cluster "
                        "(pip install 'ldbench[ray]'; docs/how-to/run-on-ray.md)")
    p.add_argument("--address", default=None,
                   help="ray: the cluster to join (auto, HOST:6379, ray://HOST:10001); default: start a local one")
    p.add_argument("--retries", type=int, default=None,
                   help="ray: times a failed task is run again (default 1)")


def _writers_arg(text: str) -> int:
    """``--writers N``: an integer in [0, MAX_WRITERS] (ldbench/harness/writers.py)."""
    from .writers import MAX_WRITERS

    try:
        n = int(text)
    except ValueError:
        n = -1
    if not 0 <= n <= MAX_WRITERS:
        raise LdbenchError(f"--writers must be an integer in [0, {MAX_WRITERS}], got {text!r}")
    return n


def _executor_from(args):
    """The executor of ``ldbench run``: local (with --writers), or Ray with --address/--retries; either with
    --save-arrays."""
    from .executors import get_executor

    if args.executor == "local":
        if args.address is not None or args.retries is not None:
            raise LdbenchError("--address and --retries go with --executor ray")
        ex = get_executor("local", writers=args.writers)
    else:
        opts = {"address": args.address, "writers": args.writers}
        if args.retries is not None:
            opts["retries"] = args.retries
        ex = get_executor("ray", **opts)
    ex.save_arrays = bool(getattr(args, "save_arrays", False))  # run_jobs hands it to every job
    return ex


def _method_sets(pairs) -> dict:
    """``--set METHOD.PARAM=VALUE`` flags as {method: {param: value}}."""
    params: dict = {}
    for kv in pairs or []:
        if "=" not in kv or "." not in kv.split("=", 1)[0]:
            raise LdbenchError(f"--set expects METHOD.PARAM=VALUE, got {kv!r}")
        k, v = kv.split("=", 1)
        m, p = k.split(".", 1)
        from ldbench.methods.base import canonical_name
        params.setdefault(canonical_name(m), {})[p] = _literal(v)
    return params


def suite_from_args(args):
    """A suite from a TOML file, or from --scene/--method/--effect flags (flags override the file)."""
    from .suite import load_suite, suite_from_dict

    if args.suite and (args.scene or args.method or args.effect):
        raise LdbenchError("give either a suite file or --scene/--method/--effect, not both")
    if args.suite and (_effect_opts(args) or args.seed is not None):
        raise LdbenchError("effect parameters and --seed go with --scene/--method/--effect; a suite file sets "
                           "them in its [[run]] tables")
    # --set with a suite overrides parameters (e.g. a deliberately degraded nightly run)
    params = _method_sets(args.set)
    if args.suite:
        suite = load_suite(args.suite)
        if params:  # --set overrides a method's parameters in every job of the suite that runs it
            from ldbench.methods.base import get_method
            for m, ps in params.items():
                if not any(j.method == m for j in suite.jobs):
                    raise LdbenchError(f"--set names method {m!r}, which this suite does not run")
            jobs = []
            for j in suite.jobs:
                if j.method in params:
                    cls = get_method(j.method)
                    P = cls.Params
                    try:  # --set overrides the suite's parameter of the same name
                        merged = P.upgrade({**dict(j.params), **params[j.method]})
                    except LdbenchError:  # the suite names it one way (build), --set the other (structure.source)
                        merged = {**P.upgrade(dict(j.params)), **P.upgrade(params[j.method])}
                    from .suite import method_params
                    method_params(cls, merged, j.method)
                    j = dataclasses.replace(j, params=tuple(sorted(merged.items())))
                jobs.append(j)
            suite.jobs = jobs
        from .suite import override  # --size/--spp/--warmup/--frames, validated like the file's values
        return override(suite, size=args.size, spp=args.spp, warmup=args.warmup, frames=args.frames,
                        job_timeout=args.job_timeout)
    if not (args.scene and args.method and args.effect):
        raise LdbenchError("ldbench run needs a suite file, or --scene, --method and --effect")
    from ldbench.methods.base import canonical_name
    for m in params:
        if m not in {canonical_name(x) for x in args.method}:
            raise LdbenchError(f"--set names method {m!r}, which is not in --method")
    run = {"scene": args.scene, "effect": args.effect, "methods": args.method, "params": params,
           "scene_params": _scene_params(args.scene_set), "effect_params": _effect_opts(args)}
    if args.effect == "ao" and "d_max" not in run["effect_params"]:  # unbounded AO blackens enclosed scenes
        from ldbench.core.scenes import default_d_max
        d, why = default_d_max(args.scene, **run["scene_params"])
        run["effect_params"]["d_max"] = d
    else:
        why = None
    if args.seed is not None:
        run["seed"] = args.seed
    head = {"name": "adhoc"}
    for k in ("size", "spp", "warmup", "frames", "job_timeout"):
        if getattr(args, k) is not None:
            head[k] = getattr(args, k)
    suite = suite_from_dict({"suite": head, "run": [run]}, name="adhoc")
    # said as a warning once the run has gone through (bad input stays one line; -q keeps it, -qq not)
    args.d_max_notice = f"ao without --d-max: d_max = {d:g} ({why})" if why else None
    return suite


def _run(args):
    from .executors import run_jobs

    suite = suite_from_args(args)
    executor = _executor_from(args)
    from .naming import slug  # a suite named "../../x" stays inside runs/
    out = Path(args.out) if args.out else Path("runs") / f"{slug(suite.name)}-{time.strftime('%Y%m%d-%H%M%S')}"
    df = run_jobs(suite, out, progress=not args.no_progress, report=not args.no_report, executor=executor)
    if getattr(args, "d_max_notice", None):
        log.warning(args.d_max_notice)
    from ldbench.reports.report import terminal_table
    print(terminal_table(df))
    print(f"wrote {out}")
    return 1 if (df["status"] != "ok").any() else 0


def _report_args(p):
    p.add_argument("run_dir", help="run directory (written by ldbench run) whose report to rebuild")


def _report(args):
    from ldbench.reports.report import build_report

    d = Path(args.run_dir)
    if not (d / "results.parquet").exists():
        raise LdbenchError(f"{d} is not a run directory (no results.parquet)")
    res = build_report(d)
    print(f"wrote {res['index']}")
    if res["damaged"]:  # each named in a warning above; the report is written without their grids
        raise LdbenchError(f"{len(res['damaged'])} image file(s) of {d} cannot be read (listed above); the report "
                           "leaves their grids out: run the jobs again")
    return 0


# ---- compare / history (ldbench/harness/compare/, ldbench/harness/history.py; imported when used) ---------------
def _compare_args(p):
    from .compare.arguments import add_arguments
    add_arguments(p)


def _compare(args):
    from .compare.command import run_cli
    return run_cli(args)


def _history_args(p):
    from .history import add_arguments
    add_arguments(p)


def _history(args):
    if args.history_command == "add":
        from .history import run_add
        return run_add(args)
    from ldbench.reports.history_plots import run_plot
    return run_plot(args)


# ---- reproduce (ldbench/reports/reproduce.py) --------------------------------------------------------------
def _reproduce_args(p):
    p.add_argument("table", nargs="?", help="registry key, e.g. aalund2015-fig8 (see --list)")
    p.add_argument("--list", action="store_true", help="list the reproducible tables and figures")
    p.add_argument("--scale", default="paper", help="paper (the suite as written) | ci (tiny, for llvmpipe)")
    p.add_argument("--size", default=None, help="WxH, overrides the scale's image size")
    p.add_argument("--out", default=None, help="run directory (default runs/<table>-<scale>-<time>)")
    p.add_argument("--from-run", default=None, metavar="RUN_DIR", help="reuse an existing run directory")
    p.add_argument("--no-report", action="store_true", help="write results only, no HTML/Markdown report")
    p.add_argument("--no-progress", action="store_true",
                   help="no progress bar (it is shown only when stderr is a terminal anyway)")


def _reproduce(args):
    from ldbench.reports.reproduce import main_cli

    return main_cli(args)


# ---- score / export (ldbench/harness/score.py, ldbench/harness/export.py) -------------------------------------------
def _pairs(values, flag, convert=str) -> dict:
    out = {}
    for kv in values or []:
        if "=" not in kv:
            raise LdbenchError(f"{flag} expects NAME=VALUE, got {kv!r}")
        k, v = kv.split("=", 1)
        try:
            out[k] = convert(v)
        except ValueError:
            raise LdbenchError(f"{flag} {kv!r}: {v!r} is not valid") from None
    return out


def _question_args(p, required=True):
    p.add_argument("--scene", required=required, help="scene name, Mitsuba XML or mesh path")
    p.add_argument("--scene-set", action="append", metavar="KEY=VALUE", help="scene builder parameter")
    _effect_args(p, required=required)
    p.add_argument("--size", default=None, metavar="WxH", help=_SIZE_HELP)
    p.add_argument("--spp", type=int, default=None,
                   help=f"reference samples per pixel (default {defaults.SPP}, as run's)")
    p.add_argument("--seed", type=int, default=None,
                   help=f"seed of the effect's inputs and the reference (default {defaults.SEED})")


def _question_from(args):
    from .score import Question
    from .suite import MAX_SEED, MAX_SPP, check_budget, checked_int, parse_size

    scene_params = _scene_params(args.scene_set)
    spp = checked_int(defaults.SPP if args.spp is None else args.spp, "--spp", 1, MAX_SPP)
    if args.size is not None:
        w, h = parse_size(args.size)
    else:  # run's rule: the scene's film (a Mitsuba XML scene), else the default size
        from ldbench.core.scenes import load_scene

        w, h = parse_size(list(defaults.image_size(load_scene(args.scene, **scene_params))))
    effect = _effect_from(args)
    check_budget(w, h, spp, effect)  # with the effect's inputs (rays per pixel, RSM) before any work
    seed = checked_int(defaults.SEED if args.seed is None else args.seed, "--seed", 0, MAX_SEED)
    return Question(scene=args.scene, effect=effect, width=w, height=h, spp=spp, seed=seed,
                    scene_params=scene_params)


def _score_args(p):
    p.add_argument("run_dir", help="run directory the rows join (created when missing)")
    p.add_argument("--from", dest="folder", metavar="FOLDER",
                   help="every folder under FOLDER with question.json + answer.* (docs/reference/adapters.md, 'Benchmarking "
                        "a method that runs elsewhere')")
    p.add_argument("--answer", metavar="FILE", help="one answer: image (.exr, .png) or per-ray/per-VPL file "
                   "(.npy, .npz, .csv)")
    _question_args(p, required=False)
    p.add_argument("--method", default="external", help="name of the method that answered (default external)")
    p.add_argument("--set", action="append", metavar="PARAM=VALUE", help="a parameter of that method (recorded)")
    p.add_argument("--paper", default="", help="the method's paper key (recorded)")
    p.add_argument("--method-version", default=None, help="the method's version (recorded)")
    p.add_argument("--method-commit", default=None, help="the method's commit (recorded)")
    p.add_argument("--mask", default=None, help="pixels that have a value (PNG/EXR/.npy, nonzero = yes)")
    p.add_argument("--transfer", default=None, choices=("srgb", "linear"), help="a PNG answer's transfer curve")
    p.add_argument("--png-scale", default="1", help="the linear value of a PNG's white (default 1)")
    p.add_argument("--stage-ms", action="append", metavar="STAGE=MS[,MS...]",
                   help="a stage's time per frame as measured by the user (recorded as timing_source=user)")
    p.add_argument("--memory", action="append", metavar="BUFFER=BYTES", help="memory the method used, per buffer")
    p.add_argument("--test", choices=("unbiased",), default=None,
                   help="also test the answer for bias against the reference within both variances "
                        "(docs/reference/cli.md, 'score --test unbiased'); exit status 1 when it fails")
    p.add_argument("--variance", metavar="FILE.exr", default=None,
                   help="the answer's per-pixel variance of the mean (sample variance / samples)")
    p.add_argument("--second-moment", metavar="FILE.exr", default=None,
                   help="the answer's per-pixel mean of squared samples (with --samples)")
    p.add_argument("--samples", type=int, default=None, help="the answer's samples per pixel")
    p.add_argument("--alpha", type=float, default=None, help="family-wise level of --test (default 0.01)")
    p.add_argument("--correction", choices=("sidak", "holm"), default=None,
                   help="multiple-test correction over the pixels (default sidak)")
    p.add_argument("--no-report", action="store_true", help="add the rows only; do not rebuild the run's report")
    p.add_argument("--no-progress", action="store_true", help="no progress bar while a reference renders")


def _score(args):
    from .score import items_from_folder, make_answer, score_into_run

    if bool(args.folder) == bool(args.answer):
        raise LdbenchError("ldbench score needs --from FOLDER or --answer FILE (with --scene, --effect, --size)")
    if args.folder:
        if args.scene or args.effect:
            raise LdbenchError("--from reads each question from its question.json; --scene/--effect go with --answer")
        _test_opts(args)  # refuses the --answer-only test flags
        items = items_from_folder(args.folder)
    else:
        if not (args.scene and args.effect):
            raise LdbenchError("--answer needs --scene and --effect (and --size)")
        stages = _pairs(args.stage_ms, "--stage-ms", lambda v: [float(x) for x in v.split(",")])
        memory = _pairs(args.memory, "--memory", int)
        params = {k: _literal(v) for k, v in _pairs(args.set, "--set").items()}
        items = [(_question_from(args), make_answer(
            args.answer, method=args.method, params=params, paper=args.paper, mask=args.mask,
            transfer=args.transfer, png_scale=args.png_scale, stage_ms=stages, memory=memory,
            method_version=args.method_version, method_commit=args.method_commit, **_test_opts(args)))]
    if args.folder and args.test:  # --test over a folder: every answer (answer.json may set it per answer)
        from .unbiased_score import check_test_args

        items = [(q, dataclasses.replace(a, **check_test_args(
            args.test, a.variance, a.second_moment, a.samples, a.alpha if args.alpha is None else args.alpha,
            args.correction or a.correction))) for q, a in items]
    rows = score_into_run(items, args.run_dir, report=not args.no_report, progress=not args.no_progress)
    for r in rows:
        metrics = [c for c in ("psnr", "ssim", "flip", "hit_agreement", "range_within_5pct", "unbiased_p",
                               "rejected_fraction") if
                   isinstance(r.get(c), float) and r[c] == r[c]]
        print(f"{r['scene']} {r['method']} {r['effect']} {r['width']}x{r['height']}: "
              + ", ".join(f"{c}={r[c]:.6g}" for c in metrics)
              + ("" if r["status"] == "ok" else f" [{r['status']}]")
              + (f" unbiased: {r['unbiased_verdict']}" if r.get("unbiased_verdict") else ""))
    print(f"wrote {args.run_dir} ({len(rows)} rows added)")
    failed = any(r.get("unbiased_verdict") == "fail" for r in rows)
    return 1 if failed or any(r["status"] != "ok" for r in rows) else 0  # as `run`: written, but not every row ok


def _test_opts(args) -> dict:
    """make_answer's test fields from the score command line (--from: see _score)."""
    if args.folder:
        if args.variance or args.second_moment or args.samples is not None:
            raise LdbenchError("--variance/--second-moment/--samples go with --answer; with --from put "
                               "variance.exr or second_moment.exr beside each answer, samples in answer.json")
        return {}
    if (args.variance or args.second_moment) and not args.test:
        raise LdbenchError("--variance/--second-moment are read by --test unbiased; add it")
    return {"test": args.test, "variance": args.variance, "second_moment": args.second_moment,
            "samples": args.samples, "alpha": 0.01 if args.alpha is None else args.alpha,
            "correction": args.correction or "sidak"}


def _export_args(p):
    _question_args(p)
    p.add_argument("--out", required=True, help="folder to write the question into (created)")


def _export(args):
    from .export import export_question

    out = export_question(_question_from(args), args.out)
    print(f"wrote {out}")
    return 0


def _new_method_args(p):
    p.add_argument("name", help="the method's name, e.g. my-ao")
    p.add_argument("--out", default=None, help="folder of the new plugin package (default ./NAME)")
    p.add_argument("--in-tree", action="store_true", help="write ldbench/methods/<name>/ of this ldbench checkout instead")


def _new_method(args):
    from .newmethod import write_template

    if args.in_tree and args.out:
        raise LdbenchError("give --out or --in-tree, not both")
    for f in write_template(args.name, out=args.out, in_tree=args.in_tree):
        print(f"wrote {f}")
    return 0


class _VersionAction(argparse.Action):
    """``--version``: asks git only when given (every other command starts without it)."""

    def __init__(self, option_strings, dest, **kw):
        super().__init__(option_strings, dest, nargs=0, default=argparse.SUPPRESS, **kw)

    def __call__(self, parser, namespace, values, option_string=None):
        print(_version_text())
        parser.exit(0)


def _version_text() -> str:
    info = ldbench_info()
    commit = (info["commit"] or "unknown commit")[:12] + ("-dirty" if info["dirty"] else "")
    return f"ldbench {info['version'] or 'unknown'} ({commit})"


COMMANDS = {
    "scenes": (_scenes_args, _scenes, "list scenes (built-in and registered real ones); fetch real scenes"),
    "methods": (_methods_args, _methods, "list the method adapters, or one method's parameters"),
    "reference": (_reference_args, _reference, "render or fetch the cached Mitsuba reference"),
    "run": (_run_args, _run, "run a suite (TOML) or one scene/method/effect"),
    "report": (_report_args, _report, "rebuild the report of a run directory"),
    "compare": (_compare_args, _compare, "regression gate: compare a run against a baseline (exit 1 = regression)"),
    "history": (_history_args, _history, "per-machine benchmark history: add a run, plot with change points"),
    "reproduce": (_reproduce_args, _reproduce, "one paper table/figure: ours beside the published numbers"),
    "export": (_export_args, _export, "write a question (scene, camera, light, Mitsuba XML, ray batch) for an "
                                      "external renderer"),
    "new-method": (_new_method_args, _new_method, "write a working template adapter (Python + GLSL) to start from"),
    "score": (_score_args, _score, "score images or per-ray answers rendered elsewhere; rows join a run directory"),
}


EPILOG = ("Exit status: 0 success, 1 a run with failed jobs or a comparison with a regression, 2 bad input "
          "(one line on stderr), 130 interrupted; docs/reference/cli.md lists them with the accepted value ranges.")


def _verbosity_args(p, default):
    p.add_argument("-v", "--verbose", action="count", default=default,
                   help="more messages on stderr (debug); repeatable")
    p.add_argument("-q", "--quiet", action="count", default=default,
                   help="fewer messages on stderr: -q warnings and errors only, -qq errors only")


def build_parser():
    parser = _Parser(prog="ldbench", description="benchmark and validation of GI through layered depth",
                     epilog=EPILOG)
    _verbosity_args(parser, 0)
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    parser.add_argument("--version", action=_VersionAction, help="ldbench's version and commit, then exit")
    for name, (add, _, helptext) in COMMANDS.items():
        p = sub.add_parser(name, help=helptext, description=helptext, epilog=EPILOG)
        _verbosity_args(p, argparse.SUPPRESS)  # -v/-q also after the sub-command
        add(p)
    return parser


class _StderrHandler(logging.Handler):
    """Log records as ``ldbench: [level: ]message`` lines on the current ``sys.stderr``."""

    #: marks the handler :func:`setup_logging` installed, which a second call replaces
    ldbench_cli: bool = False

    def emit(self, record):
        try:
            msg = record.getMessage()
            level = "" if record.levelno == logging.INFO else f"{record.levelname.lower()}: "
            print(f"ldbench: {level}{msg}", file=sys.stderr)
        except Exception:  # pragma: no cover - logging must never raise
            self.handleError(record)


def setup_logging(verbose: int = 0, quiet: int = 0) -> logging.Logger:
    """Send the package's log records to stderr at the level ``-v``/``-q`` ask for (default INFO)."""
    root = logging.getLogger(_LOG_ROOT)
    for h in [h for h in root.handlers if getattr(h, "ldbench_cli", False)]:  # main() called again
        root.removeHandler(h)
    handler = _StderrHandler()
    handler.ldbench_cli = True
    root.addHandler(handler)
    root.propagate = False
    level = logging.INFO + 10 * (quiet - verbose)
    root.setLevel(min(max(level, logging.DEBUG), logging.ERROR))
    return root


def main(argv=None) -> int:
    try:
        args = build_parser().parse_args(argv)
        setup_logging(getattr(args, "verbose", 0), getattr(args, "quiet", 0))
        return COMMANDS[args.command][1](args) or 0
    except LdbenchError as e:
        print(f"ldbench: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as e:
        print(f"ldbench: interrupted: {e}" if str(e) else "ldbench: interrupted", file=sys.stderr)
        return 130
    except OSError as e:  # the file system said no midway (full disk, read-only, too long): one line, not a traceback
        if e.errno not in _FILE_SYSTEM_ERRNOS:
            raise
        where = f"{e.filename}: " if e.filename else ""
        print(f"ldbench: error: {where}{e.strerror or e}", file=sys.stderr)
        return 2


#: What a file system answers that is no bug of ldbench's (every output path is also checked up front,
#: :func:`ldbench.core.files.check_output_path`; a disk fills up, a mount turns read-only, midway too).
_FILE_SYSTEM_ERRNOS = frozenset(getattr(errno, n) for n in (
    "ENOSPC", "EDQUOT", "EROFS", "EACCES", "EPERM", "ENAMETOOLONG", "ENOTDIR", "EISDIR", "EFBIG", "EMFILE", "ENFILE",
    "EIO") if hasattr(errno, n))


if __name__ == "__main__":
    sys.exit(main())
