"""Mitsuba 3 XML scene files → :class:`~ldbench.core.scene.Scene`, read by Mitsuba's own loader.

``load_mitsuba_xml(path, **params)`` hands the file to Mitsuba's parser (``mitsuba.parser``, the front
end of ``mitsuba.load_file``; variant ``scalar_rgb``, nothing instantiated), which does everything the
XML format defines: ``<default>`` and ``$name`` substitution (``params`` override the defaults, as
``mitsuba.load_file(path, **params)`` does; an unused one is an error), ``<include>``, ``<ref>`` ids,
version upgrades, ``<transform>`` elements composed in double precision, ``rgb``/``spectrum`` values.
This module maps the resulting graph of plugin properties onto a :class:`Scene`:

* BSDFs ``diffuse`` (``reflectance`` a constant colour: ``rgb``, a uniform ``spectrum`` or a ``float``;
  Mitsuba's default 0.5) and ``twosided`` around one diffuse BSDF; no BSDF: diffuse 0.5;
* opacity (the ``oit`` effect's α, :attr:`ldbench.core.scene.Mesh.opacity`): Mitsuba's ``mask`` BSDF around
  a diffuse or twosided BSDF or inside a twosided one, its ``opacity`` one ``float`` in [0, 1]
  (Mitsuba's default 0.5). Textured, rgb or spectral opacity, nested masks and a different front and
  back opacity are errors;
* shapes ``obj``/``ply`` (``filename`` relative to the XML's folder) and the analytic ``rectangle``,
  ``cube``, ``sphere`` (``center``, ``radius``), ``disk`` and ``cylinder`` (``p0``, ``p1``, ``radius``;
  open, as Mitsuba's), tessellated by :mod:`ldbench.core.meshio` in their local frames; ``to_world`` (as
  Mitsuba composed it, float64) is applied here in float64;
* one ``perspective`` sensor (``fov`` + ``fov_axis`` x | y | diagonal | smaller | larger, or
  ``focal_length``; ``to_world``; film width/height, Mitsuba's default 768 × 576), as ldbench's vertical
  field of view for the film's aspect ratio; the film size goes to ``scene.params['film']``. Mitsuba
  cameras look along local +z with local +x towards the image's left; :class:`~ldbench.core.scene.Camera`
  derives right = forward × up, the same (unmirrored) image for every proper rigid sensor transform;
* emitters ``spot`` (``intensity``, ``cutoff_angle``, ``beam_width``, ``to_world``) and ``point``
  (``position`` or ``to_world``, ``intensity``) → :class:`~ldbench.core.scene.SpotLight`.

Area emitters inside shapes (the shape stays geometry) and other emitter types are ignored with a line
in ``scene.warnings``; integrators, samplers, filters and clip planes do not change the geometry and are
ignored. Anything else (other BSDFs, textures, media, other shape or sensor types, several sensors)
raises :class:`LdbenchError` naming the element, its line and the file.

Why not everything from Mitsuba: the reference renders the Scene's own triangles (references/
integrators.py), and ``Scene.content_hash`` keys the reference cache on their exact bytes. Mesh files
are therefore read with :func:`ldbench.core.meshio.read_mesh` (trimesh), like every other ldbench mesh:
Mitsuba's OBJ loader splits a quad (a, b, c, d) as (a, b, c), (a, c, d) where trimesh gives (a, b, c),
(c, d, a), and an instantiated ``scalar_rgb`` scene holds vertices, camera and lights in float32.

ldbench's own layer on top of Mitsuba (:func:`_xml_layer`, xml.etree): the ``<default>`` values, which
Mitsuba's parser substitutes and forgets, recorded in ``scene.params['xml_params']`` (defaults with the
overrides applied), and malformed XML reported with expat's line before Mitsuba sees the file.
Mitsuba's own errors are reduced to one line.
"""
from __future__ import annotations

import importlib
import math
import os
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from . import meshio
from .errors import LdbenchError
from .scene import Camera, Mesh, Scene, SpotLight
from .signals import deferred_interrupt

