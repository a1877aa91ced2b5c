"""``ldbench new-method NAME``: a working adapter to start from (Python + GLSL), as a plugin package or in
ldbench's own ``methods/`` folder.

=====================  ====================================================================================
``--out DIR``          (default ``./NAME``) a package of its own: ``DIR/pyproject.toml`` with the entry
                       point ``NAME = "<module>:<Class>"`` in group ``ldbench.methods``, and ``DIR/<module>/``
                       holding ``__init__.py`` and ``<module>.glsl``. ``pip install -e DIR`` and ``ldbench
                       methods`` lists it; without installing, ``ldbench run --method <module>:<Class>`` from
                       DIR runs it.
``--in-tree``          ``ldbench/methods/<module>/`` of this ldbench checkout: discovered like every built-in adapter.
=====================  ====================================================================================

The adapter computes a normal-oriented hemisphere screen-space AO on the shared G-buffer (the ``ao``
effect), the smallest complete example of the contract in docs/reference/adapters.md. Nothing is overwritten.
"""
from __future__ import annotations

import contextlib
import importlib.util
import keyword
import os
import re
from pathlib import Path

import ldbench.methods
from ldbench.core.errors import LdbenchError
from ldbench.core.files import check_output_path
from ldbench.methods.base import aliases, registry

PYPROJECT = '''[build-system]
requires = ["setuptools>=64"]
build-backend = "setuptools.build_meta"

[project]
name = "{dist}"
version = "0.1.0"
description = "ldbench method {name}"
requires-python = ">=3.11"
dependencies = ["ldbench"]

[project.entry-points."ldbench.methods"]
{name} = "{module}:{cls}"

[tool.setuptools]
packages = ["{module}"]

[tool.setuptools.package-data]
{module} = ["*.glsl"]
'''

INIT = '''"""``{name}``: (describe the method: paper, what it computes, its stages). docs/reference/adapters.md is the contract.

Stages: ``gbuffer`` (the shared G-buffer), ``{module}`` (``{module}.glsl``, one compute pass).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from ldbench.core.bindings import B
from ldbench.core.errors import LdbenchError
from ldbench.core.gpu import read_texture
from ldbench.methods.base import Method, ParamsBase, Result, param
from ldbench.methods.gbuffer import mat_bytes
from ldbench.methods.uniforms import set_uniforms


@dataclass(frozen=True)
class {cls}Params(ParamsBase):
    samples: int = param(16, "hemisphere samples per pixel", lo=1, hi=256)
    seed: int = param(0, "seed of the per-pixel rotation (mixed with the run's --seed)", lo=0, hi=2**31 - 1)


class {cls}(Method):
    name = "{name}"
    paper = ""
    effects = frozenset({{"ao"}})
    Params = {cls}Params

    def setup(self, gpu, scene):
        """Untimed: scene upload (self.geo), G-buffer (self.gbuf), shaders."""
        self.setup_scene(gpu, scene)
        self.prog = gpu.compute(self.shader("{module}.glsl"))
        self.radius = 0.5 * scene.diagonal()
        self._size = None

    def frame(self, view, effect, inputs=None):
        if effect.name != "ao":
            raise LdbenchError(f"method {{self.name!r}} does not support effect {{effect.name!r}}")
        if effect.falloff != "step" and not math.isinf(effect.d_max):
            raise LdbenchError(f"method {{self.name!r}}: falloff {{effect.falloff!r}} not implemented yet")
        w, h = view.width, view.height
        if self._size != (w, h):
            self.out = self.res.texture("{module}.ao", (w, h), 1, "f4")  # memory-accounted
            self._size = (w, h)
        with self.gpu.stage("gbuffer"):
            self.gbuf.render(view)
        with self.gpu.stage("{module}"):
            d_max = self.radius if math.isinf(effect.d_max) else float(effect.d_max)
            self.prog["view_proj"].write(mat_bytes(self.gbuf.view_proj(view)))
            set_uniforms(self.prog, g_position=0, g_normal=1, eye=tuple(view.camera.origin),
                         samples=self.params.samples, d_max=d_max, seed=self.seed_for(self.params.seed, bits=31))
            self.gbuf.bind(0)  # texture units 0, 1, 2: position, normal, albedo
            self.out.bind_to_image(B.OUT_IMAGE, read=False, write=True)
            self.prog.run((w + 7) // 8, (h + 7) // 8)
        self.gpu.ctx.memory_barrier()
        out = self.out
        return Result(image=lambda: read_texture(out, 1), mask=self.gbuf.mask, memory_bytes=self.res.by_buffer(),
                      counters={{"samples_per_pixel": self.params.samples}})
'''

