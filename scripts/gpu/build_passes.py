"""GPU time of each compute dispatch of one layered-structure build (docs/fast_builds.md: the per-pass figures).

    python scripts/gpu/build_passes.py [VARIANT] [--fig8 TRIANGLES,MAPS,RESOLUTION] [--builds N]

VARIANT: a variant of fast_builds_bench.py (default: the Figure 8 default,
splat/linked-yang-queue-batch16-aggregate-tilesort); --fig8: the scene and maps (default 260000,512,200; the
LDI's structure at 260000,96,128); --builds: timed builds after the first (default 7). Prints, per dispatch in
order, the program, its workgroups and the median of a GL timer query around it (ms), then their sum. On
llvmpipe the queries time nothing useful (wall clock is the measure there): the numbers are for a GPU.
"""
from __future__ import annotations

import collections
import contextlib
import sys
from pathlib import Path

import moderngl
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import fast_builds_bench as fb  # noqa: E402

from ldbench.core.gpu import Gpu  # noqa: E402
from ldbench.core.scenes import load_scene  # noqa: E402
from ldbench.methods.directions import ldm_axes  # noqa: E402
from ldbench.methods.gbuffer import SceneGeometry  # noqa: E402
from ldbench.methods.structures import StructureSpec, bounding_sphere, make_structure, ortho_layers  # noqa: E402

#: the defines that tell a program's passes apart in the listing
TAGS = ("SP_BOXES_PASS", "SP_TILE_SORT", "LS_PASS_COUNT", "LL_SORT_LISTED")


def main(argv: list[str]) -> int:
    args = list(argv)
    opts = {"--fig8": "260000,512,200", "--builds": "7"}
    for k in opts:
        if k in args:
            i = args.index(k)
            opts[k] = args[i + 1]
            del args[i:i + 2]
    variant = args[0] if args else "splat/linked-yang-queue-batch16-aggregate-tilesort"
    try:
        n, maps, res = (int(x) for x in opts["--fig8"].split(","))
        builds = int(opts["--builds"])
        kw = fb.VARIANTS[variant]
    except (ValueError, KeyError) as e:
        print(f"build_passes: bad argument ({e}); see the module docstring", file=sys.stderr)
        return 2
    gpu = Gpu()
    names: dict = {}
    compute = gpu.compute

    def named_compute(path, defines=None, *a, **k):
        cs = compute(path, defines, *a, **k)
        names[id(cs)] = Path(path).name + "".join(f"+{t}" for t in TAGS if t in (defines or {}))
        return cs

    log: list = []
    run = moderngl.ComputeShader.run

    def timed_run(self, x=1, y=1, z=1):
        q = gpu.ctx.query(time=True)
        with q:
            out = run(self, x, y, z)
        log.append((names.get(id(self), "?"), (x, y, z), q))
        return out

    @contextlib.contextmanager
    def untimed_stage(name):  # GL time queries do not nest: a stage's query would leave its dispatches' at 0
        yield

    gpu.compute = named_compute
    gpu.stage = untimed_stage
    moderngl.ComputeShader.run = timed_run
    r = gpu.resources()
    try:
        geo = SceneGeometry(gpu, load_scene(f"atrium:triangles={n}"), r)
        centre, radius = bounding_sphere(geo.scene)
        clip, rows, _ = ortho_layers(ldm_axes(maps), centre, radius)
        s = make_structure(StructureSpec(**kw), gpu, geo, r, layers=maps, width=res, prefix="passes.")
        s.set_layers(clip, rows)
        s.build()  # sizes the lazy pool
        gpu.ctx.finish()
        times = collections.defaultdict(list)
        for _ in range(builds):
            log.clear()
            s.build()
            gpu.ctx.finish()
            for j, (name, groups, q) in enumerate(log):
                times[(j, name, groups)].append(q.elapsed * 1e-6)
        total = 0.0
        for (j, name, groups), v in times.items():
            ms = float(np.median(v))
            total += ms
            print(f"{j:2d} {name:40s} {str(groups):20s} {ms:8.4f} ms")
        print(f"sum {total:.4f} ms  {variant}  fragments={s.stats()['fragments']}  device={gpu.device}")
    finally:
        moderngl.ComputeShader.run = run
        r.release()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
