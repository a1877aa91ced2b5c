"""Diagnosis of the buffer placement on NVIDIA (docs/fast_builds.md, "Read-backs"): the CPU reading a
buffer that shaders use makes the driver move it from video to host memory, and the sorted (CAS)
insert of the linked layout then runs many times slower (the table in docs/fast_builds.md). Also the two copy bandwidths (glCopyBufferSubData
and a compute-shader copy).

    python scripts/gpu/buffer_placement_diag.py [--dry]

Prints, per variant, the wall time of consecutive builds (ms; the same structure rebuilt; between two
builds some variants read a buffer back, directly or through ldbench.core.gpu.Gpu.read) and the driver's GL
debug messages about buffer placement."""
from __future__ import annotations

import ctypes
import sys
import time
from contextlib import contextmanager

import numpy as np

from ldbench.core.gpu import Gpu
from ldbench.core.scenes import load_scene
from ldbench.methods.directions import ldm_axes
from ldbench.methods.gbuffer import SceneGeometry
from ldbench.methods.structures import StructureSpec, bounding_sphere, make_structure, ortho_layers

DRY = "--dry" in sys.argv
gpu = Gpu()
ctx = gpu.ctx
MSGS: list = []
CB = ctypes.CFUNCTYPE(None, ctypes.c_uint, ctypes.c_uint, ctypes.c_uint, ctypes.c_uint, ctypes.c_int,
                      ctypes.c_char_p, ctypes.c_void_p)


def _debug():
    try:
        egl = ctypes.CDLL("libEGL.so.1")
        egl.eglGetProcAddress.restype = ctypes.c_void_p
        egl.eglGetProcAddress.argtypes = [ctypes.c_char_p]
        fn = lambda name, *t: ctypes.CFUNCTYPE(None, *t)(egl.eglGetProcAddress(name))  # noqa: E731
        fn(b"glEnable", ctypes.c_uint)(0x92E0)
        fn(b"glDebugMessageControl", ctypes.c_uint, ctypes.c_uint, ctypes.c_uint, ctypes.c_int, ctypes.c_void_p,
           ctypes.c_ubyte)(0x1100, 0x1100, 0x1100, 0, None, 1)
        cb = CB(lambda src, typ, i, sev, n, msg, u: MSGS.append(msg.decode(errors="replace")))
        fn(b"glDebugMessageCallback", CB, ctypes.c_void_p)(cb, None)
        return cb
    except Exception as e:  # noqa: BLE001
        print("no debug output:", e)


KEEP = _debug()


@contextmanager
def nostage(name):
    yield


def wall(fn):
    ctx.finish()
    t0 = time.perf_counter()
    fn()
    ctx.finish()
    return (time.perf_counter() - t0) * 1e3


def bandwidth():
    copy = ctx.compute_shader("""#version 430
layout(local_size_x = 256) in;
layout(std430, binding = 0) readonly buffer A { uvec4 a[]; };
layout(std430, binding = 1) writeonly buffer B { uvec4 b[]; };
uniform uint n;
void main() { for (uint i = gl_GlobalInvocationID.x; i < n; i += gl_NumWorkGroups.x * 256u) b[i] = a[i]; }
""")
    for mb in ((4, 16) if DRY else (64, 256, 1024)):
        n = mb << 20
        a, b = ctx.buffer(reserve=n), ctx.buffer(reserve=n)
        ctx.copy_buffer(b, a)
        t_copy = np.median([wall(lambda: ctx.copy_buffer(b, a)) for _ in range(5)])
        a.bind_to_storage_buffer(0)
        b.bind_to_storage_buffer(1)
        copy["n"].value = n // 16
        t_cs = np.median([wall(lambda: copy.run(4096)) for _ in range(5)])
        print(f"bandwidth {mb} MiB: copy_buffer {n / t_copy / 1e6:.0f} GB/s, compute copy {n / t_cs / 1e6:.0f} GB/s",
              flush=True)
        a.release()
        b.release()


def series(geo, name, kw, maps, res, n=5, between=None, defines=None):
    centre, radius = bounding_sphere(geo.scene)
    clip, rows, _ = ortho_layers(ldm_axes(maps), centre, radius)
    r = gpu.resources()
    s = make_structure(StructureSpec(layout="linked", **kw), gpu, geo, r, layers=maps, width=res, prefix="d.")
    if defines:
        orig = s.defines
        s.defines = lambda: {**orig(), **defines}
    s.set_layers(clip, rows)
    t = []
    for _ in range(n):
        t.append(wall(lambda: s.build(nostage)))
        if between:
            between(s)
    st = s.stats()
    print(f"{name:38s} " + " ".join(f"{x:8.1f}" for x in t) + f"  cap={s.capacity} pages={s.pages} "
          f"frags={st['fragments']} failed={st.get('failed_inserts', '?')} bad={s.invariants(st)}", flush=True)
    r.release()


bandwidth()
n_tri, maps, res = (4000, 16, 32) if DRY else (260000, 512, 200)
r0 = gpu.resources()
geo = SceneGeometry(gpu, load_scene(f"atrium:triangles={n_tri}"), r0)
big = 27_000_000 if not DRY else 200_000
F = dict(pool="fixed", pool_capacity=big)
V = [
    ("sorted fixed", F, None, None),
    ("sorted grow (gpu.read)", dict(), None, None),
    ("sorted lazy (gpu.read)", dict(pool="lazy"), None, None),
    ("sorted fixed, stats between (gpu.read)", F, lambda s: s.stats(), None),
    ("sorted fixed, counters read directly", F, lambda s: s.counters_buf.read(), None),
    ("sorted fixed, nodes read directly", F, lambda s: s.node_pages[0].read(size=1 << 20), None),
    ("yang fixed", dict(F, sorted_insert=False), None, None),
    ("yang fixed, counters read directly", dict(F, sorted_insert=False), lambda s: s.counters_buf.read(), None),
    ("splat sorted grow (gpu.read)", dict(source="splat"), None, None),
]
for name, kw, between, d in V:
    try:
        series(geo, name, kw, maps, res, between=between, defines=d)
    except Exception as e:  # noqa: BLE001
        print(name, "failed", type(e).__name__, e, flush=True)
seen = {}
for m in MSGS:
    seen[m[:300]] = seen.get(m[:300], 0) + 1
print(f"GL debug messages: {len(MSGS)}")
for m, c in list(seen.items())[:60]:
    if "HOST" not in m and "DMA" not in m and "SYSTEM" not in m:
        continue
    print(f"  [{c}x] {m}")
