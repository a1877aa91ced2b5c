"""Scenes: one module per scene, discovered, and the scene dispatcher.

``load_scene(spec, **params)`` turns a scene specification into a :class:`~ldbench.core.scene.Scene`:

* a scene name (``cornell``, ``atrium``, ``hairball``, ``city``, ``teapot``, ``mesh``, ``transparent_dragon``,
  or a plugin's), optionally with parameters appended as ``name:key=value,key=value``
  (e.g. ``atrium:triangles=260000``);
* a path ending in ``.xml``: a Mitsuba 3 scene file (:func:`ldbench.core.mitsuba_xml.load_mitsuba_xml`;
  ``params`` then override the file's ``<default>`` values);
* a path to a mesh file (``.ply``, ``.obj``, ``.stl``, ``.off``): the ``mesh`` scene (mesh in an open box);
* a registered real scene (``sponza``, ``sibenik``, ``dragon``, ...; ``ldbench/core/scene_registry.toml``),
  read from the scene cache after its checksums are verified (:func:`build_registered`).

A scene is a :class:`~ldbench.core.scenes.base.SceneBuilder` subclass with validated ``Params``, one module of
this package per built-in scene (``cornell.py``, ``atrium.py``, ...). :func:`builders` discovers them, never a
hand-kept list, together with the entry points of group ``ldbench.scenes`` of installed distributions, so a new
scene is one module. The dispatcher validates a scene's parameters (an unknown or out-of-range one is one error
line naming the scene and the parameter) and records them, defaults included, in ``scene.params``
(``load_scene(builder, **scene.params)`` rebuilds the same scene; the builder is ``scene.name``, or ``mesh`` for
mesh scenes, which are named after the file).

Every built-in scene is deterministic and vectorised numpy (300k triangles in well under a second), and gives
a camera and one spot light that lights most of what the camera sees, so ``direct`` and ``indirect``
are meaningful. Conventions (docs/design.md): metres, y up, right-handed, triangles counter-clockwise seen
from the front (walls face into the room, solids face outwards); methods treat them as two-sided.
"""
from __future__ import annotations

import dataclasses
import importlib
import inspect
import os
import pkgutil
import re

import numpy as np

from ldbench.core import plugins, scene_registry
from ldbench.core.errors import LdbenchError
from ldbench.core.mitsuba_xml import load_mitsuba_xml
from ldbench.core.paramdoc import markdown
from ldbench.core.scene import Scene, without_duplicate_triangles

from .base import SceneBuilder, SceneParams
from .registered import build_registered

__all__ = ["DEFAULT_D_MAX_FRACTION", "MESH_SUFFIXES", "SceneBuilder", "SceneParams", "build_registered",
           "build_scene", "builders", "default_d_max", "doc_summary", "list_scenes", "load_scene"]

MESH_SUFFIXES = (".ply", ".obj", ".stl", ".off")

#: a scene's name: what ``name:key=value`` and a suite's ``scene = "..."`` can hold unambiguously
_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_-]*")


# ---------------------------------------------------------------------------------------------------
# discovery

_BUILDERS: dict = {}  # {plugins.discovery_key: builders}: the current environment's only


def builders() -> dict:
    """{name: :class:`SceneBuilder` subclass}: every scene module of this package (discovered) and every
    entry point of group ``ldbench.scenes`` (:mod:`ldbench.core.plugins`). Two scenes with one name, or a
    scene named like a registered real scene, are one error naming both."""
    key = plugins.discovery_key(plugins.SCENE_GROUP)
    if key not in _BUILDERS:
        found = _discover()
        _BUILDERS.clear()
        _BUILDERS[key] = found
    return dict(_BUILDERS[key])


