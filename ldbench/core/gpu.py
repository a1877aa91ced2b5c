"""Headless GPU context, shader loading, memory accounting and stage timing.

One :class:`Gpu` wraps one moderngl EGL context (OpenGL >= 4.3, for compute shaders and SSBOs).

Stage timing implements the timing protocol of docs/design.md: :meth:`Gpu.stage` (a GL timer query, or
wall clock on a software rasterizer) and :meth:`begin_frame` / :meth:`end_frame` around whole frames.

Shaders: one ``.glsl`` file per program with stage sections selected by ``#if defined(VERTEX_SHADER)``
etc. (as moderngl-window does), ``#include "file.glsl"`` resolved beside the file and then in
``ldbench/methods/glsl/``, whose shared files sit in folders named in the include (``common/``, ``gbuffer/``,
``layered/``, ``lights/``, ``oit/``: ``#include "layered/linked_list.glsl"``); and default ``#define``s injected after ``#version``, with the binding numbers of
:mod:`ldbench.core.bindings` (``#define B_RAYS 20``...). Every program compiled is checked against that table.
"""
from __future__ import annotations

import ctypes
import logging
import os
import re
import time
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from . import bindings, egl
from .device import classify_device  # noqa: F401 (the one rule; re-exported)
from .errors import LdbenchError

if TYPE_CHECKING:
    import moderngl

# Lazy: moderngl is imported when a Gpu opens (Gpu.__init__ turns its absence into an LdbenchError); a process that
# only reads this module's constants and host checks never loads the GL library.

log = logging.getLogger(__name__)

METHODS_DIR = Path(__file__).resolve().parent.parent / "methods"
GLSL_DIR = METHODS_DIR / "glsl"
STAGES = {
    "vertex_shader": "VERTEX_SHADER",
    "geometry_shader": "GEOMETRY_SHADER",
    "fragment_shader": "FRAGMENT_SHADER",
}
#: one ``#include "x"`` line (blanks only within the line: ``\s`` would also take the newlines before it, and
#: the line numbers after the include would be off by as many)
_INCLUDE = re.compile(r'^[ \t]*#include[ \t]+"([^"]+)"[ \t]*$', re.M)
#: Peak host memory of one job per image pixel: 358 B measured (maximum RSS of `ldbench run` with a
#: report, direct-raster at 1024^2 vs 2048^2 on llvmpipe, whose GPU memory is host memory; ldm-ao 292 B).
HOST_BYTES_PER_PIXEL = 400
#: GPU memory per image pixel: G-buffer (position, normal, albedo RGBA32F, depth) and an RGBA32F output,
#: 68 B in the records' ``memory`` column; rounded up for framebuffers and read-back staging.
GPU_BYTES_PER_PIXEL = 96
_GPU_MEMORY_INFO_CURRENT_AVAILABLE_VIDMEM_NVX = 0x9049  # glGetIntegerv, KiB


LINE_STRIDE = 100_000  # lines a shader file may have: file k of a program is numbered from k · LINE_STRIDE + 1


def expand_includes(path: Path, seen: tuple = (), files: list | None = None) -> str:
    """Source of ``path`` with ``#include "x"`` replaced (beside the file first, then ldbench/methods/glsl/).

    Every included file is framed by ``#line`` directives: file ``k`` of ``files`` (filled in here, ``path``
    first) numbers its lines from ``k · LINE_STRIDE + 1``, and the including file's numbering resumes after it.
    A compiler's line number then names the file and its line (:func:`compile_error`): the source string
    number of ``#line`` would too, but Mesa reports 0 for some of its errors."""
    path = Path(path)
    if path in seen:
        raise LdbenchError(f"recursive #include of {path.name}")
    files = [] if files is None else files
    if path not in files:
        files.append(path)
    me = files.index(path)
    try:
        src = path.read_text()
    except OSError as e:
        raise LdbenchError(f"cannot read shader {path}: {e.strerror}")

    def repl(m):
        name = m.group(1)
        found = next((d / name for d in (path.parent, GLSL_DIR) if (d / name).is_file()), None)
        if found is None:
            found = _flat_include(path, name)
        if found is None:
            line = src.count("\n", 0, m.start()) + 1
            raise LdbenchError(f"{shader_name(path)}:{line}: #include \"{name}\" not found (beside the file or "
                               f"under ldbench/methods/glsl/, e.g. \"common/common.glsl\")")
        body = expand_includes(found, seen + (path,), files)
        line = src.count("\n", 0, m.start()) + 1  # the #include's own line
        k = files.index(found)
        return f"#line {k * LINE_STRIDE + 1} {k}\n{body}\n#line {me * LINE_STRIDE + line + 1} {me}"

    return _INCLUDE.sub(repl, src)


