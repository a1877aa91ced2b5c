"""Registered real scenes (``sponza``, ``sibenik``, ``dragon``, ...): built from their verified files in the
scene cache as their entry in ``ldbench/core/scene_registry.toml`` says. Their one parameter is ``view``, one of
the viewpoints their entry names besides its camera."""
from __future__ import annotations

from fnmatch import fnmatch
from pathlib import Path

import numpy as np

from ldbench.core import scene_registry
from ldbench.core.errors import LdbenchError
from ldbench.core.meshio import read_mesh, read_mtl, rotation
from ldbench.core.mitsuba_xml import load_mitsuba_xml
from ldbench.core.scene import Camera, Mesh, Scene

from .base import part_mesh
from .mesh import object_in_box


def build_registered(name: str, root=None, view: str = "") -> Scene:
    """A registered real scene, built from its files in the scene cache (``root``: another cache).

    The entry in ``ldbench/core/scene_registry.toml`` says how (``load.kind``): ``mesh`` (one file, one
    albedo), ``parts`` (one file per material, albedo = the MTL's Kd), ``object`` (rotated, then placed
    in the ``mesh`` scene's box) or ``xml`` (a Mitsuba 3 file, camera from the file). ``load.scale``
    converts model units to metres (geometry and the file's camera); the spot light, and the camera
    unless the file gives it, are the entry's. Checksums are verified before anything is read; a scene
    that is not fetched is one :class:`LdbenchError` line saying how to fetch it. ``view``: one of the entry's
    ``views`` instead of its camera (the scene's ``params`` then hold it).
    """
    entry = scene_registry.get(name)
    if view and view not in entry.views:
        raise LdbenchError(f"registered scene {name!r} has no view {view!r} "
                           f"(views: {', '.join(entry.views) or 'none'})")
    folder = scene_registry.verified_root(name, root)
    ld, camera = entry.load, entry.camera
    s = float(ld.get("scale", 1.0))
    warnings = [entry.warning] if entry.warning else []
    if ld["kind"] == "mesh":
        v, f = read_mesh(folder / ld["mesh"])
        meshes = [part_mesh(Path(ld["mesh"]).stem, (v * s, f), tuple(ld["albedo"]))]
    elif ld["kind"] == "parts":
        kd = read_mtl(folder / ld["mtl"])
        meshes = []
        for spec in entry.files:
            if not fnmatch(spec.path, ld["parts"]):
                continue
            mat = Path(spec.path).stem
            if mat not in kd:
                raise LdbenchError(f"scene {name!r}: material {mat!r} has no Kd in {folder / ld['mtl']}")
            v, f = read_mesh(folder / spec.path)
            meshes.append(part_mesh(mat, (v * s, f), kd[mat]))
    elif ld["kind"] == "object":
        v, f = read_mesh(folder / ld["mesh"])
        for ax, ay, az, deg in ld.get("rotate", ()):
            v = v @ rotation((ax, ay, az), deg).T
        meshes = object_in_box(Path(ld["mesh"]).stem, v, f, tuple(ld["albedo"]), folder / ld["mesh"])
    else:  # xml
        sc = load_mitsuba_xml(folder / ld["xml"])
        meshes = [Mesh(m.name, m.vertices * s, m.faces, m.albedo, m.opacity) for m in sc.meshes]
        c = sc.camera
        camera = camera or Camera(tuple(np.multiply(c.origin, s)), tuple(np.multiply(c.target, s)), c.up, c.fov_y)
        warnings += sc.warnings
    if view:
        camera = entry.views[view]
    if camera is None:  # only a Mitsuba file brings its own camera
        raise LdbenchError(f"scene registry: entry {name!r} of kind {ld['kind']!r} needs a [camera]")
    return Scene(name, meshes, camera, [entry.light], params={"view": view} if view else {},
                 source=f"registry:{name}", warnings=warnings)