def _discover() -> dict:
    found: dict = {}
    sources: dict = {}
    for mod in pkgutil.iter_modules(__path__):
        if mod.ispkg or mod.name.startswith("_"):
            continue
        m = importlib.import_module(f"{__name__}.{mod.name}")
        for obj in vars(m).values():
            if (isinstance(obj, type) and issubclass(obj, SceneBuilder) and obj.name
                    and obj.__module__ == m.__name__):
                plugins.add_unique(found, sources, obj, f"{obj.__module__}.{obj.__qualname__} (ldbench)", "scene")
    for obj, source in plugins.entry_point_classes(plugins.SCENE_GROUP, SceneBuilder):
        plugins.add_unique(found, sources, obj, source, "scene")
    registered = scene_registry.registry()
    for name, source in sources.items():
        if not _NAME.fullmatch(name):
            raise LdbenchError(f"scene name {name!r} of {source} is not a name (letters, digits, _ and -)")
        if name in registered:
            raise LdbenchError(f"two scenes are named {name!r}: {source} and the registered real scene "
                               "(ldbench/core/scene_registry.toml)")
    return dict(sorted(found.items()))


# ---------------------------------------------------------------------------------------------------
# building and listing

def build_scene(name: str, **params) -> Scene:
    """The scene ``name`` (a :func:`builders` name) with ``params`` validated by its ``Params``; the
    parameters used, defaults included, recorded in ``scene.params`` (tuples as lists)."""
    reg = builders()
    if name not in reg:
        raise LdbenchError(f"unknown scene {name!r} (scenes: {', '.join(reg)})")
    cls = reg[name]
    P = cls.Params
    try:
        values = P.upgrade(params)
        known = P.field_names()
        for k in values:
            if k not in known:
                raise LdbenchError(f"unknown parameter {k!r} for scene {name!r} "
                                   f"(parameters: {', '.join(known) or 'none'})")
        p = P.from_dict(values, method=name)
    except LdbenchError as e:
        msg = str(e)
        raise LdbenchError(msg if f"scene {name!r}" in msg else f"scene {name!r}: {msg}") from None
    scene = cls().build(p)
    if not isinstance(scene, Scene):
        raise LdbenchError(f"scene {name!r}: {cls.__module__}.{cls.__qualname__}.build returned a "
                           f"{type(scene).__name__}, not a Scene")
    scene.params = {k: (list(v) if isinstance(v, tuple) else v) for k, v in p.to_dict().items()}
    return scene


def registered_needed(spec) -> str | None:
    """The registered real scene that scene ``spec`` reads from the scene cache: itself when registered,
    the one a built-in scene builds on (:attr:`SceneBuilder.registered`), else None (a file path, a
    scene built from parameters alone)."""
    base = str(spec).split(":", 1)[0].strip()
    if base in scene_registry.registry():
        return base
    cls = builders().get(base)
    return (cls.registered or None) if cls is not None else None


def doc_summary(doc: str) -> str:
    """The first sentence of a docstring's first paragraph, on one line, without RST literal marks.

    A sentence ends at a full stop followed by a space and a capital letter, or at the paragraph's end,
    so "Fig. 2" or a sentence wrapped over several lines stays whole."""
    para = " ".join(" ".join((doc or "").strip().split("\n\n", 1)[0].split()).split())
    para = para.replace("``", "")
    m = re.search(r"\.\s+(?=[A-Z])", para)
    return para[: m.start() + 1] if m else para


def list_scenes() -> list[dict]:
    """One dict per scene of :func:`builders`: ``name``, ``description`` (its class docstring's first
    sentence, one line: :func:`doc_summary`), ``parameters`` (name -> default), ``doc`` (the docstring) and
    ``table`` (the parameters' Markdown table: :func:`ldbench.core.paramdoc.markdown`)."""
    out = []
    for name, cls in builders().items():
        doc = inspect.cleandoc(cls.__dict__.get("__doc__") or "")
        defaults = {f.name: (list(f.default) if isinstance(f.default, tuple) else f.default)
                    for f in dataclasses.fields(cls.Params)}
        out.append({"name": name, "description": doc_summary(doc), "parameters": defaults, "doc": doc,
                    "table": markdown(cls.Params)})
    return out


# ---------------------------------------------------------------------------------------------------
# the d_max policy

#: An ad-hoc ``ldbench run --effect ao`` without ``--d-max`` on a scene with no registered d_max uses
#: this fraction of the scene's largest bounding-box extent: the small radius of the aalund2015 AO
#: suites (0.1 m in the 2 m Cornell box, 1.5 m in the 30 m atrium), where AO looks like AO and screen
#: space has the information it needs. Unbounded AO leaves enclosed scenes nearly black.
DEFAULT_D_MAX_FRACTION = 0.05


