"""Fast-build measurements (scripts/gpu/README.md; docs/reference/methods/fast_builds.md): the copy bandwidth
that bounds a build, and the build variants of the layered structures (ldbench/methods/structures/) timed
alone, on the LDM's maps of aalund2015 Figure 8.

    python scripts/gpu/fast_builds_bench.py OUT_DIR PART [--dry] [--fig8 TRIANGLES,MAPS,RESOLUTION] [--variants A,B]

PART:
  bandwidth  copy bandwidth of this GPU (a compute-shader copy of 64 MiB … 1 GiB, the fastest; timed like a
             stage; glCopyBufferSubData beside it) -> bandwidth.csv
  fig8       every variant at the Figure 8 maps (atrium 260k, 512 maps of 200²) -> builds.csv
  triangles  build time of every variant against atrium triangles (512 maps of 200²) -> builds.csv
  maps       build time of every variant against the number of maps (atrium 260k, 200²) -> builds.csv
  coverage   one-pass raster and the splat (both ways of its long triangles) against the raster at the Figure 8
             maps: fragments missing / extra -> coverage.csv
  tune       the splat's layers per invocation and long-edge threshold at the Figure 8 maps -> builds.csv

Each build is timed as the runner times a frame (gpu.begin_frame / stage / end_frame: GL timer queries
on a GPU, wall clock on llvmpipe) after one untimed build that sizes the pools; a row is written as soon
as it is measured, so a part cut short by its time limit keeps its rows. --dry: tiny sizes (llvmpipe);
--fig8: another configuration for the fig8, coverage and tune parts; --variants: only these variants.
"""
from __future__ import annotations

import csv
import dataclasses
import sys
import time
from pathlib import Path

import numpy as np

from ldbench.core.gpu import Gpu
from ldbench.core.scenes import load_scene
from ldbench.methods.directions import ldm_axes
from ldbench.methods.ldi import LdiParams
from ldbench.methods.ldm import LdmParams
from ldbench.methods.gbuffer import SceneGeometry
from ldbench.methods.structures import StructureSpec, bounding_sphere, make_structure, ortho_layers

LDI_STRUCTURE = {f.name: getattr(LdiParams().structure, f.name) for f in dataclasses.fields(StructureSpec)}
LDM_STRUCTURE = {f.name: getattr(LdmParams().structure, f.name) for f in dataclasses.fields(StructureSpec)}
#: name -> StructureSpec fields; "today" is the Figure 8 default (hardware raster, sorted CAS insert,
#: pool grow with its read-back); every other variant uses the lazy pool (no read-back inside a build).
VARIANTS = {
    "raster/linked/grow (today)": dict(layout="linked"),
    "raster/linked": dict(layout="linked", pool="lazy"),
    "raster/linear": dict(layout="linear", pool="lazy"),
    "raster/linear-sort": dict(layout="linear", pool="lazy", assembly="sort"),
    "one_pass/linear": dict(layout="linear", pool="lazy", source="one_pass"),
    "splat/linked": dict(layout="linked", pool="lazy", source="splat"),
    "splat/linked-yang": dict(layout="linked", pool="lazy", source="splat", sorted_insert=False),
    "splat/linear": dict(layout="linear", pool="lazy", source="splat"),
    "splat/linear-sort": dict(layout="linear", pool="lazy", source="splat", assembly="sort"),
    # the long triangles by the hardware draw (the tiles' pass is the default)
    "splat/linked-yang-large-raster": dict(layout="linked", pool="lazy", source="splat", sorted_insert=False,
                                           splat_large="raster"),
    "splat/linear-sort-large-raster": dict(layout="linear", pool="lazy", source="splat", assembly="sort",
                                           splat_large="raster"),
    **{f"splat/linked-yang-max{m}": dict(layout="linked", pool="lazy", source="splat", sorted_insert=False,
                                         splat_max=float(m)) for m in (4, 8, 32, 64)},
    **{f"splat/linked-yang-batch{b}": dict(layout="linked", pool="lazy", source="splat", sorted_insert=False,
                                           splat_batch=b) for b in (4, 16)},
    "splat/linked-yang-aggregate": dict(layout="linked", pool="lazy", source="splat", sorted_insert=False,
                                        aggregate=True),
    **{f"splat/linked-yang-group{g}": dict(layout="linked", pool="lazy", source="splat", sorted_insert=False,
                                           splat_group=g) for g in (32, 128, 256)},
    # the small triangles' pairs queued in shared memory
    **{f"splat/linked-yang-queue{suffix}": dict(layout="linked", pool="lazy", source="splat", sorted_insert=False,
                                                splat_queue=True, **kw)
       for suffix, kw in (("", {}), ("-batch16", dict(splat_batch=16)), ("-batch32", dict(splat_batch=32)),
                          ("-group128", dict(splat_group=128)), ("-group256", dict(splat_group=256)),
                          ("-batch16-aggregate", dict(splat_batch=16, aggregate=True)),
                          ("-aggregate", dict(aggregate=True)))},
    # the LDM adapter's default structure (the Figure 8 build of docs/reference/methods/fast_builds.md)
    "splat/linked-yang-queue-batch16-aggregate-tilesort": LDM_STRUCTURE,
    "splat/linked-yang-batch16-aggregate": dict(layout="linked", pool="lazy", source="splat", sorted_insert=False,
                                                splat_batch=16, aggregate=True),
    "splat/linear-sort-queue": dict(layout="linear", pool="lazy", source="splat", assembly="sort", splat_queue=True),
    # the LDI adapter's default structure (payload, ties in payload order), at --fig8 260000,96,128
    **{f"ldi/splat-sort-group{g}": {**LDI_STRUCTURE, "splat_group": g} for g in (32, 64, 128, 256)},
    "ldi/splat-sort-grow": {**LDI_STRUCTURE, "pool": "grow"},
    "ldi/splat-sort-queue": {**LDI_STRUCTURE, "splat_queue": True},
    "ldi/splat-sort-queue-batch16": {**LDI_STRUCTURE, "splat_queue": True, "splat_batch": 16},
}
#: the Figure 8 default with another long-edge threshold, layers per invocation or invocations per workgroup
VARIANTS.update({f"splat/linked-yang-queue-batch16-aggregate-tilesort-{suffix}":
                 {**VARIANTS["splat/linked-yang-queue-batch16-aggregate-tilesort"], **kw}
                 for suffix, kw in (("max4", dict(splat_max=4.0)), ("max8", dict(splat_max=8.0)),
                                    ("max12", dict(splat_max=12.0)), ("max32", dict(splat_max=32.0)),
                                    ("batch32", dict(splat_batch=32)), ("batch8", dict(splat_batch=8)),
                                    ("group64", dict(splat_group=64)), ("group32", dict(splat_group=32)))})

