"""Mitsuba 3 XML scene files → :class:`~harness.scene.Scene`, without needing Mitsuba.

``load_mitsuba_xml(path, **params)`` reads the subset of the Mitsuba 3 scene format that ldbench can
represent, parsing the XML itself (ElementTree elements built by expat, so errors can give line numbers):

* ``<scene version="2.x/3.x">``; ``<default name= value=>`` and ``$name`` substitution in every
  attribute (``params`` override the defaults, as ``mitsuba.load_file(path, **params)`` does);
* BSDFs ``diffuse`` (``reflectance`` as ``<rgb>``, a single-value ``<spectrum>`` or ``<float>``;
  Mitsuba's default 0.5) and ``twosided`` wrapping one diffuse BSDF; named BSDFs (``id``) used through
  ``<ref id=...>``; a shape without a BSDF gets Mitsuba's default diffuse 0.5;
* opacity (the ``oit`` effect's α, :attr:`harness.scene.Mesh.opacity`): Mitsuba's own ``mask`` BSDF,
  ``<bsdf type="mask"><float name="opacity" value="0.4"/> <bsdf type="diffuse">…</bsdf></bsdf>``, around
  a diffuse or twosided BSDF or inside a twosided one; its opacity must be one ``<float>`` in [0, 1]
  (Mitsuba's default 0.5 when absent). Opacity as a texture, an ``<rgb>`` or a spectrum, nested masks
  and a different front and back opacity are errors;
* shapes ``obj``/``ply`` (``filename`` relative to the XML's folder, read with trimesh,
  ``process=False``, all parts merged as Mitsuba does) and the analytic ``rectangle`` ([-1, 1]² in
  z = 0, 2 triangles), ``cube`` ([-1, 1]³, 12 triangles), ``sphere`` (``center``, ``radius``;
  an icosphere of 5120 triangles inscribed in the sphere) and ``disk`` (unit disk in z = 0, 64-gon),
  tessellated here — the reference renders these same triangles;
* ``<transform name="to_world">`` of ``matrix`` (16 or 9 numbers, row-major), ``translate``,
  ``rotate`` (axis, angle in degrees, right-handed; like Mitsuba, the axis is not normalised),
  ``scale``, ``lookat``, composed in Mitsuba's
  order: each element left-multiplies what came before;
* one ``<sensor type="perspective">`` (``fov`` + ``fov_axis`` x | y | diagonal | smaller | larger,
  or ``focal_length``; ``to_world``; ``<film>`` width/height, Mitsuba's default 768 × 576). The
  field of view is converted to ldbench's vertical one for the film's aspect ratio, and the film
  size is kept in ``scene.params['film'] = (width, height)``. Mitsuba cameras look along local +z
  with local +x towards the image's *left*; :class:`~harness.scene.Camera` derives right = forward ×
  up, which is the same image (not mirrored) for every proper (det > 0) rigid sensor transform;
* emitters ``spot`` (``intensity``, ``cutoff_angle``, ``beam_width``, ``to_world``) and ``point``
  (``position`` or ``to_world``, ``intensity``) → :class:`~harness.scene.SpotLight`.

Area emitters inside shapes (the shape stays as geometry) and other emitter types (``constant``,
``envmap``, ``directional``, ...) are ignored with a line in ``scene.warnings``; ``<integrator>`` and
sensor details that do not change the image geometry (sampler, rfilter, clip planes) are ignored.
Everything else that ldbench cannot represent — other BSDFs, textures, several sensors, other shape
or sensor types, media — raises :class:`LdbenchError` naming the element, its line and the file.
"""
from __future__ import annotations

import math
import os
import re
import xml.etree.ElementTree as ET
import xml.parsers.expat
from pathlib import Path

import numpy as np

from . import meshio
from .errors import LdbenchError
from .scene import Camera, Mesh, Scene, SpotLight

SUPPORTED_SHAPES = ("obj", "ply", "rectangle", "cube", "sphere", "disk")
DEFAULT_FILM = (768, 576)  # Mitsuba's hdrfilm default
_PARAM_RE = re.compile(r"\$([A-Za-z_][A-Za-z0-9_]*)")