def default_d_max(spec, **params) -> tuple[float, str]:
    """The AO distance for a scene when the user gives none: ``(d_max, where it comes from)``.

    A registered scene's ``d_max`` (ldbench/core/scene_registry.toml) if it has one, else
    :data:`DEFAULT_D_MAX_FRACTION` of the largest extent of the scene's bounding box (3 significant
    digits). Suites state their d_max; this is for ad-hoc runs only."""
    name = spec.split(":", 1)[0] if isinstance(spec, str) else None
    entry = scene_registry.registry().get(name) if name else None
    if entry is not None and entry.d_max is not None:
        return float(entry.d_max), f"registered for scene {name!r}"
    lo, hi = load_scene(spec, **params).bounds()
    extent = float(np.max(hi - lo))
    d = float(f"{DEFAULT_D_MAX_FRACTION * extent:.3g}")
    return d, f"{DEFAULT_D_MAX_FRACTION:.0%} of the scene's largest bounding-box extent {extent:.3g}"


# ---------------------------------------------------------------------------------------------------
# dispatch

def _parse_inline_params(text: str, spec: str) -> dict:
    out = {}
    for item in filter(None, (s.strip() for s in text.split(","))):
        if "=" not in item:
            raise LdbenchError(f"scene {spec!r}: expected key=value after ':', got {item!r}")
        k, v = (s.strip() for s in item.split("=", 1))
        out[k] = v
    return out


def _is_xml(spec: str) -> bool:
    return spec.lower().endswith(".xml")


def _is_mesh(spec: str) -> bool:
    return spec.lower().endswith(MESH_SUFFIXES)


def load_scene(spec, **params) -> Scene:
    """Build a scene from a scene name (optionally ``name:key=value,...``), a registered real scene, a
    Mitsuba 3 XML path, or a mesh file path (the ``mesh`` scene). Bad input raises :class:`LdbenchError`
    naming it. Exact duplicate triangles within a mesh are removed, with a line in ``scene.warnings``
    (:func:`ldbench.core.scene.without_duplicate_triangles`: every method and reference see them once)."""
    return without_duplicate_triangles(_load_scene(spec, **params))


def _load_scene(spec, **params) -> Scene:
    """:func:`load_scene` before the duplicate triangles are removed."""
    spec = os.fspath(spec) if isinstance(spec, os.PathLike) else spec
    if not isinstance(spec, str) or not spec.strip():
        raise LdbenchError(f"scene must be a name or a file path, got {spec!r}")
    spec = spec.strip()
    head, colon, inline = spec.partition(":")
    registered = scene_registry.registry()
    if head in registered:
        given = {**_parse_inline_params(inline, spec), **params}
        if set(given) - {"view"}:
            raise LdbenchError(f"registered scene {head!r} takes only the parameter view (got "
                               f"{', '.join(sorted(set(given) - {'view'}))})")
        return build_registered(head, view=str(given.get("view", "")))
    reg = builders()
    if head in reg:
        return build_scene(head, **{**_parse_inline_params(inline, spec), **params})
    if _is_xml(spec):
        return load_mitsuba_xml(spec, **params)
    if _is_mesh(spec):
        others = [f.name for f in dataclasses.fields(reg["mesh"].Params) if f.name != "path"]
        for k in params:
            if k not in others:
                raise LdbenchError(f"unknown parameter {k!r} for mesh scene {spec!r} "
                                   f"(parameters: {', '.join(others)})")
        return build_scene("mesh", **params, path=spec)
    if os.path.exists(spec):
        raise LdbenchError(f"cannot tell what scene file {spec!r} is: expected a Mitsuba .xml or a mesh "
                           f"({', '.join(MESH_SUFFIXES)})")
    raise LdbenchError(f"unknown scene {spec!r} (built-in: {', '.join(reg)}; registered: "
                       f"{', '.join(registered)}; or a path to a Mitsuba .xml file or a "
                       f"{'/'.join(s[1:] for s in MESH_SUFFIXES)} mesh)")
