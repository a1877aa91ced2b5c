"""LDM single-bounce indirect light: photon differentials traced through the maps and splatted into the
camera view (aalund2015 §3.4, §4.2; docs/reference/methods/ldm_indirect.md). Used by :class:`ldbench.methods.ldm.Ldm` for the
``indirect`` effect (LDDE paths, no direct term).

Per frame, after the camera G-buffer and the LDM build of the adapter (stages):

================  =====================================================================================
``light_raster``  the shared :class:`~ldbench.methods.gbuffer.GBuffer` rendered from each spot light: an R × R
                  pinhole raster whose field of view is twice the cut-off angle (first hits x₁, normals
                  facing the light, albedo). One photon per texel inside the cone.
``trace``         ``photon_trace.glsl``: flux I·falloff·Ω_texel, ray differential of the texel, transfer
                  to x₁, split into the N map directions in x₁'s hemisphere (weights albedo·cos, see
                  ``estimator``), second hit x₂ by the LDM two-way query, camera visibility (G-buffer),
                  diffuse reflection of the differential (the rotation α(ω_i, d₂) taking ω_i = −d₁,
                  or d₁ with ``rotation = "propagation"``, to d₂), transfer to x₂, store.
                  The photon buffer grows like the LDM pool: the count is read back after the trace; a
                  buffer too small is re-allocated to the count and the trace redone (counted in
                  ``photon_trace_passes``); one more than twice too large is shrunk before the next frame.
``splat``         ``photon_splat.glsl``: every stored photon splatted with Silverman's kernel over its
                  footprint, ``splat = "blend"`` (points → geometry-shader quads → additive blending,
                  the paper's) or ``"atomic"`` (a compute pass with float atomics).
================  =====================================================================================

Counters (an untimed statistics pass re-traces the same photons and sorts every candidate by fate):
``photons_emitted`` (texels inside the cone), ``photons_hit`` (primary photons that hit the scene),
``photon_candidates`` (secondary photons with non-zero weight), ``photons_stored``,
``photons_offscreen`` and ``photons_hidden`` (discarded by the camera visibility test),
``photons_escaped`` (the trace left the scene), ``photons_dropped`` (differential bias),
``splats_clipped`` (behind the eye or larger than ``max_splat_px``), and the power (W, mean of RGB) of
each: ``power_*``; ``splat_pixels`` (the drawn splats' total screen area: about the fragments shaded); ``power_reflected`` = Σ photon flux × albedo at x₁. Invariants: no photon lost to a
full buffer, the trace's atomic count equals the statistics pass's, every candidate has exactly one
fate, and with ``estimator = "ratio"`` the candidates carry exactly the reflected power.
"""
from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from ldbench.core.bindings import B
from ldbench.core.errors import LdbenchError
from ldbench.core.gpu import read_texture
from ldbench.core.scene import Camera
from ldbench.methods.base import View
from ldbench.methods.lights import set_spot_uniforms
from ldbench.methods.gbuffer import GBuffer, mat_bytes
from ldbench.methods.structures import fill_uint
from ldbench.methods.structures.splat import fill_rule, rule_defines

if TYPE_CHECKING:
    import moderngl

PHOTON_BYTES = 64
#: widest spot light one pinhole raster covers (field of view = 2 × cut-off)
MAX_CUTOFF_DEG = 80.0
#: fates of a photon in the statistics pass (index = slot of ``PhotonStats`` in photon_trace.glsl)
FATES = {0: "emitted", 1: "hit", 2: "candidates", 3: "stored", 4: "offscreen", 5: "hidden", 6: "escaped",
         7: "dropped", 9: "reflected"}
_COUNT_NAMES = {"emitted": "photons_emitted", "hit": "photons_hit", "candidates": "photon_candidates",
                "stored": "photons_stored", "offscreen": "photons_offscreen", "hidden": "photons_hidden",
                "escaped": "photons_escaped", "dropped": "photons_dropped"}
_WORKGROUPS = 65535


def light_camera(light) -> Camera:
    """The pinhole of a spot light's raster: at the light, along its axis, field of view 2 × cut-off."""
    if light.cutoff_angle > MAX_CUTOFF_DEG:
        raise LdbenchError(f"method 'ldm': the indirect effect needs spot lights with cutoff_angle <= "
                           f"{MAX_CUTOFF_DEG:g} degrees (one pinhole raster covers the cone); a light has "
                           f"{light.cutoff_angle:g}")
    d = light.direction()
    up = np.asarray(light.up, float)
    if np.linalg.norm(np.cross(d, up)) < 1e-6 * max(float(np.linalg.norm(up)), 1e-30):
        up = np.eye(3)[int(np.argmin(np.abs(d)))]  # the fall-off is symmetric: any up will do
    return Camera(light.position, light.target, tuple(up), 2.0 * light.cutoff_angle)