# Heavy: Mitsuba is imported by _mitsuba() alone, when a Mitsuba XML scene is read.

SUPPORTED_SHAPES = ("obj", "ply", "rectangle", "cube", "sphere", "disk", "cylinder")
DEFAULT_FILM = (768, 576)  # Mitsuba's hdrfilm default
VARIANT = "scalar_rgb"  # the parser's variant: rgb values stay colours (a spectral one makes textures)
COLOUR_HINT = "ldbench supports constant colours (rgb, uniform spectrum, float)"
MASK_HINT = ('ldbench reads opacity as <bsdf type="mask"><float name="opacity" value="0.5"/> around a '
             'diffuse or twosided bsdf, with one opacity in [0, 1]')
BSDF_HINT = "ldbench supports diffuse and twosided(diffuse), optionally in a mask (opacity)"

# Mitsuba's object types as the XML tag that declares them (for messages).
_TAGS = {"Scene": "scene", "Sensor": "sensor", "Film": "film", "Emitter": "emitter", "Sampler": "sampler",
         "Shape": "shape", "Texture": "texture", "Volume": "volume", "Medium": "medium", "BSDF": "bsdf",
         "Integrator": "integrator", "PhaseFunction": "phase", "ReconstructionFilter": "rfilter"}


def _mitsuba():
    """(mitsuba, its parser module) with the ``scalar_rgb`` types registered, without setting a variant
    (the references choose theirs; a scalar variant's module does not start the LLVM backend)."""
    try:
        with deferred_interrupt():  # a Ctrl-C inside the extension's start-up would read as "not installed"
            import mitsuba as mi

            importlib.import_module(f"mitsuba.{VARIANT}")
        return mi, mi.parser
    except ImportError as e:
        raise LdbenchError(f"reading Mitsuba XML needs Mitsuba 3 with its {VARIANT} variant ({e})") from None
    except AttributeError:
        raise LdbenchError(f"reading Mitsuba XML needs mitsuba.parser, which Mitsuba {mi.__version__} lacks: "
                           f"pip install -U mitsuba") from None


def mitsuba_message(e: Exception) -> str:
    """Mitsuba's exception text as one line: source locations (``[parser.cpp:451] ``) dropped,
    whitespace and line breaks collapsed."""
    msg = re.sub(r"\[[\w./-]+:\d+\]\s*", "", str(e))
    return " ".join(msg.split()) or type(e).__name__


def _xml_layer(path: str) -> dict:
    """ldbench's reading of the file itself: ``{name: value}`` of the root's ``<default>`` elements.

    Malformed XML is an LdbenchError with expat's line and column."""
    try:
        root = ET.parse(path).getroot()
    except OSError as e:
        raise LdbenchError(f"cannot read scene file {path}: {e.strerror or e}") from None
    except ET.ParseError as e:
        raise LdbenchError(f"malformed XML in {path}: {e}") from None
    return {d.get("name"): d.get("value") for d in root.findall("default") if d.get("name") is not None}