RASTER_BOUND = ("raster/linked/grow (today)", "raster/linked", "raster/linear", "raster/linear-sort", "one_pass/linear")


def sizes(dry: bool) -> dict:
    if dry:
        return dict(fig8=(4000, 16, 32), triangles=[2000, 8000], maps=[4, 8, 16], tri_maps=(16, 32),
                    maps_tri=(2000, 32), frames=2, copy_mb=[4, 16], tune_batch=[1, 8], tune_max=[4, 16])
    return dict(fig8=(260000, 512, 200), triangles=[65000, 260000, 1000000, 4000000], maps=[32, 64, 128, 256, 512, 1024],
                tri_maps=(512, 200), maps_tri=(260000, 200), frames=3, copy_mb=[64, 256, 1024],
                tune_batch=[1, 4, 8, 16, 32], tune_max=[4, 16, 64])


BUILD_FIELDS = ("sweep", "scene", "triangles", "maps", "resolution", "variant", "build_ms", "wall_ms", "first_build_ms",
                "stages", "fragments", "max_list", "large_triangles", "sort_left", "memory_mb", "structure_mb",
                "bandwidth_fraction", "splat_batch", "splat_max", "device", "status")


class Rows:
    """A CSV written row by row (appended; the header when the file is new); ``fields``: fixed columns."""

    def __init__(self, path: Path, fields=None):
        self.path, self.fields = path, fields

    def add(self, row: dict):
        new = not self.path.exists()
        with open(self.path, "a", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(self.fields or row), restval="")
            if new:
                w.writeheader()
            w.writerow(row)
        print(" ".join(f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}" for k, v in row.items()), flush=True)


def timed(gpu, fn, frames: int):
    """Median stage times (ms) and total of ``frames`` calls of fn() timed as runner frames."""
    samples = []
    for _ in range(frames):
        gpu.begin_frame()
        fn()
        stages, wall = gpu.end_frame()
        samples.append((stages, wall))
    keys = samples[0][0].keys()
    st = {k: float(np.median([s[k] for s, _ in samples])) for k in keys}
    total = float(np.median([sum(s.values()) for s, _ in samples]))
    wall = float(np.median([w for _, w in samples]))
    return st, total, wall


COPY_GLSL = """#version 430
layout(local_size_x = 256) in;
layout(std430, binding = 0) readonly buffer A { uvec4 a[]; };
layout(std430, binding = 1) writeonly buffer B { uvec4 b[]; };
uniform uint n;
void main() { for (uint i = gl_GlobalInvocationID.x; i < n; i += gl_NumWorkGroups.x * 256u) b[i] = a[i]; }
"""


def copy_bandwidth(gpu, mb: int, frames: int = 5) -> tuple[float, float]:
    """Bytes per second of copying ``mb`` MiB between two buffers (each byte read once, written once):
    (a compute shader of 16-byte loads and stores, glCopyBufferSubData). The shader copy is the bound of
    a build's shader stores; NVIDIA's glCopyBufferSubData is ~15x slower (88 GB/s on an H200)."""
    n = mb << 20
    a, b = gpu.ctx.buffer(reserve=n), gpu.ctx.buffer(reserve=n)
    cs = gpu.ctx.compute_shader(COPY_GLSL)
    try:
        a.bind_to_storage_buffer(0)
        b.bind_to_storage_buffer(1)
        cs["n"].value = n // 16
        out = []
        for name, fn in (("shader", lambda: cs.run(4096)), ("copy", lambda: gpu.ctx.copy_buffer(b, a))):
            fn()  # first touch
            ms = []
            for _ in range(frames):
                gpu.begin_frame()
                with gpu.stage(name):
                    fn()
                st, _ = gpu.end_frame()
                ms.append(st[name])
            out.append(n / (float(np.median(ms)) * 1e-3))
        return out[0], out[1]
    finally:
        for o in (a, b, cs):
            o.release()


def structure_bytes(s, st: dict) -> int:
    """Bytes of the finished structure (what a build must write at least): per list a head or offset,
    per fragment a node (linked: 8 B) or depth (linear: 4 B) and its payload words."""
    node = 8 if s.layout == "linked" else 4
    return 4 * s.n_lists + st["fragments_stored"] * (node + 4 * len(s.payload))


def measure(gpu, geo, scene_label, maps, res, name, kw, frames, bw, rows: Rows, extra=None):
    centre, radius = bounding_sphere(geo.scene)
    clip, drows, _ = ortho_layers(ldm_axes(maps), centre, radius)
    r = gpu.resources()
    try:
        s = make_structure(StructureSpec(**kw), gpu, geo, r, layers=maps, width=res, prefix="b.")
        s.set_layers(clip, drows)
        t0 = time.perf_counter()
        s.build()  # sizes the pool (the lazy policy's synchronous first build)
        gpu.ctx.finish()
        first_ms = (time.perf_counter() - t0) * 1e3
        stages, total, wall = timed(gpu, s.build, frames)
        st = s.stats()
        bad = s.invariants(st)
        out = structure_bytes(s, st)
        row = dict(scene=scene_label, triangles=geo.triangles, maps=maps, resolution=res, variant=name,
                   build_ms=total, wall_ms=wall, first_build_ms=first_ms,
                   stages=";".join(f"{k}={v:.3f}" for k, v in stages.items()),
                   fragments=st["fragments"], max_list=st["max_list_length"],
                   large_triangles=st.get("splat_large_triangles", ""), sort_left=st.get("splat_sort_left", ""),
                   memory_mb=sum(s.memory().values()) / 2**20, structure_mb=out / 2**20,
                   bandwidth_fraction=out / (total * 1e-3 * bw) if bw and total > 0 else float("nan"),
                   device=gpu.device, status="ok" if not bad else "degraded: " + "; ".join(bad))
        if extra:
            row.update(extra)
        rows.add(row)
    except Exception as e:  # noqa: BLE001 - one variant failing (e.g. memory) must not stop the sweep
        rows.add(dict(scene=scene_label, triangles=geo.triangles, maps=maps, resolution=res, variant=name,
                      build_ms=float("nan"), status=f"failed: {type(e).__name__}: {str(e)[:200]}"))
    finally:
        r.release()


def main():
    out, part, dry = Path(sys.argv[1]), sys.argv[2], "--dry" in sys.argv
    out.mkdir(parents=True, exist_ok=True)
    z = sizes(dry)
    if "--fig8" in sys.argv:
        z["fig8"] = tuple(int(x) for x in sys.argv[sys.argv.index("--fig8") + 1].split(","))
    if "--variants" in sys.argv:  # a comma-separated subset of VARIANTS
        keep = sys.argv[sys.argv.index("--variants") + 1].split(",")
        for k in list(VARIANTS):
            if k not in keep:
                del VARIANTS[k]
    gpu = Gpu()
    bw_file = out / "bandwidth.csv"
    if part == "bandwidth":
        best = None
        for mb in z["copy_mb"]:  # the fastest size is the bound
            bw, gl_copy = copy_bandwidth(gpu, mb)
            if best is None or bw > best[1]:
                best = (mb, bw, gl_copy)
        mb, bw, gl_copy = best
        Rows(bw_file).add(dict(copy_mb=mb, bytes_per_s=bw, gb_per_s=bw / 1e9, gl_copy_gb_per_s=gl_copy / 1e9,
                               device=gpu.device, renderer=gpu.info["GL_RENDERER"]))
        return
    bw = float(next(csv.DictReader(open(bw_file)))["bytes_per_s"]) if bw_file.exists() else 0.0
    rows = Rows(out / "coverage.csv") if part == "coverage" else Rows(out / "builds.csv", BUILD_FIELDS)
    if part == "fig8":
        n, maps, res = z["fig8"]
        r = gpu.resources()
        geo = SceneGeometry(gpu, load_scene(f"atrium:triangles={n}"), r)
        for name, kw in VARIANTS.items():
            measure(gpu, geo, "atrium", maps, res, name, kw, z["frames"], bw, rows, {"sweep": "fig8"})
        r.release()
    elif part == "triangles":
        maps, res = z["tri_maps"]
        for n in z["triangles"]:
            r = gpu.resources()
            geo = SceneGeometry(gpu, load_scene(f"atrium:triangles={n}"), r)
            for name, kw in VARIANTS.items():
                measure(gpu, geo, "atrium", maps, res, name, kw, z["frames"], bw, rows, {"sweep": "triangles"})
            r.release()
    elif part == "maps":
        n, res = z["maps_tri"]
        r = gpu.resources()
        geo = SceneGeometry(gpu, load_scene(f"atrium:triangles={n}"), r)
        for maps in z["maps"]:
            for name, kw in VARIANTS.items():
                measure(gpu, geo, "atrium", maps, res, name, kw, z["frames"], bw, rows, {"sweep": "maps"})
        r.release()
    elif part == "tune":
        n, maps, res = z["fig8"]
        r = gpu.resources()
        geo = SceneGeometry(gpu, load_scene(f"atrium:triangles={n}"), r)
        for b in z["tune_batch"]:
            for m in z["tune_max"]:
                kw = dict(VARIANTS["splat/linear-sort"], splat_batch=b, splat_max=float(m))
                measure(gpu, geo, "atrium", maps, res, f"splat/linear-sort b{b} max{m}", kw, z["frames"], bw, rows,
                        {"sweep": "tune", "splat_batch": b, "splat_max": m})
        r.release()
    elif part == "coverage":
        n, maps, res = z["fig8"]
        r = gpu.resources()
        geo = SceneGeometry(gpu, load_scene(f"atrium:triangles={n}"), r)
        centre, radius = bounding_sphere(geo.scene)
        clip, drows, _ = ortho_layers(ldm_axes(maps), centre, radius)
        counts = {}
        for name, kw in (("raster", {}), ("one_pass", dict(source="one_pass")), ("splat", dict(source="splat")),
                         ("splat, long triangles by the hardware", dict(source="splat", splat_large="raster"))):
            sr = gpu.resources()  # one structure at a time
            s = make_structure(StructureSpec(layout="linear", **kw), gpu, geo, sr, layers=maps, width=res,
                               prefix="c.")
            s.set_layers(clip, drows)
            s.build()
            counts[name] = s.list_counts()
            sr.release()
        ref = counts["raster"]
        for name, c in counts.items():
            miss, extra = int(np.maximum(ref - c, 0).sum()), int(np.maximum(c - ref, 0).sum())
            rows.add(dict(triangles=n, maps=maps, resolution=res, build=name, fragments=int(c.sum()),
                          raster_fragments=int(ref.sum()), missing=miss, extra=extra,
                          missing_pct=100 * miss / max(1, ref.sum()), extra_pct=100 * extra / max(1, ref.sum()),
                          lists_differing=int((c != ref).sum()), device=gpu.device))
        r.release()
    else:
        sys.exit(f"unknown part {part!r}")


if __name__ == "__main__":
    main()