def _flat_include(path: Path, name: str) -> Path | None:
    """A plugin's include by a shared file's bare name (``"common.glsl"``), as it was written before the
    shared files had folders: the one file of that name under ldbench/methods/glsl/, with a deprecation
    message. The project's own shaders must name the folder (``"common/common.glsl"``)."""
    if "/" in name or Path(path).resolve().is_relative_to(METHODS_DIR):
        return None
    hits = sorted(GLSL_DIR.rglob(name))
    if len(hits) != 1:
        return None
    new = hits[0].relative_to(GLSL_DIR).as_posix()
    if (path, name) not in _WARNED_FLAT:
        _WARNED_FLAT.add((path, name))
        log.warning("%s: #include \"%s\" is deprecated: write #include \"%s\"", shader_name(path), name, new)
    return hits[0]


_WARNED_FLAT: set = set()


def shader_source(path, stage_macro: str, defines: dict | None = None, version: int = 430,
                  files: list | None = None) -> str:
    """The whole source of one stage: ``#version``, the stage macro, ``defines``, the binding numbers, then
    ``path`` with its includes (``files``, if given, receives the files in the order of their line numbering:
    :func:`expand_includes`)."""
    header = [f"#version {version}", f"#define {stage_macro} 1"]
    for k, v in (defines or {}).items():
        if isinstance(v, bool):
            v = int(v)
        header.append(f"#define {k} {v}")
    header.append(bindings.glsl_header())
    return "\n".join(header) + "\n#line 1 0\n" + expand_includes(Path(path), files=[] if files is None else files)


#: a compiler message's source string and line: Mesa ``0:46(12): error: ...``, NVIDIA ``0(46) : error C1008: ...``
_MESSAGE = re.compile(r"^\s*(?:ERROR:\s*)?(\d+)(?::(\d+)\(\d+\)|\((\d+)\))\s*:\s*(.*)$")


def shader_name(path: Path) -> str:
    """A shader file as messages name it: relative to methods/ for the project's own, else the full path."""
    path = Path(path).resolve()
    return str(path.relative_to(METHODS_DIR)) if path.is_relative_to(METHODS_DIR) else str(path)


def compile_error(e: Exception, files: list) -> str:
    """The compiler's first error as ``file:line: message`` (the files of :func:`expand_includes`)."""
    lines = [l.strip() for l in str(e).splitlines() if l.strip() and set(l.strip()) != {"="}]
    for l in lines:
        m = _MESSAGE.match(l)
        if m and "error" in m.group(4).lower():
            src, line = divmod(int(m.group(2) or m.group(3)), LINE_STRIDE)
            where = shader_name(files[src]) if src < len(files) else f"source {src}"
            return f"{where}:{line}: {m.group(4)}"[:300]
    return _first_error(e)


def check_bindings(program, path) -> None:
    """Refuse a program whose buffer bindings disagree with :mod:`ldbench.core.bindings` (a block at another
    number than the table's would read another buffer, silently). Storage blocks the table does not name
    are refused only in the project's shaders (under methods/)."""
    strict = Path(path).resolve().is_relative_to(METHODS_DIR)
    errs = bindings.program_mismatches(program, strict=strict)
    if errs:
        program.release()
        raise LdbenchError(f"shader {Path(path).name}: {errs[0]}" + (f" (+{len(errs) - 1} more)" if errs[1:] else ""))