class _Loader:
    def __init__(self, path: str, params: dict):
        self.path = str(path)
        self.dir = Path(self.path).resolve().parent
        self.overrides = {k: str(v) for k, v in params.items()}
        self.warnings: list[str] = []
        self._albedo: dict[int, tuple] = {}
        self._opacity: dict[int, float] = {}  # id(mask BSDF node) -> its α (see opacity())

    # -- Mitsuba's parse -----------------------------------------------------------------------------
    def parse(self):
        self.mi, parser = _mitsuba()
        self.T = self.mi.Properties.Type
        cfg = parser.ParserConfig(VARIANT)
        cfg.merge_equivalent = False  # keep one node per XML element: ids, lines and order as written
        cfg.merge_meshes = False
        try:
            state = parser.parse_file(cfg, self.path, **self.overrides)
            parser.transform_upgrade(cfg, state)
            parser.transform_resolve(cfg, state)
        except Exception as e:  # Mitsuba raises RuntimeError with a multi-line text
            raise self.parse_error(mitsuba_message(e)) from None
        self.nodes = list(state.nodes)  # one Python object per node: id(node) keys the caches below
        self.files = [str(f) for f in state.files]
        self._text: dict[int, bytes] = {}

    def parse_error(self, msg: str) -> LdbenchError:
        unused = re.findall(r"\$(\w+)=", msg) if "unused parameters" in msg else []
        if unused:
            return LdbenchError(f"parameter {', '.join(map(repr, unused))} is not used by scene file {self.path} "
                                f"(its defaults: {', '.join(self.defaults) or 'none'})")
        msg = re.sub(rf'^Error while loading (XML file )?"?{re.escape(self.path)}"?:? ?', "", msg)
        return LdbenchError(f"Mitsuba cannot load scene file {self.path}" + (" " if msg.startswith("(") else ": ")
                            + msg)

    # -- nodes -----------------------------------------------------------------------------------------
    def tag(self, n) -> str:
        return _TAGS.get(n.type.name, n.type.name.lower())

    def line(self, n):
        """1-based line of a node's element (Mitsuba records its byte offset in its file)."""
        if n.file_index not in self._text:
            try:
                self._text[n.file_index] = Path(self.files[n.file_index]).read_bytes()
            except (OSError, IndexError):
                self._text[n.file_index] = b""
        data = self._text[n.file_index]
        return data.count(b"\n", 0, n.offset) + 1 if data else None

    def file(self, n) -> str:
        """The file a node comes from (the scene file or one it includes)."""
        return self.files[n.file_index] if n.file_index < len(self.files) else self.path

    def where(self, n) -> str:
        return f"line {self.line(n)} of {self.file(n)}"

    def desc(self, n) -> str:
        i = n.props.id()
        attrs = f' type="{n.props.plugin_name()}"' + (f' id="{i}"' if i else "")
        line = self.line(n)
        return f"<{self.tag(n)}{attrs}>" + (f" at line {line}" if line else "")

    def err(self, what: str, n=None, hint: str = "") -> LdbenchError:
        where = f" (element {self.desc(n)})" if n is not None else ""
        return LdbenchError(f"{what}{where} in {self.file(n) if n is not None else self.path}"
                            + (f": {hint}" if hint else ""))

    def children(self, n) -> list:
        """The object nodes nested in (or referenced by) ``n``, in document order, as (name, node)."""
        out = [(n.props[k].index(), k) for k in n.props.keys() if n.props.type(k) == self.T.ResolvedReference]
        return [(k, self.nodes[i]) for i, k in sorted(out)]

    def kind(self, n, tag: str) -> list:
        return [c for _, c in self.children(n) if self.tag(c) == tag]

    # -- values ----------------------------------------------------------------------------------------
    def has(self, n, name: str) -> bool:
        return name in n.props

    def number(self, n, name: str, default: float) -> float:
        if not self.has(n, name):
            return default
        if n.props.type(name) not in (self.T.Float, self.T.Integer):
            raise self.err(f"property {name!r} must be a float", n)
        v = float(n.props[name])
        if not math.isfinite(v):
            raise self.err(f"non-finite {name} {v}", n)
        return v

    def string(self, n, name: str, default=None):
        if not self.has(n, name):
            return default
        return n.props[name] if n.props.type(name) == self.T.String else n.props.as_string(name)

    def vec3(self, n, name: str) -> np.ndarray:
        if n.props.type(name) != self.T.Vector:
            raise self.err(f"property {name!r} must be a point", n)
        v = np.array(n.props[name], np.float64).reshape(3)
        if not np.all(np.isfinite(v)):
            raise self.err(f"non-finite {name} {tuple(v)}", n)
        return v

    def color(self, n, name: str, what: str) -> tuple:
        """A constant colour property: rgb, uniform spectrum, float; textures are errors."""
        t = n.props.type(name)
        if t == self.T.Color:
            v = tuple(float(x) for x in n.props[name])
        elif t == self.T.Spectrum:
            s = n.props[name]
            if not s.is_uniform():
                raise self.err(f"unsupported spectrum for {what}", n, "ldbench supports rgb values and uniform spectra")
            v = (float(s.values[0]),) * 3
        elif t in (self.T.Float, self.T.Integer):
            v = (float(n.props[name]),) * 3
        elif t == self.T.ResolvedReference:
            tgt = self.nodes[n.props[name].index()]
            raise self.err(f"unsupported {self.tag(tgt)} type {tgt.props.plugin_name()!r} for {what}", tgt, COLOUR_HINT)
        else:
            raise self.err(f"unsupported {t.name.lower()} value for {what}", n, COLOUR_HINT)
        if not all(math.isfinite(x) for x in v):
            raise self.err(f"non-finite {what} {v}", n)
        return v

    def to_world(self, n) -> np.ndarray:
        if not self.has(n, "to_world"):
            return np.eye(4)
        if n.props.type("to_world") != self.T.Transform:
            raise self.err("property 'to_world' must be a transform", n)
        M = np.array(n.props["to_world"].matrix, np.float64).reshape(4, 4)
        if not np.all(np.isfinite(M)):
            raise self.err("non-finite transform", n)
        return M

    # -- BSDFs ---------------------------------------------------------------------------------------
    def albedo(self, n) -> tuple:
        key = id(n)
        if key in self._albedo:
            return self._albedo[key]
        t = n.props.plugin_name()
        if t == "diffuse":
            for name, c in self.children(n):
                if name != "reflectance":
                    raise self.err(f"unsupported {self.tag(c)} type {c.props.plugin_name()!r}", c)
            a = self.color(n, "reflectance", "the diffuse reflectance") if self.has(n, "reflectance") \
                else (0.5, 0.5, 0.5)
            if min(a) < 0 or max(a) > 1:
                raise self.err(f"diffuse reflectance {a} outside [0, 1]", n)
        elif t == "twosided":
            inner = self.kind(n, "bsdf")
            for _, c in self.children(n):
                if self.tag(c) != "bsdf":
                    raise self.err(f"unsupported {self.tag(c)} type {c.props.plugin_name()!r}", c)
            if not inner:
                raise self.err("twosided bsdf without a nested bsdf", n, BSDF_HINT)
            if len(inner) > 2:
                raise self.err("twosided bsdf with more than two nested bsdfs", n, BSDF_HINT)
            albs = [self.albedo(c) for c in inner]
            if len(albs) == 2 and not np.allclose(albs[0], albs[1]):
                raise self.err("twosided bsdf with different front and back bsdfs", n, BSDF_HINT)
            a = albs[0]
        elif t == "mask":
            a = self._mask(n)
        else:
            raise self.err(f"unsupported bsdf type {t!r}", n, BSDF_HINT)
        self._albedo[key] = a
        return a

    def _mask(self, n) -> tuple:
        """Albedo of a ``mask`` BSDF's nested BSDF; records the mask's opacity."""
        for name, c in self.children(n):
            if self.tag(c) != "bsdf":
                raise self.err(f"unsupported {self.tag(c)} type {c.props.plugin_name()!r} in a mask bsdf", c,
                               MASK_HINT)
        inner = self.kind(n, "bsdf")
        if len(inner) != 1:
            raise self.err(f"mask bsdf with {len(inner)} nested bsdfs", n, MASK_HINT)
        tgt = inner[0]
        if tgt.props.plugin_name() == "mask" or any(c.props.plugin_name() == "mask" for c in self.kind(tgt, "bsdf")):
            raise self.err("nested mask bsdfs", n, MASK_HINT)
        if not self.has(n, "opacity"):
            alpha = 0.5  # Mitsuba's default
        elif n.props.type("opacity") != self.T.Float:
            kind = {self.T.Color: "<rgb>", self.T.Spectrum: "<spectrum>"}.get(n.props.type("opacity"), "value")
            raise self.err(f"unsupported {kind} as mask opacity", n, MASK_HINT)
        else:
            alpha = float(n.props["opacity"])
            if not 0.0 <= alpha <= 1.0:
                raise self.err(f"mask opacity {alpha} outside [0, 1]", n, MASK_HINT)
        self._opacity[id(n)] = alpha
        return self.albedo(tgt)

    def opacity(self, n) -> float:
        """α of a BSDF already read by :meth:`albedo`: a ``mask``'s opacity, else 1."""
        t = n.props.plugin_name()
        if t == "mask":
            return self._opacity[id(n)]
        if t == "twosided":
            alphas = [self.opacity(c) for c in self.kind(n, "bsdf")]
            if len(set(alphas)) > 1:
                raise self.err("twosided bsdf with different front and back opacity", n, MASK_HINT)
            return alphas[0] if alphas else 1.0
        return 1.0

    # -- shapes ----------------------------------------------------------------------------------------
    def shape(self, n, index: int) -> Mesh:
        t = n.props.plugin_name()
        if t not in SUPPORTED_SHAPES:
            raise self.err(f"unsupported shape type {t!r}", n, f"ldbench supports {', '.join(SUPPORTED_SHAPES)}")
        bsdfs = []
        for _, c in self.children(n):
            tag = self.tag(c)
            if tag == "bsdf":
                bsdfs.append(c)
            elif tag == "emitter":
                if c.props.plugin_name() != "area":
                    raise self.err(f"unsupported emitter type {c.props.plugin_name()!r} inside a shape", c,
                                   "only area emitters may be attached to shapes")
                self.warnings.append(f"area emitter of shape {n.props.id() or t + str(index)!r} ignored "
                                     f"({self.where(c)}): ldbench lights are spot/point emitters; "
                                     f"the shape is kept as geometry")
            else:
                raise self.err(f"unsupported <{tag}> inside a shape", c)
        if len(bsdfs) > 1:
            raise self.err("shape with more than one bsdf", n)
        albedo = self.albedo(bsdfs[0]) if bsdfs else (0.5, 0.5, 0.5)
        alpha = self.opacity(bsdfs[0]) if bsdfs else 1.0
        M = self.to_world(n)
        if t in ("obj", "ply"):
            fn = self.string(n, "filename")
            if not fn:
                raise self.err("shape without a filename", n)
            p = Path(fn) if os.path.isabs(fn) else self.dir / fn  # Mitsuba resolves it from the scene's folder
            if not p.is_file():
                raise self.err(f"mesh file {p} not found", n)
            try:
                v, f = meshio.read_mesh(p)
            except LdbenchError as e:
                raise self.err(str(e), n) from None
        elif t == "rectangle":
            v, f = meshio.rectangle()
        elif t == "cube":
            v, f = meshio.box((-1, -1, -1), (1, 1, 1))
        elif t == "disk":
            v, f = meshio.disk()
        elif t == "cylinder":  # the unit tube along +z mapped onto p0 -> p1 with the radius
            v, f = meshio.tube()
            p0 = self.vec3(n, "p0") if self.has(n, "p0") else np.zeros(3)
            p1 = self.vec3(n, "p1") if self.has(n, "p1") else np.array([0.0, 0.0, 1.0])
            radius = self.number(n, "radius", 1.0)
            axis = p1 - p0
            length = float(np.linalg.norm(axis))
            if not radius > 0 or not length > 0:
                raise self.err(f"cylinder needs a positive radius and p0 != p1, got radius {radius}", n)
            e3 = axis / length
            e1 = np.cross(np.eye(3)[int(np.argmin(np.abs(e3)))], e3)
            e1 /= np.linalg.norm(e1)
            F = np.eye(4)
            F[:3, 0], F[:3, 1], F[:3, 2], F[:3, 3] = e1 * radius, np.cross(e3, e1) * radius, axis, p0
            M = M @ F
        else:  # sphere: Mitsuba's to_world · translate(center) · scale(radius)
            v, f = meshio.icosphere()
            center = self.vec3(n, "center") if self.has(n, "center") else np.zeros(3)
            radius = self.number(n, "radius", 1.0)
            if not radius > 0:
                raise self.err(f"sphere radius must be positive, got {radius}", n)
            S = np.eye(4)
            S[:3, :3] *= radius
            S[:3, 3] = center
            M = M @ S
        v = v @ M[:3, :3].T + M[:3, 3]
        return Mesh(n.props.id() or f"{t}{index}", v.astype(np.float32), f.astype(np.int32), albedo, alpha)

    # -- sensor ----------------------------------------------------------------------------------------
    def sensor(self, n):
        t = n.props.plugin_name()
        if t != "perspective":
            raise self.err(f"unsupported sensor type {t!r}", n, "ldbench supports perspective sensors")
        w, h = DEFAULT_FILM
        for _, c in self.children(n):
            tag = self.tag(c)
            if tag == "film":
                for k in ("crop_offset_x", "crop_offset_y", "crop_width", "crop_height"):
                    if self.has(c, k):
                        raise self.err(f"unsupported film property {k!r}", c)
                w, h = int(self.number(c, "width", w)), int(self.number(c, "height", h))
                if w < 1 or h < 1:
                    raise self.err(f"film size {w}x{h} is not positive", c)
            elif tag != "sampler":
                raise self.err(f"unsupported <{tag}> inside a sensor", c)
        for k in ("principal_point_offset_x", "principal_point_offset_y"):
            if self.number(n, k, 0.0) != 0.0:
                raise self.err(f"unsupported sensor property {k!r}", n)
        aspect = w / h
        axis = (self.string(n, "fov_axis", "x") or "x").lower()
        if self.has(n, "fov"):
            fov = self.number(n, "fov", 0.0)
            if not 0 < fov < 180:
                raise self.err(f"fov {fov} must be in (0, 180) degrees", n)
        else:
            fl = self.string(n, "focal_length", "50mm") or "50mm"
            try:
                f = float(fl.strip().removesuffix("mm"))
            except ValueError:
                raise self.err(f"bad focal_length {fl!r}", n) from None
            if not f > 0:
                raise self.err(f"bad focal_length {fl!r}", n)
            fov, axis = 2 * math.degrees(math.atan(math.hypot(36.0, 24.0) / (2 * f))), "diagonal"
        if axis == "smaller":
            axis = "y" if aspect > 1 else "x"
        elif axis == "larger":
            axis = "x" if aspect > 1 else "y"
        tan_half = math.tan(math.radians(fov) / 2)
        if axis == "x":
            tan_y = tan_half / aspect
        elif axis == "y":
            tan_y = tan_half
        elif axis == "diagonal":
            tan_y = tan_half / math.sqrt(1 + aspect * aspect)
        else:
            raise self.err(f"unsupported fov_axis {axis!r}", n, "use x, y, diagonal, smaller or larger")
        fov_y = 2 * math.degrees(math.atan(tan_y))
        M = self.to_world(n)
        A = M[:3, :3]
        sx, sy, sz = np.linalg.norm(A, axis=0)
        if min(sx, sy, sz) < 1e-12:
            raise self.err("sensor to_world is singular", n)
        U = A / np.array([sx, sy, sz])
        if np.abs(U.T @ U - np.eye(3)).max() > 1e-4 or max(sx, sy, sz) / min(sx, sy, sz) > 1 + 1e-4:
            raise self.err("sensor to_world has shear or non-uniform scale", n,
                           "ldbench cameras are look-at transforms (rotation + translation)")
        if np.linalg.det(U) < 0:
            raise self.err("sensor to_world is mirrored (negative determinant)", n,
                           "ldbench cameras are look-at transforms (rotation + translation)")
        origin = M[:3, 3]
        cam = Camera(origin=tuple(origin), target=tuple(origin + U[:, 2]), up=tuple(U[:, 1]), fov_y=fov_y)
        return cam, (w, h)

    # -- emitters --------------------------------------------------------------------------------------
    def emitter(self, n):
        t = n.props.plugin_name()
        if t not in ("spot", "point"):
            self.warnings.append(f"emitter type {t!r} ignored ({self.where(n)}): ldbench lights are spot/point "
                                 f"emitters")
            return None
        for _, c in self.children(n):
            raise self.err(f"unsupported {self.tag(c)} type {c.props.plugin_name()!r} in a {t} emitter", c)
        intensity = self.color(n, "intensity", "the intensity") if self.has(n, "intensity") else (1.0, 1.0, 1.0)
        M = self.to_world(n)
        if t == "point":
            if self.has(n, "position"):
                if self.has(n, "to_world"):
                    raise self.err("point emitter with both position and to_world", n)
                pos = self.vec3(n, "position")
            else:
                pos = M[:3, 3]
            return SpotLight(position=tuple(pos), target=tuple(pos + np.array([0.0, 0.0, 1.0])),
                             intensity=intensity, cutoff_angle=180.0, beam_width=180.0, up=(0.0, 1.0, 0.0))
        cutoff = self.number(n, "cutoff_angle", 20.0)
        beam = self.number(n, "beam_width", cutoff * 0.75)
        if not 0 < cutoff <= 180 or not 0 <= beam <= cutoff:
            raise self.err(f"bad spot angles (cutoff_angle {cutoff}, beam_width {beam})", n)
        pos = M[:3, 3]
        d = M[:3, :3] @ np.array([0.0, 0.0, 1.0])
        up = M[:3, :3] @ np.array([0.0, 1.0, 0.0])
        if np.linalg.norm(d) < 1e-12:
            raise self.err("spot emitter to_world is singular", n)
        d = d / np.linalg.norm(d)
        up = up - d * (up @ d)
        if np.linalg.norm(up) < 1e-9:
            up = np.array([1.0, 0.0, 0.0]) if abs(d[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
            up = up - d * (up @ d)
        up /= np.linalg.norm(up)
        return SpotLight(position=tuple(pos), target=tuple(pos + d), intensity=intensity,
                         cutoff_angle=cutoff, beam_width=beam, up=tuple(up))

    # -- scene -----------------------------------------------------------------------------------------
    def load(self) -> Scene:
        self.defaults = _xml_layer(self.path)
        self.parse()
        for n in self.nodes:
            if self.tag(n) == "texture":
                raise self.err(f"unsupported texture type {n.props.plugin_name()!r}", n, COLOUR_HINT)
        root = self.nodes[0]
        sensors = self.kind(root, "sensor")
        if len(sensors) > 1:
            raise self.err(f"{len(sensors)} sensors (second one)", sensors[1],
                           "ldbench needs exactly one perspective sensor")
        if not sensors:
            raise LdbenchError(f"no <sensor> in {self.path}: ldbench needs one perspective sensor")
        meshes: list[Mesh] = []
        lights: list[SpotLight] = []
        for _, n in self.children(root):
            tag = self.tag(n)
            if tag in ("integrator", "sensor"):
                continue
            if tag == "bsdf":
                self.albedo(n)  # validate even when unused
            elif tag == "shape":
                meshes.append(self.shape(n, len(meshes)))
            elif tag == "emitter":
                light = self.emitter(n)
                if light is not None:
                    lights.append(light)
            else:
                raise self.err(f"unsupported element <{tag}>", n,
                               "ldbench reads default, integrator (ignored), sensor, bsdf, shape, emitter")
        cam, film = self.sensor(sensors[0])
        if not meshes:
            raise LdbenchError(f"no shapes in {self.path}")
        params = {"film": film}
        values = {**self.defaults, **self.overrides}
        if values:
            params["xml_params"] = dict(sorted(values.items()))
        return Scene(Path(self.path).stem, meshes, cam, lights, params=params, source=self.path,
                     warnings=self.warnings)


def load_mitsuba_xml(path, **params) -> Scene:
    """Read a Mitsuba 3 scene file into a :class:`Scene` (see the module docstring for the subset).

    ``params`` override the file's ``<default>`` values (as ``mitsuba.load_file(path, **params)``).
    """
    return _Loader(os.fspath(path), params).load()