GLSL = '''// {name}: normal-oriented hemisphere SSAO on ldbench's G-buffer (docs/reference/adapters.md, "G-buffer").
#include "common/common.glsl"

layout(local_size_x = 8, local_size_y = 8) in;
layout(r32f, binding = B_OUT_IMAGE) writeonly uniform image2D out_ao;
uniform sampler2D g_position;   // world position; w = 1 where the pixel's view ray hits
uniform sampler2D g_normal;     // world-space geometric normal facing the camera
uniform mat4 view_proj;         // world -> clip
uniform vec3 eye;
uniform int samples;
uniform float d_max;
uniform uint seed;

uint hash(uint x) {{ x ^= x >> 16; x *= 0x7feb352du; x ^= x >> 15; x *= 0x846ca68bu; x ^= x >> 16; return x; }}
float u01(uint x) {{ return float(hash(x) >> 8) * (1.0 / 16777216.0); }}

void main() {{
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);   // texel (x, y): y = 0 is the image's bottom row
    ivec2 size = imageSize(out_ao);
    if (any(greaterThanEqual(p, size))) return;
    vec4 pos = texelFetch(g_position, p, 0);
    if (pos.w < 0.5) {{ imageStore(out_ao, p, vec4(1.0)); return; }}
    vec3 P = pos.xyz, n = normalize(texelFetch(g_normal, p, 0).xyz);
    vec3 t = normalize(abs(n.x) > 0.5 ? cross(n, vec3(0, 1, 0)) : cross(n, vec3(1, 0, 0)));
    vec3 b = cross(n, t);
    uint key = hash(uint(p.x) * 73856093u ^ uint(p.y) * 19349663u ^ seed * 83492791u);
    float occ = 0.0;
    for (int i = 0; i < samples; ++i) {{
        float z = (float(i) + 0.5) / float(samples), s = sqrt(z), c = sqrt(1.0 - z);
        float phi = float(i) * 2.39996323 + 6.2831853 * u01(key);
        vec3 S = P + (t * (s * cos(phi)) + b * (s * sin(phi)) + n * c) * (d_max * max(u01(key + uint(i) + 1u), 0.05));
        vec4 clip = view_proj * vec4(S, 1.0);
        if (clip.w <= 0.0) continue;
        ivec2 q = ivec2(floor((clip.xy / clip.w * 0.5 + 0.5) * vec2(size)));
        if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, size))) continue;
        vec4 Q = texelFetch(g_position, q, 0);
        if (Q.w > 0.5 && distance(eye, Q.xyz) < distance(eye, S) && distance(Q.xyz, P) < d_max) occ += 1.0;
    }}
    imageStore(out_ao, p, vec4(1.0 - occ / float(samples)));
}}
'''


def names(name: str) -> dict:
    """The method name and the Python names derived from it (``my-ao`` → module ``my_ao``, class ``MyAo``)."""
    if not re.fullmatch(r"[a-z][a-z0-9]*([-_][a-z0-9]+)*", name or ""):
        raise LdbenchError(f"method name {name!r}: lower-case letters, digits and single '-' or '_' between them, "
                           "starting with a letter (e.g. my-ao)")
    module = name.replace("-", "_")
    if keyword.iskeyword(module):
        raise LdbenchError(f"method name {name!r} is a Python keyword")
    cls = "".join(part.capitalize() for part in re.split(r"[-_]", name))
    return {"name": name, "module": module, "cls": cls, "dist": f"ldbench-{name}"}


def check_free(n: dict, in_tree: bool) -> None:
    """Refuse a name that an existing method (built-in, installed or registered, by name or alias) already
    has, and a module name that would shadow one (an in-tree module of ``ldbench/methods/``, or an importable
    top-level module such as ``json`` for a package of its own): the template would never be the method
    that name runs, or would break the one it hides."""
    reg = registry()
    taken = n["name"] if n["name"] in reg else aliases().get(n["name"])
    if taken:
        raise LdbenchError(f"method name {n['name']!r} is taken by the existing method {taken!r} "
                           f"({reg[taken].__module__}); choose another name")
    if in_tree:
        here = Path(ldbench.methods.__path__[0])
        for p in (here / n["module"], here / f"{n['module']}.py"):
            if os.path.lexists(p):
                raise LdbenchError(f"method name {n['name']!r}: {p} exists (module {n['module']!r} of ldbench.methods); "
                                   "choose another name")
        return
    try:
        spec = importlib.util.find_spec(n["module"])
    except (ImportError, ValueError):
        spec = None
    if spec is not None:
        where = spec.origin or ", ".join(spec.submodule_search_locations or []) or "built in"
        raise LdbenchError(f"method name {n['name']!r}: a module {n['module']!r} is already importable ({where}); "
                           "the plugin's package would shadow it or be shadowed: choose another name")


def write_template(name: str, *, out=None, in_tree: bool = False) -> list:
    """Write the template (module docstring); returns the files written. Everything is checked first (the
    name, the output folder, that no file exists); a write that fails midway removes what it wrote, so a
    failure leaves nothing behind."""
    n = names(name)
    check_free(n, in_tree)
    if in_tree:
        pkg = Path(ldbench.methods.__path__[0]) / n["module"]
        files = [(pkg / "__init__.py", INIT), (pkg / f"{n['module']}.glsl", GLSL)]
        check_output_path(pkg, into=True, flag="--in-tree")
    else:
        root = Path(out) if out else Path(n["name"])
        pkg = root / n["module"]
        files = [(root / "pyproject.toml", PYPROJECT), (pkg / "__init__.py", INIT), (pkg / f"{n['module']}.glsl", GLSL)]
        check_output_path(pkg, into=True)  # the deepest folder written: every name on the way, and the disk
    for path, _ in files:
        if os.path.lexists(path):
            raise LdbenchError(f"{path} exists; ldbench new-method never overwrites a file")
    made: list[Path] = []  # what this call created, removed again when a write fails
    try:
        missing = [d for d in (pkg, *pkg.parents) if not os.path.lexists(d)]
        for d in reversed(missing):
            d.mkdir()
            made.append(d)
        for path, text in files:
            with open(path, "x", encoding="utf-8") as fh:  # "x": never replaces a file created meanwhile
                made.append(path)
                fh.write(text.format(**n))
    except BaseException:
        for p in reversed(made):
            with contextlib.suppress(OSError):
                p.rmdir() if p.is_dir() and not p.is_symlink() else p.unlink()
        raise
    return [p for p, _ in files]