# ---------------------------------------------------------------------------------------------------
# parsing

def _parse(path: str):
    """(root element, {id(element): line}) of an XML file; malformed XML is an LdbenchError."""
    try:
        data = Path(path).read_bytes()
    except OSError as e:
        raise LdbenchError(f"cannot read scene file {path}: {e.strerror or e}") from None
    parser = xml.parsers.expat.ParserCreate()
    stack, lines, roots = [], {}, []

    def start(tag, attrs):
        el = ET.Element(tag, attrs)
        lines[id(el)] = parser.CurrentLineNumber
        (stack[-1].append(el) if stack else roots.append(el))
        stack.append(el)

    def end(tag):
        stack.pop()

    parser.StartElementHandler, parser.EndElementHandler = start, end
    try:
        parser.Parse(data, True)
    except xml.parsers.expat.ExpatError as e:
        raise LdbenchError(f"malformed XML in {path}: {e}") from None
    return roots[0], lines


class _Loader:
    def __init__(self, path: str, params: dict):
        self.path = str(path)
        self.dir = Path(self.path).resolve().parent
        self.root, self.lines = _parse(self.path)
        self.overrides = {k: str(v) for k, v in params.items()}
        self.warnings: list[str] = []
        self.ids: dict[str, ET.Element] = {}
        self._albedo_cache: dict[int, tuple] = {}
        self._opacity: dict[int, float] = {}  # id(bsdf element) -> α of a mask BSDF (see opacity())

    # -- messages ------------------------------------------------------------------------------------
    def desc(self, el) -> str:
        attrs = "".join(f' {k}="{el.get(k)}"' for k in ("type", "id", "name") if el.get(k) is not None)
        line = self.lines.get(id(el))
        return f"<{el.tag}{attrs}>" + (f" at line {line}" if line else "")

    def err(self, what: str, el=None, hint: str = "") -> LdbenchError:
        where = f" (element {self.desc(el)})" if el is not None else ""
        return LdbenchError(f"{what}{where} in {self.path}" + (f": {hint}" if hint else ""))

    # -- values ----------------------------------------------------------------------------------------
    def floats(self, el, attr: str, n=None, default=None) -> list[float]:
        s = el.get(attr)
        if s is None:
            if default is not None:
                return default
            raise self.err(f"missing attribute {attr!r}", el)
        try:
            vals = [float(x) for x in s.replace(",", " ").split()]
        except ValueError:
            raise self.err(f"bad number in {attr}={s!r}", el) from None
        if not all(math.isfinite(v) for v in vals):
            raise self.err(f"non-finite number in {attr}={s!r}", el)
        if n is not None and len(vals) not in (n if isinstance(n, tuple) else (n,)):
            raise self.err(f"{attr}={s!r} must have {' or '.join(map(str, n if isinstance(n, tuple) else (n,)))} "
                           f"numbers", el)
        return vals

    def vec3(self, el, default=(0.0, 0.0, 0.0)) -> np.ndarray:
        """A point/vector: ``value="x, y, z"`` or ``x= y= z=`` attributes."""
        if el.get("value") is not None:
            return np.array(self.floats(el, "value", 3))
        return np.array([self.floats(el, k, 1, [d])[0] for k, d in zip("xyz", default)])

    def props(self, el) -> dict:
        """name → property element, for the simple property children of an object element."""
        out = {}
        for c in el:
            if c.tag in ("float", "integer", "boolean", "string", "rgb", "spectrum", "point", "vector",
                         "transform", "texture", "bsdf", "ref") and c.get("name"):
                out[c.get("name")] = c
        return out

    def number(self, el, name: str, default: float) -> float:
        c = self.props(el).get(name)
        if c is None:
            return default
        if c.tag not in ("float", "integer"):
            raise self.err(f"property {name!r} must be a float", c)
        return self.floats(c, "value", 1)[0]

    def string(self, el, name: str, default=None):
        c = self.props(el).get(name)
        return default if c is None else c.get("value", "")

    def color(self, c, what: str) -> tuple:
        """A constant colour property: <rgb>, single-value <spectrum>, <float>; textures are errors."""
        if c.tag == "rgb":
            v = self.floats(c, "value", (1, 3))
        elif c.tag == "spectrum":
            if c.get("filename") is not None or ":" in (c.get("value") or ""):
                raise self.err(f"unsupported spectrum for {what}", c,
                               "ldbench supports rgb values and single-value spectra")
            v = self.floats(c, "value", 1)
        elif c.tag in ("float", "integer"):
            v = self.floats(c, "value", 1)
        elif c.tag == "texture":
            raise self.err(f"unsupported texture type {c.get('type')!r} for {what}", c,
                           "ldbench supports constant colours (rgb, single-value spectrum, float)")
        elif c.tag == "ref":
            tgt = self.lookup(c)
            raise self.err(f"unsupported reference to a <{tgt.tag}> for {what}", c,
                           "ldbench supports constant colours (rgb, single-value spectrum, float)")
        else:
            raise self.err(f"unsupported <{c.tag}> for {what}", c)
        return tuple(v * 3 if len(v) == 1 else v)

    # -- substitution ----------------------------------------------------------------------------------
    def substitute(self):
        if self.root.tag != "scene":
            raise self.err("the root element must be <scene>", self.root)
        ver = self.root.get("version")
        if ver is not None:
            m = re.match(r"\s*(\d+)", ver)
            if m is None or int(m.group(1)) < 2:
                raise self.err(f"scene version {ver!r} is the Mitsuba 0.x format", self.root,
                               "ldbench reads Mitsuba 2/3 XML (version 2.0.0 or later)")
        defaults = {}
        for el in self.root.iter("default"):
            if el not in list(self.root):
                raise self.err("<default> must be a direct child of <scene>", el)
            name, value = el.get("name"), el.get("value")
            if not name or value is None:
                raise self.err("<default> needs name and value", el)
            defaults[name] = value
        values = {**defaults, **self.overrides}
        used = set()

        def repl(el, s):
            def one(m):
                k = m.group(1)
                if k not in values:
                    raise self.err(f"undefined parameter ${k}", el,
                                   "declare it with <default name=... value=...> or pass it")
                used.add(k)
                return values[k]
            return _PARAM_RE.sub(one, s)

        for el in self.root.iter():
            if el.tag == "default":
                continue
            for k, v in list(el.attrib.items()):
                if "$" in v:
                    el.set(k, repl(el, v))
        for k in self.overrides:
            if k not in defaults and k not in used:
                raise LdbenchError(f"parameter {k!r} is not used by scene file {self.path} "
                                   f"(its defaults: {', '.join(defaults) or 'none'})")
        self.values = values

    # -- references ------------------------------------------------------------------------------------
    def register_ids(self):
        for el in self.root.iter():
            i = el.get("id")
            if i is not None and el.tag not in ("ref", "default"):
                if i in self.ids:
                    raise self.err(f"duplicate id {i!r}", el)
                self.ids[i] = el

    def lookup(self, ref):
        i = ref.get("id")
        if i is None:
            raise self.err("<ref> without id", ref)
        if i not in self.ids:
            raise self.err(f"reference to undefined id {i!r}", ref)
        return self.ids[i]

    # -- transforms ------------------------------------------------------------------------------------
    def transform(self, el) -> np.ndarray:
        M = np.eye(4)
        for c in el:
            T = np.eye(4)
            if c.tag == "translate":
                T[:3, 3] = self.vec3(c)
            elif c.tag == "scale":
                if c.get("value") is not None:
                    v = self.floats(c, "value", (1, 3))
                    s = v * 3 if len(v) == 1 else v
                else:
                    s = self.vec3(c, (1.0, 1.0, 1.0))
                T[:3, :3] = np.diag(s)
            elif c.tag == "rotate":
                axis = self.vec3(c)
                if not np.any(axis):
                    raise self.err("rotation axis is zero", c)
                # Mitsuba 3.9 does not normalise the axis (a non-unit axis also scales): same here.
                T[:3, :3] = _rotation(axis, self.floats(c, "angle", 1, [0.0])[0])
            elif c.tag == "matrix":
                v = self.floats(c, "value", (16, 9))
                if len(v) == 16:
                    T = np.array(v).reshape(4, 4)
                else:
                    T[:3, :3] = np.array(v).reshape(3, 3)
            elif c.tag == "lookat":
                o, t = (np.array(self.floats(c, k, 3)) for k in ("origin", "target"))
                up = np.array(self.floats(c, "up", 3, [0.0, 1.0, 0.0]))
                T = _lookat(o, t, up)
                if T is None:
                    raise self.err("degenerate lookat (origin = target, or up parallel to the view)", c)
            else:
                raise self.err(f"unsupported transform element <{c.tag}>", c,
                               "ldbench supports matrix, translate, rotate, scale and lookat")
            M = T @ M
        if not np.all(np.isfinite(M)):
            raise self.err("non-finite transform", el)
        return M

    def to_world(self, el):
        c = [x for x in el if x.tag == "transform" and x.get("name") == "to_world"]
        return self.transform(c[0]) if c else np.eye(4)

    # -- BSDFs ---------------------------------------------------------------------------------------
    def albedo(self, el) -> tuple:
        if el.tag == "ref":
            tgt = self.lookup(el)
            if tgt.tag != "bsdf":
                raise self.err(f"reference to a <{tgt.tag}> where a bsdf is expected", el)
            el = tgt
        key = id(el)
        if key in self._albedo_cache:
            return self._albedo_cache[key]
        t = el.get("type")
        hint = "ldbench supports diffuse and twosided(diffuse), optionally in a mask (opacity)"
        if t == "diffuse":
            for c in el:
                if c.tag == "texture" and c.get("name") != "reflectance":
                    raise self.err(f"unsupported texture type {c.get('type')!r}", c)
            c = self.props(el).get("reflectance")
            a = (0.5, 0.5, 0.5) if c is None else self.color(c, "the diffuse reflectance")
            if min(a) < 0 or max(a) > 1:
                raise self.err(f"diffuse reflectance {a} outside [0, 1]", c)
        elif t == "twosided":
            inner = [c for c in el if c.tag in ("bsdf", "ref")]
            if not inner:
                raise self.err("twosided bsdf without a nested bsdf", el, hint)
            if len(inner) > 2:
                raise self.err("twosided bsdf with more than two nested bsdfs", el, hint)
            albs = [self.albedo(c) for c in inner]
            if len(albs) == 2 and not np.allclose(albs[0], albs[1]):
                raise self.err("twosided bsdf with different front and back bsdfs", el, hint)
            a = albs[0]
            for c in el:
                if c.tag == "texture":
                    raise self.err(f"unsupported texture type {c.get('type')!r}", c)
        elif t == "mask":
            a = self._mask(el)
        else:
            raise self.err(f"unsupported bsdf type {t!r}", el, hint)
        self._albedo_cache[key] = a
        return a

    MASK_HINT = ('ldbench reads opacity as <bsdf type="mask"><float name="opacity" value="0.5"/> around a '
                 'diffuse or twosided bsdf, with one opacity in [0, 1]')

    def _mask(self, el) -> tuple:
        """Albedo of a ``mask`` BSDF's nested BSDF; records the mask's opacity (``self._opacity``)."""
        inner = [c for c in el if c.tag in ("bsdf", "ref")]
        if len(inner) != 1:
            raise self.err(f"mask bsdf with {len(inner)} nested bsdfs", el, self.MASK_HINT)
        tgt = self.lookup(inner[0]) if inner[0].tag == "ref" else inner[0]
        if tgt.tag == "bsdf" and (tgt.get("type") == "mask" or any(
                c.tag == "bsdf" and c.get("type") == "mask" for c in tgt)):
            raise self.err("nested mask bsdfs", el, self.MASK_HINT)
        for c in el:
            if c.tag not in ("bsdf", "ref") and c.get("name") != "opacity":
                raise self.err(f"unsupported <{c.tag}> in a mask bsdf", c, self.MASK_HINT)
        c = self.props(el).get("opacity")
        if c is None:
            alpha = 0.5  # Mitsuba's default
        elif c.tag != "float":
            raise self.err(f"unsupported <{c.tag}> as mask opacity", c, self.MASK_HINT)
        else:
            alpha = self.floats(c, "value", 1)[0]
            if not 0.0 <= alpha <= 1.0:
                raise self.err(f"mask opacity {alpha} outside [0, 1]", c, self.MASK_HINT)
        self._opacity[id(el)] = alpha
        return self.albedo(inner[0])

    def opacity(self, el) -> float:
        """α of a shape's BSDF (already read by :meth:`albedo`): a ``mask``'s opacity, else 1."""
        if el.tag == "ref":
            el = self.lookup(el)
        if el.get("type") == "mask":
            return self._opacity[id(el)]
        if el.get("type") == "twosided":
            alphas = [self.opacity(c) for c in el if c.tag in ("bsdf", "ref")]
            if len(set(alphas)) > 1:
                raise self.err("twosided bsdf with different front and back opacity", el, self.MASK_HINT)
            return alphas[0] if alphas else 1.0
        return 1.0

    # -- shapes ----------------------------------------------------------------------------------------
    def shape(self, el, index: int):
        t = el.get("type")
        if t not in SUPPORTED_SHAPES:
            raise self.err(f"unsupported shape type {t!r}", el,
                           f"ldbench supports {', '.join(SUPPORTED_SHAPES)}")
        bsdfs = []
        for c in el:
            if c.tag in ("bsdf", "ref"):
                bsdfs.append(c)
            elif c.tag == "emitter":
                if c.get("type") == "area":
                    self.warnings.append(
                        f"area emitter of shape {el.get('id') or t + str(index)!r} ignored "
                        f"(line {self.lines.get(id(c))} of {self.path}): ldbench lights are spot/point "
                        f"emitters; the shape is kept as geometry")
                else:
                    raise self.err(f"unsupported emitter type {c.get('type')!r} inside a shape", c,
                                   "only area emitters may be attached to shapes")
            elif c.tag in ("texture", "medium", "sensor", "shape"):
                raise self.err(f"unsupported <{c.tag}> inside a shape", c)
        if len(bsdfs) > 1:
            raise self.err("shape with more than one bsdf", el)
        albedo = self.albedo(bsdfs[0]) if bsdfs else (0.5, 0.5, 0.5)
        alpha = self.opacity(bsdfs[0]) if bsdfs else 1.0
        M = self.to_world(el)
        if t in ("obj", "ply"):
            fn = self.string(el, "filename")
            if not fn:
                raise self.err("shape without a filename", el)
            p = Path(fn) if os.path.isabs(fn) else self.dir / fn
            if not p.is_file():
                raise self.err(f"mesh file {p} not found", el)
            try:
                v, f = meshio.read_mesh(p)
            except LdbenchError as e:
                raise self.err(str(e), el) from None
        elif t == "rectangle":
            v, f = meshio.rectangle()
        elif t == "cube":
            v, f = meshio.box((-1, -1, -1), (1, 1, 1))
        elif t == "disk":
            v, f = meshio.disk()
        else:  # sphere
            v, f = meshio.icosphere()
            props = self.props(el)
            center = self.vec3(props["center"]) if "center" in props else np.zeros(3)
            radius = self.number(el, "radius", 1.0)
            if not radius > 0:
                raise self.err(f"sphere radius must be positive, got {radius}", el)
            S = np.eye(4)
            S[:3, :3] *= radius
            S[:3, 3] = center
            M = M @ S
        v = v @ M[:3, :3].T + M[:3, 3]
        name = el.get("id") or f"{t}{index}"
        return Mesh(name, v.astype(np.float32), f.astype(np.int32), albedo, alpha)

    # -- sensor ----------------------------------------------------------------------------------------
    def sensor(self, el):
        t = el.get("type")
        if t != "perspective":
            raise self.err(f"unsupported sensor type {t!r}", el, "ldbench supports perspective sensors")
        films = [c for c in el if c.tag == "film"]
        w, h = DEFAULT_FILM
        if films:
            film = films[0]
            for k in ("crop_offset_x", "crop_offset_y", "crop_width", "crop_height"):
                if k in self.props(film):
                    raise self.err(f"unsupported film property {k!r}", film)
            w = int(self.number(film, "width", w))
            h = int(self.number(film, "height", h))
            if w < 1 or h < 1:
                raise self.err(f"film size {w}x{h} is not positive", film)
        for k in ("principal_point_offset_x", "principal_point_offset_y"):
            if self.number(el, k, 0.0) != 0.0:
                raise self.err(f"unsupported sensor property {k!r}", el)
        for c in el:
            if c.tag in ("texture", "medium", "emitter", "shape", "bsdf"):
                raise self.err(f"unsupported <{c.tag}> inside a sensor", c)
        aspect = w / h
        fl = self.string(el, "focal_length")
        axis = (self.string(el, "fov_axis", "x") or "x").lower()
        if "fov" in self.props(el):
            fov = self.number(el, "fov", 0.0)
            if not 0 < fov < 180:
                raise self.err(f"fov {fov} must be in (0, 180) degrees", el)
        else:
            fl = fl or "50mm"
            try:
                f = float(fl.strip().removesuffix("mm"))
            except ValueError:
                raise self.err(f"bad focal_length {fl!r}", el) from None
            if not f > 0:
                raise self.err(f"bad focal_length {fl!r}", el)
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
            raise self.err(f"unsupported fov_axis {axis!r}", el, "use x, y, diagonal, smaller or larger")
        fov_y = 2 * math.degrees(math.atan(tan_y))
        M = self.to_world(el)
        A = M[:3, :3]
        sx, sy, sz = np.linalg.norm(A, axis=0)
        if min(sx, sy, sz) < 1e-12:
            raise self.err("sensor to_world is singular", el)
        U = A / np.array([sx, sy, sz])
        if np.abs(U.T @ U - np.eye(3)).max() > 1e-4 or max(sx, sy, sz) / min(sx, sy, sz) > 1 + 1e-4:
            raise self.err("sensor to_world has shear or non-uniform scale", el,
                           "ldbench cameras are look-at transforms (rotation + translation)")
        if np.linalg.det(U) < 0:
            raise self.err("sensor to_world is mirrored (negative determinant)", el,
                           "ldbench cameras are look-at transforms (rotation + translation)")
        origin = M[:3, 3]
        cam = Camera(origin=tuple(origin), target=tuple(origin + U[:, 2]), up=tuple(U[:, 1]), fov_y=fov_y)
        return cam, (w, h)

    # -- emitters --------------------------------------------------------------------------------------
    def emitter(self, el):
        t = el.get("type")
        if t not in ("spot", "point"):
            self.warnings.append(f"emitter type {t!r} ignored (line {self.lines.get(id(el))} of {self.path}): "
                                 f"ldbench lights are spot/point emitters")
            return None
        for c in el:
            if c.tag == "texture":
                raise self.err(f"unsupported texture type {c.get('type')!r} in a {t} emitter", c)
        props = self.props(el)
        intensity = self.color(props["intensity"], "the intensity") if "intensity" in props else (1.0, 1.0, 1.0)
        M = self.to_world(el)
        if t == "point":
            if "position" in props:
                if any(c.tag == "transform" for c in el):
                    raise self.err("point emitter with both position and to_world", el)
                pos = self.vec3(props["position"])
            else:
                pos = M[:3, 3]
            return SpotLight(position=tuple(pos), target=tuple(pos + np.array([0.0, 0.0, 1.0])),
                             intensity=intensity, cutoff_angle=180.0, beam_width=180.0, up=(0.0, 1.0, 0.0))
        cutoff = self.number(el, "cutoff_angle", 20.0)
        beam = self.number(el, "beam_width", cutoff * 0.75)
        if not 0 < cutoff <= 180 or not 0 <= beam <= cutoff:
            raise self.err(f"bad spot angles (cutoff_angle {cutoff}, beam_width {beam})", el)
        pos = M[:3, 3]
        d = M[:3, :3] @ np.array([0.0, 0.0, 1.0])
        up = M[:3, :3] @ np.array([0.0, 1.0, 0.0])
        if np.linalg.norm(d) < 1e-12:
            raise self.err("spot emitter to_world is singular", el)
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
        self.substitute()
        self.register_ids()
        for el in self.root.iter():
            if el.tag == "texture":
                raise self.err(f"unsupported texture type {el.get('type')!r}", el,
                               "ldbench supports constant colours (rgb, single-value spectrum, float)")
        sensors = [c for c in self.root if c.tag == "sensor"]
        if len(sensors) > 1:
            raise self.err(f"{len(sensors)} sensors (second one)", sensors[1],
                           "ldbench needs exactly one perspective sensor")
        if not sensors:
            raise LdbenchError(f"no <sensor> in {self.path}: ldbench needs one perspective sensor")
        meshes, lights, nshape = [], [], 0
        for el in self.root:
            tag = el.tag
            if tag in ("default", "integrator", "sensor"):
                continue
            if tag in ("bsdf", "shape", "emitter", "sensor") and not el.get("type"):
                raise self.err(f"<{tag}> without a type", el)
            if tag == "bsdf":
                self.albedo(el)  # validate even when unused
            elif tag == "shape":
                meshes.append(self.shape(el, nshape))
                nshape += 1
            elif tag == "emitter":
                light = self.emitter(el)
                if light is not None:
                    lights.append(light)
            else:
                raise self.err(f"unsupported element <{tag}>", el,
                               "ldbench reads default, integrator (ignored), sensor, bsdf, shape, emitter")
        cam, film = self.sensor(sensors[0])
        if not meshes:
            raise LdbenchError(f"no shapes in {self.path}")
        params = {"film": film}
        if self.values:
            params["xml_params"] = dict(sorted(self.values.items()))
        return Scene(Path(self.path).stem, meshes, cam, lights, params=params, source=self.path,
                     warnings=self.warnings)