class _GLObject(Protocol):
    """What :class:`Resources` keeps: a moderngl object (buffer, texture, ...) that frees its GPU memory."""

    def release(self) -> None: ...


class Resources:
    """GPU objects one owner (a method, a G-buffer) allocated, with their sizes in bytes.

    Every buffer/texture a method uses goes through here, so the memory column of the records is the
    sum of real allocations, not an estimate.
    """

    def __init__(self, ctx, prefix: str = ""):
        self.ctx, self.prefix = ctx, prefix
        self.objects: dict[str, _GLObject] = {}
        self.bytes: dict[str, int] = {}

    def _add(self, name, obj, nbytes):
        _check_allocation(self.ctx, obj, name, nbytes)
        if name in self.objects:
            self.objects[name].release()
        self.objects[name] = obj
        self.bytes[name] = int(nbytes)
        return obj

    def adopt(self, name: str, obj, nbytes: int | None = None):
        """Account ``obj``, made elsewhere (e.g. a grown copy of a buffer), as ``name``; the object
        that held the name is released. ``nbytes`` defaults to the object's ``size``."""
        return self._add(name, obj, obj.size if nbytes is None else nbytes)

    def buffer(self, name: str, data=None, *, reserve: int = 0, dynamic: bool = False):
        if data is not None:
            data = np.ascontiguousarray(data).tobytes() if isinstance(data, np.ndarray) else data
            buf = self.ctx.buffer(data, dynamic=dynamic)
        else:
            buf = self.ctx.buffer(reserve=max(int(reserve), 4), dynamic=dynamic)
        return self._add(name, buf, buf.size)

    def texture(self, name: str, size, components: int, dtype: str = "f4", data=None):
        tex = self.ctx.texture(tuple(size), components, data, dtype=dtype)
        nbytes = size[0] * size[1] * components * int(dtype[-1])
        return self._add(name, tex, nbytes)

    def depth_texture(self, name: str, size):
        tex = self.ctx.depth_texture(tuple(size))
        return self._add(name, tex, size[0] * size[1] * 4)

    def free(self, name: str) -> None:
        """Release one object (no-op if absent), e.g. a pool page no longer needed."""
        obj = self.objects.pop(name, None)
        self.bytes.pop(name, None)
        if obj is not None:
            obj.release()

    def total(self) -> int:
        return sum(self.bytes.values())

    def by_buffer(self) -> dict:
        return {f"{self.prefix}{k}": v for k, v in self.bytes.items()}

    def release(self):
        for o in self.objects.values():
            o.release()
        self.objects.clear()
        self.bytes.clear()


def _check_allocation(ctx, obj, name: str, nbytes: int) -> None:
    """Raise where the driver could not allocate ``obj``: OpenGL reports it only through glGetError, and a
    buffer or texture whose storage failed reads back undefined contents (garbage counts and images, not
    an error)."""
    if ctx.error == "GL_OUT_OF_MEMORY":
        obj.release()
        raise LdbenchError(f"the GPU is out of memory: {name} ({nbytes / 2**20:.1f} MiB) could not be allocated")


STAGING_KEEP = 16 << 20  # bytes: read-backs up to this size reuse one staging buffer per context
_LIVE: list = []  # Gpu instances not yet released, in creation order (one thread uses them)