class IndirectLight:
    """The indirect-light passes of one :class:`~ldbench.methods.ldm.Ldm` adapter (its maps, G-buffer, params)."""

    def __init__(self, ldm):
        self.m, self.gpu, self.p = ldm, ldm.gpu, ldm.params.indirect
        self.lights = list(ldm.scene.lights)
        if not self.lights:
            raise LdbenchError("method 'ldm': the indirect effect needs a spot light in the scene")
        R = self.p.photons
        self.cams = [light_camera(l) for l in self.lights]
        self.lres = self.gpu.resources("light.")
        self.lgbuf = GBuffer(self.gpu, ldm.geo, self.lres)
        self.lviews = [View(c, R, R) for c in self.cams]
        res = ldm.res
        self.count_buf = res.buffer("photons.count", reserve=4)
        self.max_capacity = max(1, int(ldm.ls.ssbo_limit) // PHOTON_BYTES)
        self.capacity, self._shrink_to, self.trace_passes = 0, 0, 0
        self.vao: moderngl.VertexArray | None = None  # the splat's, made at its first use
        self._allocate(min(self.max_capacity, max(1024, 4 * R * R)))
        self.out = self.fbo = self.accum = None
        self._size = None
        self.view = None
        self.n_stored = 0
        self.splat_prog = self.gpu.program(ldm.shader("photon_splat.glsl"))
        self.splat_cs = (self._compute("photon_splat.glsl", {"SPLAT_ATOMIC": 1, **rule_defines(fill_rule(self.gpu))})
                         if self.p.splat == "atomic" else None)
        self.trace_defines = {**ldm.ls.defines(), "REFINE_HIT": int(self.p.refine_hit),
                              "ROTATE_INCIDENT": int(self.p.rotation == "incident")}
        self.trace_cs = self.gpu.compute(ldm.shader("photon_trace.glsl"), self.trace_defines)

    # ---- buffers ---------------------------------------------------------------------------------
    def _allocate(self, n: int):
        self.capacity = int(min(max(n, 1), self.max_capacity))
        if self.vao is not None:
            self.vao.release()  # bound to the old buffer
        self.vao = None
        self.photons = self.m.res.buffer("photons.buffer", reserve=PHOTON_BYTES * self.capacity)

    def _outputs(self, w: int, h: int):
        if self._size == (w, h):
            return
        res = self.m.res
        if self.fbo is not None:
            self.fbo.release()
            self.fbo = None
        if self.p.splat == "blend":
            res.free("photons.accum")
            self.out = res.texture("photons.output", (w, h), 4, "f4")
            self.fbo = self.gpu.ctx.framebuffer([self.out])
        else:
            res.free("photons.output")
            self.accum = res.buffer("photons.accum", reserve=12 * w * h)
        self._size = (w, h)

    # ---- passes ----------------------------------------------------------------------------------
    def _set_trace_uniforms(self, cs, li: int, view):
        p, m = self.p, self.m
        cam = self.cams[li]
        r, u, f = cam.basis()
        set_spot_uniforms(cs, self.lights[li])
        for name, v in (("light_right", r), ("light_up", u), ("light_fwd", f)):
            cs[name].value = tuple(float(x) for x in v)
        cs["light_tan"].value = math.tan(math.radians(cam.fov_y) / 2)
        cs["photons_side"].value = p.photons
        cs["view_proj"].write(mat_bytes(m.gbuf.view_proj(view)))
        cs["image_size"].value = (view.width, view.height)
        cs["vis_tol"].value = p.visibility_bias * m.texel
        cs["diff_max"].value = p.differential_bias * m.radius
        cs["estimator"].value = 0 if m.params.trace.estimator == "ratio" else 1
        if "capacity" in cs:
            cs["capacity"].value = self.capacity
        for name, unit in (("l_position", 0), ("l_normal", 1), ("l_albedo", 2), ("c_position", 3),
                           ("c_normal", 4)):
            cs[name].value = unit
        self.lgbuf.bind(0)
        m.gbuf.position.use(3)
        m.gbuf.normal.use(4)
        m._bind_maps(cs)

    def _trace_all(self, view):
        """Light raster and trace for every light into the photon buffer (count reset first)."""
        gpu = self.gpu
        self.count_buf.write(np.zeros(1, np.uint32).tobytes())
        groups = (self.p.photons + 7) // 8
        for li, lview in enumerate(self.lviews):
            with gpu.stage("light_raster"):
                self.lgbuf.render(lview)
            with gpu.stage("trace"):
                cs = self.trace_cs
                self._set_trace_uniforms(cs, li, view)
                self.photons.bind_to_storage_buffer(B.PHOTONS)
                self.count_buf.bind_to_storage_buffer(B.PHOTON_COUNT)
                cs.run(groups, groups)
                gpu.ctx.memory_barrier()
        self.trace_passes += 1

    def _trace(self, view):
        gpu = self.gpu
        if self._shrink_to:
            self._allocate(self._shrink_to)
            self._shrink_to = 0
        self.trace_passes = 0
        self._trace_all(view)
        with gpu.stage("trace"):
            n = int(np.frombuffer(self.gpu.read(self.count_buf), np.uint32)[0])  # the pool-growth read-back
        if n > self.capacity and self.capacity < self.max_capacity:
            self._allocate(n)
            self._trace_all(view)
        elif n < self.capacity // 2:
            self._shrink_to = max(n, 1024)  # the buffer is in use this frame: shrink at the next one
        self.n_attempted = n
        self.n_stored = min(n, self.capacity)

    def _splat_uniforms(self, prog, view):
        p = self.p
        prog["view_proj"].write(mat_bytes(self.m.gbuf.view_proj(view)))
        for name, v in (("image_size", (float(view.width), float(view.height))),
                        ("footprint_scale", p.footprint_scale), ("topology", p.topology_bias),
                        ("max_splat_px", p.max_splat_px)):
            if name in prog:  # the statistics variant does not use them all
                prog[name].value = v

    def _splat(self, view):
        gpu, ctx, n = self.gpu, self.gpu.ctx, self.n_stored
        g = self.m.gbuf
        with gpu.stage("splat"):
            if self.p.splat == "blend":
                prog = self.splat_prog
                self._splat_uniforms(prog, view)
                prog["g_position"].value = 0
                prog["g_albedo"].value = 2
                g.bind(0)
                self.fbo.use()
                self.fbo.clear(0.0, 0.0, 0.0, 0.0)
                if n:
                    if self.vao is None:
                        self.vao = ctx.vertex_array(prog, [(self.photons, "4f 4f 4f 3f 4x", "p_x", "p_du", "p_dv",
                                                            "p_n")])
                    ctx.disable(ctx.DEPTH_TEST | ctx.CULL_FACE)
                    with self.gpu.blending((ctx.ONE, ctx.ONE)):
                        self.vao.render(mode=ctx.POINTS, vertices=n)
            else:
                w, h = self._size
                fill_uint(gpu, self.accum, 3 * w * h, 0)
                cs = self.splat_cs
                if n:
                    self._splat_uniforms(cs, view)
                    cs["n_photons"].value = n
                    cs["g_position"].value = 0
                    cs["g_albedo"].value = 2
                    g.bind(0)
                    self.photons.bind_to_storage_buffer(B.PHOTONS)
                    self.accum.bind_to_storage_buffer(B.PHOTON_ACCUM)
                    cs.run(min(n, _WORKGROUPS))  # one workgroup per photon
                    ctx.memory_barrier()

    def _compute(self, name, defines):
        try:
            return self.gpu.compute(self.m.shader(name), defines)
        except LdbenchError as e:
            if "GL_NV_shader_atomic_float" not in self.gpu.ctx.extensions:
                raise LdbenchError(f"method 'ldm': {name} with {defines} needs GL_NV_shader_atomic_float, "
                                   f"which this GPU lacks ({self.gpu.info['GL_RENDERER']})") from e
            raise

    def frame(self, view):
        """Trace and splat (stages ``light_raster``, ``trace``, ``splat``) after the adapter's G-buffer and
        maps; returns a lazy (H × W × 3, row 0 at the top) image callable."""
        self.view = view
        self._outputs(view.width, view.height)
        self._trace(view)
        self._splat(view)
        if self.p.splat == "blend":
            out = self.out
            return lambda: read_texture(out, 3)
        acc, (w, h) = self.accum, self._size
        return lambda: np.ascontiguousarray(np.frombuffer(self.gpu.read(acc), np.float32).reshape(h, w, 3)[::-1])

    # ---- read-back (untimed) ---------------------------------------------------------------------
    def photon_array(self) -> np.ndarray:
        """The stored photons of the last frame as an (n, 16) float32 array (tests, debugging)."""
        n = self.n_stored
        if not n:
            return np.zeros((0, 16), np.float32)
        return np.frombuffer(self.gpu.read(self.photons, n * PHOTON_BYTES), np.float32).reshape(n, 16).copy()

    def counters(self) -> dict:
        """Re-trace the last frame's photons with the statistics variant (untimed) and count every fate."""
        out = {"photons": self.p.photons, "photon_capacity": self.capacity, "photon_trace_passes":
               self.trace_passes, "photons_counted": self.n_attempted}
        if self.view is None:
            return out
        try:
            cs = self.gpu.compute(self.m.shader("photon_trace.glsl"), {**self.trace_defines, "PHOTON_STATS": 1})
            ss = self.gpu.compute(self.m.shader("photon_splat.glsl"), {"SPLAT_STATS": 1})
        except LdbenchError:
            out["photon_stats"] = "unavailable (needs GL_NV_shader_atomic_float)"
            return out
        stats = self.gpu.ctx.buffer(reserve=128)
        try:
            stats.write(np.zeros(32, np.uint32).tobytes())
            for li, lview in enumerate(self.lviews):
                if len(self.lviews) > 1 or li != len(self.lviews) - 1:
                    self.lgbuf.render(lview)  # the last light's raster is still there
                self._set_trace_uniforms(cs, li, self.view)
                stats.bind_to_storage_buffer(B.PHOTON_STATS)
                g = (self.p.photons + 7) // 8
                cs.run(g, g)
                self.gpu.ctx.memory_barrier()
            raw = self.gpu.read(stats)
            counts, power = np.frombuffer(raw[:64], np.uint32), np.frombuffer(raw[64:], np.float32)
            for i, name in FATES.items():
                if name in _COUNT_NAMES:
                    out[_COUNT_NAMES[name]] = int(counts[i])
                out[f"power_{name}"] = float(power[i])
            stats.write(np.zeros(32, np.uint32).tobytes())
            if self.n_stored:
                self._splat_uniforms(ss, self.view)
                ss["n_photons"].value = self.n_stored
                self.photons.bind_to_storage_buffer(B.PHOTONS)
                stats.bind_to_storage_buffer(B.PHOTON_STATS)
                ss.run(min(-(-self.n_stored // 64), _WORKGROUPS))
                self.gpu.ctx.memory_barrier()
            raw = self.gpu.read(stats)
            out["splats_clipped"] = int(np.frombuffer(raw[:4], np.uint32)[0])
            out["power_splats_clipped"] = float(np.frombuffer(raw[64:68], np.float32)[0])
            out["splat_pixels"] = float(np.frombuffer(raw[68:72], np.float32)[0])
        finally:
            stats.release()
        return out

    def invariants(self, c: dict) -> list[str]:
        out = []
        if c.get("photons_counted", 0) > c.get("photon_capacity", 0):
            out.append(f"{c['photons_counted'] - c['photon_capacity']} of {c['photons_counted']} photons not "
                       f"stored (photon buffer full)")
        if "photons_stored" not in c:
            return out
        if c["photons_stored"] != c["photons_counted"]:
            out.append(f"trace stored {c['photons_counted']} photons, its statistics pass finds "
                       f"{c['photons_stored']}")
        fates = sum(c[k] for k in ("photons_stored", "photons_offscreen", "photons_hidden", "photons_escaped",
                                   "photons_dropped"))
        if fates != c["photon_candidates"]:
            out.append(f"{c['photon_candidates']} candidate photons but {fates} fates")
        if self.m.params.trace.estimator == "ratio" and c["power_reflected"] > 0:
            err = abs(c["power_candidates"] / c["power_reflected"] - 1.0)
            if err > 1e-3:
                out.append(f"split weights do not sum to 1 (candidates carry {err:.2%} off the reflected power)")
        return out

    def memory(self) -> dict:
        return self.lres.by_buffer()

    def release(self):
        for obj in (self.fbo, self.vao, getattr(self.lgbuf, "fbo", None)):
            if obj is not None:
                obj.release()
        self.fbo = self.vao = None
        self.lres.release()
