"""The ``ldbench`` command line (DESIGN.md, "Command line").

Every user error is an :class:`~harness.errors.LdbenchError`: one line on stderr, exit status 2, no
traceback. Sub-commands are registered in :data:`COMMANDS` (name → (add_arguments, handler)).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from .errors import LdbenchError


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
    from . import scene_registry
    from .scenes import list_scenes

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
    pass


def _methods(args):
    from methods.base import registry

    for name, cls in registry().items():
        also = f" (also: {', '.join(cls.aliases)})" if cls.aliases else ""
        print(f"{name}{also}  [{cls.paper}]  effects: {', '.join(sorted(cls.effects))}")
        print(cls.Params.table())
    return 0


# ---- reference -------------------------------------------------------------------------------------
# Effect parameters with flags of their own; any other one: --effect-set NAME=VALUE.
EFFECT_FLAGS = (("d_max", "--d-max", "ao, rays (kind ao): maximum distance (world units, or 'inf')"),
                ("falloff", "--falloff", "ao: step | quadratic"),
                ("ray_kind", "--ray-kind", "rays: diffuse | glossy | shadow | ao"),
                ("rays_per_pixel", "--rays-per-pixel", "rays: rays per hit pixel"))


def _effect_args(p, required=True):
    from .effects import EFFECTS

    p.add_argument("--effect", required=required, help=" | ".join(EFFECTS))
    for _, flag, helptext in EFFECT_FLAGS:
        p.add_argument(flag, default=None, help=helptext)
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
    from .effects import Effect

    return Effect.parse(args.effect, _effect_opts(args))


def _scene_params(pairs):
    out = {}
    for kv in pairs or []:
        if "=" not in kv:
            raise LdbenchError(f"--scene-set expects key=value, got {kv!r}")
        k, v = kv.split("=", 1)
        out[k] = _literal(v)
    return out


def _literal(v: str):
    import ast

    if v.lower() in ("inf", "infinity"):
        return float("inf")
    if v.lower() in ("true", "false"):
        return v.lower() == "true"
    try:
        return ast.literal_eval(v)
    except (ValueError, SyntaxError):
        return v


def _reference_args(p):
    p.add_argument("scene")
    _effect_args(p)
    p.add_argument("--spp", type=int, default=1024)
    p.add_argument("--size", default="256x256")
    p.add_argument("--scene-set", action="append", metavar="KEY=VALUE", help="scene builder parameter")
    p.add_argument("--out", default=None, help="also write the mean as this EXR file")
    p.add_argument("--no-cache", action="store_true")


def _reference(args):
    from .scenes import load_scene
    from .suite import parse_size

    from .suite import MAX_SPP, checked_int, check_budget
    w, h = parse_size(args.size)
    check_budget(w, h, checked_int(args.spp, "--spp", 1, MAX_SPP))
    effect = _effect_from(args)
    spec = effect.spec
    if spec.output != "image":
        raise LdbenchError(f"ldbench reference writes images; effect {effect.name!r} is answered per "
                           f"{spec.output[:-1]} by its oracle inside `ldbench run`")
    scene = load_scene(args.scene, **_scene_params(args.scene_set))
    for w_ in scene.warnings:
        print(f"warning: {w_}", file=sys.stderr)
    effect.check_scene(scene)
    from references import EXACT, render_effect

    ref = render_effect(scene, effect, width=w, height=h, spp=args.spp, seed=0,
                        inputs=spec.inputs(scene, w, h, effect.params, 0, exact=EXACT), cache=not args.no_cache)
    m = ref.meta
    took = "cached" if m.get("cached") else f"{m.get('seconds', 0):.2f} s"
    print(f"{scene.name} {effect.label()} {w}x{h} spp={args.spp} variant={m.get('variant')} {took} "
          f"key={m.get('key')}")
    if args.out:
        from .imageio import save_image
        out = Path(args.out)
        save_image(out.with_suffix(""), ref.mean)
        print(f"wrote {out.with_suffix('.exr')}")
    return 0


# ---- run / report ---------------------------------------------------------------------------------
def _run_args(p):
    p.add_argument("suite", nargs="?", help="suite TOML file")
    p.add_argument("--scene")
    p.add_argument("--method", action="append")
    _effect_args(p, required=False)
    p.add_argument("--seed", type=int, default=None, help="seed of the effect's inputs and the reference")
    p.add_argument("--size", default=None, help="WxH")
    p.add_argument("--spp", type=int, default=None, help="reference samples per pixel")
    p.add_argument("--warmup", type=int, default=None)
    p.add_argument("--frames", type=int, default=None)
    p.add_argument("--set", action="append", metavar="METHOD.PARAM=VALUE", help="method parameter")
    p.add_argument("--scene-set", action="append", metavar="KEY=VALUE", help="scene builder parameter")
    p.add_argument("--out", default=None, help="run directory (default runs/<suite>-<time>)")
    p.add_argument("--no-report", action="store_true")
    p.add_argument("--no-progress", action="store_true")
    p.add_argument("--executor", default="local", choices=("local", "ray"),
                   help="local: this process (default); ray: one task per job group on a Ray cluster "
                        "(pip install 'ldbench[ray]'; docs/ray.md)")
    p.add_argument("--address", default=None,
                   help="ray: the cluster to join (auto, HOST:6379, ray://HOST:10001); default: start a local one")
    p.add_argument("--retries", type=int, default=None,
                   help="ray: times a failed task is run again (default 1)")


def _executor_from(args):
    """The executor of ``ldbench run``: local, or Ray with --address/--retries."""
    if args.executor == "local":
        if args.address is not None or args.retries is not None:
            raise LdbenchError("--address and --retries go with --executor ray")
        return "local"
    from .executors import get_executor

    opts = {"address": args.address}
    if args.retries is not None:
        opts["retries"] = args.retries
    return get_executor("ray", **opts)


def _method_sets(pairs) -> dict:
    """``--set METHOD.PARAM=VALUE`` flags as {method: {param: value}}."""
    params: dict = {}
    for kv in pairs or []:
        if "=" not in kv or "." not in kv.split("=", 1)[0]:
            raise LdbenchError(f"--set expects METHOD.PARAM=VALUE, got {kv!r}")
        k, v = kv.split("=", 1)
        m, p = k.split(".", 1)
        from methods.base import canonical_name
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
            import dataclasses
            from methods.base import get_method
            for m, ps in params.items():
                if not any(j.method == m for j in suite.jobs):
                    raise LdbenchError(f"--set names method {m!r}, which this suite does not run")
            jobs = []
            for j in suite.jobs:
                if j.method in params:
                    merged = {**dict(j.params), **params[j.method]}
                    get_method(j.method).Params.from_dict(merged, method=j.method)
                    j = dataclasses.replace(j, params=tuple(sorted(merged.items())))
                jobs.append(j)
            suite.jobs = jobs
        from .suite import override  # --size/--spp/--warmup/--frames, validated like the file's values
        return override(suite, size=args.size, spp=args.spp, warmup=args.warmup, frames=args.frames)
    if not (args.scene and args.method and args.effect):
        raise LdbenchError("ldbench run needs a suite file, or --scene, --method and --effect")
    from methods.base import canonical_name
    for m in params:
        if m not in {canonical_name(x) for x in args.method}:
            raise LdbenchError(f"--set names method {m!r}, which is not in --method")
    run = {"scene": args.scene, "effect": args.effect, "methods": args.method, "params": params,
           "scene_params": _scene_params(args.scene_set), "effect_params": _effect_opts(args)}
    if args.seed is not None:
        run["seed"] = args.seed
    head = {"name": "adhoc"}
    for k in ("size", "spp", "warmup", "frames"):
        if getattr(args, k) is not None:
            head[k] = getattr(args, k)
    return suite_from_dict({"suite": head, "run": [run]}, name="adhoc")


def _run(args):
    import time
    from .executors import run_jobs

    suite = suite_from_args(args)
    executor = _executor_from(args)
    from .naming import slug  # a suite named "../../x" stays inside runs/
    out = Path(args.out) if args.out else Path("runs") / f"{slug(suite.name)}-{time.strftime('%Y%m%d-%H%M%S')}"
    df = run_jobs(suite, out, progress=not args.no_progress, report=not args.no_report, executor=executor)
    cols = [c for c in ("scene", "method", "effect", "width", "height", "total_ms", "memory_bytes", "psnr",
                        "ssim", "status") if c in df.columns]
    import pandas as pd
    with pd.option_context("display.width", 200, "display.max_columns", 20):
        print(df[cols].to_string(index=False))
    print(f"wrote {out}")
    return 1 if (df["status"] != "ok").any() else 0


def _report_args(p):
    p.add_argument("run_dir")


def _report(args):
    from .report import write_report

    d = Path(args.run_dir)
    if not (d / "results.parquet").exists():
        raise LdbenchError(f"{d} is not a run directory (no results.parquet)")
    path = write_report(d)
    print(f"wrote {path}")
    return 0


# ---- compare / history (harness/compare.py, harness/history.py; imported when used) ---------------
def _compare_args(p):
    from .compare import add_arguments
    add_arguments(p)


def _compare(args):
    from .compare import run_cli
    return run_cli(args)


def _history_args(p):
    from .history import add_arguments
    add_arguments(p)


def _history(args):
    if args.history_command == "add":
        from .history import run_add
        return run_add(args)
    from .history_plots import run_plot
    return run_plot(args)


# ---- reproduce (harness/reproduce.py) --------------------------------------------------------------
def _reproduce_args(p):
    p.add_argument("table", nargs="?", help="registry key, e.g. aalund2015-fig8 (see --list)")
    p.add_argument("--list", action="store_true", help="list the reproducible tables and figures")
    p.add_argument("--scale", default="paper", help="paper (the suite as written) | ci (tiny, for llvmpipe)")
    p.add_argument("--size", default=None, help="WxH, overrides the scale's image size")
    p.add_argument("--out", default=None, help="run directory (default runs/<table>-<scale>-<time>)")
    p.add_argument("--from-run", default=None, metavar="RUN_DIR", help="reuse an existing run directory")
    p.add_argument("--no-report", action="store_true")
    p.add_argument("--no-progress", action="store_true")


def _reproduce(args):
    from .reproduce import main_cli

    return main_cli(args)


COMMANDS = {
    "scenes": (_scenes_args, _scenes, "list scenes (built-in and registered real ones); fetch real scenes"),
    "methods": (_methods_args, _methods, "list method adapters and their parameters"),
    "reference": (_reference_args, _reference, "render or fetch the cached Mitsuba reference"),
    "run": (_run_args, _run, "run a suite (TOML) or one scene/method/effect"),
    "report": (_report_args, _report, "rebuild the report of a run directory"),
    "compare": (_compare_args, _compare, "regression gate: compare a run against a baseline (exit 1 = regression)"),
    "history": (_history_args, _history, "per-machine benchmark history: add a run, plot with change points"),
    "reproduce": (_reproduce_args, _reproduce, "one paper table/figure: ours beside the published numbers"),
}


def build_parser():
    parser = _Parser(prog="ldbench", description="benchmark and validation of GI through layered depth")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    for name, (add, _, helptext) in COMMANDS.items():
        add(sub.add_parser(name, help=helptext))
    return parser


def main(argv=None) -> int:
    try:
        args = build_parser().parse_args(argv)
        return COMMANDS[args.command][1](args) or 0
    except LdbenchError as e:
        print(f"ldbench: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("ldbench: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
