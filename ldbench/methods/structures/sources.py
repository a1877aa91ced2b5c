"""Fragment sources: how a structure's fragment pass finds the fragments of every layer.

A source is attached to one structure (:meth:`~ldbench.methods.structures.core.LayeredStructure.attach_source`)
and runs each fragment pass of its layout and assembly (``run(extra, capacity)``: every fragment stored
with ``ls_store`` compiled with the ``extra`` defines). The sources (``spec.source``):

* ``raster`` (:class:`Raster`): the scene rasterized in each layer's own view, one instanced draw
  (``gl_InstanceID`` = layer; ``spec.instanced = False``: one draw per layer, the "brute force" of
  archer2019), both faces, no depth test (``ldbench/methods/glsl/layered/build.glsl``). Texel centres are sampled
  exactly.
* ``one_pass`` (:class:`OnePass`, archer2019 §3.1): the scene rasterized *once*, each triangle swizzled
  to its dominant axis over the square of a bounding sphere (default the geometry's; ``raster_size``²
  samples, default the layer size), and every fragment projected into each layer in the fragment shader
  (``ldbench/methods/glsl/layered/build_one_pass.glsl``); ``pass_layers`` > 0 splits the layers into passes of
  that many (1 = one raster per layer of the *same* fragments: identical lists up to order). Not
  conservative: a layer sees a triangle's fragments at the raster's sample positions, not at its own
  texel centres (holes where a triangle is more face-on to the layer than to its dominant axis, extra
  fragments where it is edge-on).
* ``splat`` (:class:`ldbench.methods.structures.splat.Splat`): a compute-shader rasterizer of the small triangles
  with the hardware's fill rule (the same fragments as ``raster``), the triangles longer than
  ``splat_max`` texels by a compute pass over tiles of the layers or by the hardware (``splat_large``), in
  the same pass (affine layers only).
* ``peel`` (:class:`ldbench.methods.structures.peel.Peel`): depth peeling; it assembles the linear arrays
  itself (``assembles``) instead of serving count and fill passes.
"""
from __future__ import annotations

import numpy as np

from ldbench.core.gpu import GLSL_DIR

from .core import B_ALBEDO, bounding_sphere


class FragmentSource:
    """Base of the sources: the defaults of what a source adds to its structure's build."""

    #: True: the source builds the arrays itself (:meth:`assemble`) instead of serving fragment passes
    assembles = False

    def __init__(self, structure):
        self.s = structure

    def run(self, extra: dict, capacity: int):
        raise NotImplementedError

    def assemble(self, stage):
        raise NotImplementedError

    def stats(self) -> dict:
        """The source's counters (merged into the structure's :meth:`stats`)."""
        return {}

    def invariants(self, stats: dict) -> list[str]:
        return []

    def free_scratch(self):
        """Release buffers only the build needs (none by default)."""

    def unsorted_lists(self):
        """``None``: the last pass may have left any list unsorted (the splat's tiles may sort most of them:
        :meth:`ldbench.methods.structures.splat.Splat.unsorted_lists`)."""
        return None

    def uniforms(self, prog, capacity: int):
        """Bind the structure and set the uniforms every build shader may use."""
        s = self.s
        for name, v in (("ls_size", (s.width, s.height)), ("ls_capacity", int(capacity))):
            if name in prog:
                prog[name].value = v
        s.bind()
        if "albedo" in s.payload:
            s.geo.albedo.bind_to_storage_buffer(B_ALBEDO)


class Raster(FragmentSource):
    """``raster``: every layer rasterized by the hardware in its own view (module docstring)."""

    shader = "layered/build.glsl"

    def __init__(self, structure):
        super().__init__(structure)
        self._vaos: dict = {}

    def program(self, extra: dict):
        s = self.s
        prog = s.gpu.program(GLSL_DIR / self.shader, {**s.defines(), **extra})
        key = id(prog)
        if key not in self._vaos:
            self._vaos[key] = (s.geo.vao(prog) if s.payload or not s.indexed else s.geo.vao_positions(prog))
        return prog, self._vaos[key]

    def run(self, extra: dict, capacity: int):
        s, ctx = self.s, self.s.gpu.ctx
        prog, vao = self.program(extra)
        self.uniforms(prog, capacity)
        ctx.disable(ctx.DEPTH_TEST | ctx.CULL_FACE | ctx.BLEND)
        s.fbo.use()
        s.fbo.viewport = (0, 0, s.width, s.height)
        if s.instanced:
            if "layer_base" in prog:
                prog["layer_base"].value = 0
            vao.render(instances=s.layers)
        else:
            for k in range(s.layers):
                prog["layer_base"].value = k
                vao.render()
        ctx.memory_barrier()


class OnePass(Raster):
    """``one_pass``: one swizzled raster whose fragments every layer takes (module docstring).
    ``sphere`` = (centre, radius) the raster covers; None: the geometry's bounding sphere."""

    shader = "layered/build_one_pass.glsl"

    def __init__(self, structure, sphere=None):
        super().__init__(structure)
        spec = structure.spec
        c, r = bounding_sphere(structure.geo.scene) if sphere is None else sphere
        self.sphere = (np.asarray(c, np.float64).reshape(3), float(r))
        self.pass_layers = spec.pass_layers
        self.side = spec.raster_size or max(structure.width, structure.height)
        self.fbo = structure.gpu.ctx.empty_framebuffer((self.side, self.side))

    def run(self, extra: dict, capacity: int):
        s, ctx = self.s, self.s.gpu.ctx
        prog, vao = self.program(extra)
        self.uniforms(prog, capacity)
        ctx.disable(ctx.DEPTH_TEST | ctx.CULL_FACE | ctx.BLEND)
        c, r = self.sphere
        prog["op_centre"].value = tuple(float(x) for x in c)
        prog["op_radius"].value = r
        self.fbo.use()
        self.fbo.viewport = (0, 0, self.side, self.side)
        step = self.pass_layers or s.layers
        for k in range(0, s.layers, step):
            prog["layer_base"].value = k
            prog["layer_count"].value = min(step, s.layers - k)
            vao.render()
        ctx.memory_barrier()