def _rotation(axis: np.ndarray, deg: float) -> np.ndarray:
    """Right-handed rotation about ``axis`` by ``deg`` degrees, exactly Mitsuba's ``Transform4f.rotate``:
    the axis is used as given (for a non-unit axis this is not a pure rotation, as in Mitsuba)."""
    x, y, z = axis
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    C = 1 - c
    return np.array([[x * x * C + c, x * y * C - z * s, x * z * C + y * s],
                     [y * x * C + z * s, y * y * C + c, y * z * C - x * s],
                     [z * x * C - y * s, z * y * C + x * s, z * z * C + c]])


def _lookat(origin, target, up):
    """Mitsuba's look-at matrix: columns (left, up', dir, origin); local +z looks at the target."""
    d = target - origin
    if np.linalg.norm(d) < 1e-12:
        return None
    d = d / np.linalg.norm(d)
    left = np.cross(up, d)
    if np.linalg.norm(left) < 1e-9:
        return None
    left /= np.linalg.norm(left)
    new_up = np.cross(d, left)
    M = np.eye(4)
    M[:3, 0], M[:3, 1], M[:3, 2], M[:3, 3] = left, new_up, d, origin
    return M


def load_mitsuba_xml(path, **params) -> Scene:
    """Read a Mitsuba 3 scene file into a :class:`Scene` (see the module docstring for the subset).

    ``params`` override the file's ``<default>`` values (as ``mitsuba.load_file(path, **params)``).
    """
    return _Loader(os.fspath(path), params).load()