class Gpu:
    """A headless OpenGL >= 4.3 context with timing helpers.

    Parameters
    ----------
    require : int
        Minimum GL version as moderngl writes it (430 = 4.3).

    The context opens on the EGL device of this process's GPU (:mod:`ldbench.core.egl`: the first
    ``CUDA_VISIBLE_DEVICES`` GPU through ``EGL_NV_device_cuda``; without an NVIDIA GPU, EGL device 0
    as always). ``selection`` says which, and :attr:`device_columns` are the record's device columns.
    """

    def __init__(self, *, require: int = 430):
        try:
            import moderngl
        except ImportError as e:  # pragma: no cover - packaging error
            raise LdbenchError(f"moderngl is not installed: {e}")

        try:
            self.selection = egl.select_device()
        except Exception:  # a broken EGL install: no choice, the default device as before
            self.selection = egl.Selection(None, egl.visible_gpu(), None, "default")
        # str and int values; moderngl's stub types each setting as a dict, so the mapping is typed loosely
        settings: dict[str, Any] = {"backend": "egl"}
        if self.selection.egl_device is not None:
            settings["device_index"] = self.selection.egl_device
        try:
            self.ctx = moderngl.create_standalone_context(require=require, **settings)
        except Exception as e:
            msg = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
            raise LdbenchError(
                f"no headless OpenGL {require // 100}.{require % 100 // 10} context through EGL ({msg}); "
                "ldbench needs a GPU driver or Mesa llvmpipe with EGL (apt-get install libegl1 libgl1-mesa-dri)")
        self.info = {k: self.ctx.info.get(k) for k in ("GL_RENDERER", "GL_VERSION", "GL_VENDOR")}
        self.device = classify_device(self.info["GL_RENDERER"] or "", self.info["GL_VENDOR"] or "")
        self.device_columns = self.selection.columns()
        self.timer_queries = self.device != "cpu-software"
        self._pending: list = []  # (stage, query or ms) for the current frame
        self._frame_t0 = None
        self._programs: dict = {}
        self._staging: moderngl.Buffer | None = None  # the kept staging buffer of read()
        _LIVE.append(self)

    # ---- shaders -------------------------------------------------------------------------
    def program(self, path, defines: dict | None = None, varyings=()):
        """A vertex/geometry/fragment program from one ``.glsl`` file with stage ``#if``s (cached)."""
        key = ("p", str(path), tuple(sorted((defines or {}).items())))
        if key not in self._programs:
            text = expand_includes(Path(path))
            files: list = []
            src = {k: shader_source(path, m, defines, files=files) for k, m in STAGES.items()
                   if re.search(rf"\b{m}\b", text)}
            try:
                prog = self.ctx.program(vertex_shader=src.get("vertex_shader"),
                                        geometry_shader=src.get("geometry_shader"),
                                        fragment_shader=src.get("fragment_shader"), varyings=tuple(varyings))
            except Exception as e:
                raise LdbenchError(f"shader {Path(path).name} failed to compile: {compile_error(e, files)}")
            check_bindings(prog, path)
            self._programs[key] = prog
        return self._programs[key]

    def compute(self, path, defines: dict | None = None):
        """A compute shader from ``path`` (its ``COMPUTE_SHADER`` section, or the whole file)."""
        key = ("c", str(path), tuple(sorted((defines or {}).items())))
        if key not in self._programs:
            files: list = []
            try:
                prog = self.ctx.compute_shader(shader_source(path, "COMPUTE_SHADER", defines, files=files))
            except Exception as e:
                raise LdbenchError(f"shader {Path(path).name} failed to compile: {compile_error(e, files)}")
            check_bindings(prog, path)
            self._programs[key] = prog
        return self._programs[key]

    def resources(self, prefix: str = "") -> Resources:
        return Resources(self.ctx, prefix)

    # ---- read-back -----------------------------------------------------------------------
    def read(self, buffer, size: int | None = None, offset: int = 0) -> bytes:
        """``size`` bytes of ``buffer`` from ``offset`` (default: to its end), through a staging buffer.

        Never ``buffer.read()`` on a buffer that shaders keep using: NVIDIA's driver moves a buffer the CPU
        reads from video to host memory ("Buffer performance warning: ... is being copied/moved from
        VIDEO memory to HOST memory"), and every later atomic on it crosses PCIe (measured in
        docs/reference/methods/fast_builds.md, "Read-backs"). The GPU copies into this staging buffer, which alone the
        driver may move."""
        size = buffer.size - offset if size is None else int(size)
        if size <= 0:
            return b""
        kept = self._staging
        if size > STAGING_KEEP:  # a large read (a whole structure, in tests and statistics): a staging
            st = self.ctx.buffer(reserve=size, dynamic=True)  # buffer of its own, released below
        elif kept is None or kept.size < size:
            if kept is not None:
                kept.release()
            st = self._staging = self.ctx.buffer(reserve=max(1 << 12, 1 << (size - 1).bit_length()), dynamic=True)
        else:
            st = kept
        if st is not kept:
            try:
                _check_allocation(self.ctx, st, "a staging buffer", size)
            except LdbenchError:
                if st is self._staging:
                    self._staging = None
                raise
        try:
            self.ctx.copy_buffer(st, buffer, size, read_offset=offset)
            return st.read(size=size)
        finally:
            if st is not self._staging:
                st.release()

    @contextmanager
    def blending(self, func: tuple):
        """Additive blending (``FUNC_ADD``) with ``func`` inside the block; after it (also on an error)
        blending is off and the blend function is moderngl's default again."""
        ctx = self.ctx
        ctx.enable(ctx.BLEND)
        ctx.blend_equation = (ctx.FUNC_ADD, ctx.FUNC_ADD)  # rgb, alpha
        ctx.blend_func = func
        try:
            yield
        finally:
            ctx.disable(ctx.BLEND)
            ctx.blend_func = (ctx.SRC_ALPHA, ctx.ONE_MINUS_SRC_ALPHA)  # moderngl's DEFAULT_BLENDING

    # ---- timing --------------------------------------------------------------------------
    def begin_frame(self):
        self.ctx.finish()
        self._pending = []
        self._frame_t0 = time.perf_counter()

    @contextmanager
    def stage(self, name: str):
        """Time one stage of the current frame (GL timer query, or wall clock on llvmpipe)."""
        if self.timer_queries:
            q = self.ctx.query(time=True)
            with q:
                yield
            self._pending.append((name, q))
        else:
            self.ctx.finish()
            t0 = time.perf_counter()
            yield
            self.ctx.finish()
            self._pending.append((name, (time.perf_counter() - t0) * 1e3))

    def end_frame(self) -> tuple[dict, float]:
        """Finish the frame: ({stage: ms}, wall-clock ms). Repeated stage names add up."""
        self.ctx.finish()
        wall = (time.perf_counter() - self._frame_t0) * 1e3 if self._frame_t0 else float("nan")
        stages: dict = {}
        for name, q in self._pending:
            ms = q if isinstance(q, float) else q.elapsed * 1e-6
            stages[name] = stages.get(name, 0.0) + ms
        self._pending, self._frame_t0 = [], None
        return stages, wall

    # ---- limits --------------------------------------------------------------------------
    def check_gl_size(self, width: int, height: int) -> None:
        """Refuse a render target of ``width × height`` beyond this GPU's GL limits (``GL_MAX_TEXTURE_SIZE``,
        ``GL_MAX_RENDERBUFFER_SIZE``, ``GL_MAX_VIEWPORT_DIMS``, ``GL_MAX_FRAMEBUFFER_WIDTH/HEIGHT``)."""
        info = self.ctx.info
        for name, i in (("GL_MAX_TEXTURE_SIZE", None), ("GL_MAX_RENDERBUFFER_SIZE", None),
                        ("GL_MAX_VIEWPORT_DIMS", 0), ("GL_MAX_VIEWPORT_DIMS", 1),
                        ("GL_MAX_FRAMEBUFFER_WIDTH", None), ("GL_MAX_FRAMEBUFFER_HEIGHT", None)):
            lim = info.get(name)
            if lim is None:
                continue
            lim = int(lim[i] if i is not None else lim)
            side = {"GL_MAX_FRAMEBUFFER_WIDTH": width, "GL_MAX_FRAMEBUFFER_HEIGHT": height}.get(
                name, height if i == 1 else width if i == 0 else max(width, height))
            if side > lim:
                raise LdbenchError(f"size {width}x{height} exceeds this GPU's {name} ({lim}; "
                                   f"{self.info['GL_RENDERER']})")

    def check_image_size(self, width: int, height: int) -> None:
        """Refuse, before anything is rendered, an image size this GPU or this machine cannot hold:
        the GL limits (``GL_MAX_TEXTURE_SIZE``, ``GL_MAX_RENDERBUFFER_SIZE``, ``GL_MAX_VIEWPORT_DIMS``,
        ``GL_MAX_FRAMEBUFFER_WIDTH/HEIGHT``), host memory (:data:`HOST_BYTES_PER_PIXEL` against
        ``MemAvailable``) and, where the driver reports it (NVX_gpu_memory_info), GPU memory
        (:data:`GPU_BYTES_PER_PIXEL`)."""
        self.check_gl_size(width, height)
        px = width * height
        host = host_available_bytes()
        if host is not None and px * HOST_BYTES_PER_PIXEL > host:
            raise LdbenchError(f"size {width}x{height} needs about {px * HOST_BYTES_PER_PIXEL / 2**30:.1f} GiB of "
                               f"memory, this machine has {host / 2**30:.1f} GiB available")
        vram = self.available_gpu_memory()
        if vram is not None and px * GPU_BYTES_PER_PIXEL > vram:
            raise LdbenchError(f"size {width}x{height} needs about {px * GPU_BYTES_PER_PIXEL / 2**30:.1f} GiB of "
                               f"GPU memory, {vram / 2**30:.1f} GiB are free")

    def available_gpu_memory(self) -> int | None:
        """Free GPU memory in bytes (GL_NVX_gpu_memory_info), or None where the driver does not say
        (software rasterizers use host memory, checked separately)."""
        if self.device == "cpu-software" or "GL_NVX_gpu_memory_info" not in self.ctx.extensions:
            return None
        try:
            libegl = ctypes.CDLL("libEGL.so.1")
            libegl.eglGetProcAddress.restype = ctypes.c_void_p
            addr = libegl.eglGetProcAddress(b"glGetIntegerv")  # this thread's current context (ours)
            if not addr:
                return None
            get = ctypes.CFUNCTYPE(None, ctypes.c_uint, ctypes.POINTER(ctypes.c_int))(addr)
            kib = ctypes.c_int(-1)
            get(_GPU_MEMORY_INFO_CURRENT_AVAILABLE_VIDMEM_NVX, ctypes.byref(kib))
            self.ctx.error  # reading it clears a GL error the query may have set
            return kib.value * 1024 if kib.value > 0 else None
        except (OSError, AttributeError):
            return None

    def release(self):
        if self._staging is not None:
            self._staging.release()
            self._staging = None
        for p in self._programs.values():
            p.release()
        self._programs.clear()
        self.ctx.release()
        if self in _LIVE:
            _LIVE.remove(self)
        if _LIVE:  # releasing an EGL context leaves none current: hand the thread back to the last live one
            _LIVE[-1].ctx.__enter__()


def host_available_bytes() -> int | None:
    """``MemAvailable`` of /proc/meminfo (Linux), else free physical pages, else None."""
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return None


def _first_error(e: Exception) -> str:
    lines = [l.strip() for l in str(e).splitlines() if l.strip() and set(l.strip()) != {"="}]
    errs = [l for l in lines if "error" in l.lower()]
    return (errs or lines or [type(e).__name__])[0][:300]


def read_texture(tex, components: int | None = None, dtype=np.float32) -> np.ndarray:
    """Read a texture back as H×W×C with row 0 = top (OpenGL's row 0 is the bottom)."""
    c = components or tex.components
    w, h = tex.size
    a = np.frombuffer(tex.read(), dtype=dtype).reshape(h, w, tex.components)[:, :, :c]
    return np.ascontiguousarray(a[::-1])
