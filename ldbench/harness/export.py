"""``ldbench export``: one question (scene, view, effect, size, spp, seed) as files an external renderer or
tracer can answer exactly, and that ``ldbench score --from`` reads back (:mod:`ldbench.harness.score`).

Files written into the output folder:

=================  ========================================================================================
``question.json``  scene (and builder parameters), effect with its parameters, width, height, spp, seed,
                   ldbench's version and commit, the scene's content hash, what each file is
``scene.ply``      every triangle of the scene in one mesh (trimesh), world space, with a face property
                   ``material`` (index into ``materials`` of question.json: the albedo and opacity of each
                   mesh)
``meshes/*.ply``   the same triangles, one file per mesh (what ``scene.xml`` loads)
``scene.xml``      Mitsuba 3 scene: the meshes with twosided diffuse BSDFs (for ``oit``, inside a ``mask`` BSDF
                   carrying the mesh's opacity, so that ``ldbench`` reading the file back has the same
                   question), the light(s), the camera, the
                   film and an integrator, such that ``mitsuba scene.xml`` renders the effect's reference
                   where Mitsuba's own integrators can express it (``xml_renders`` in question.json):
                   ``direct`` (integrator ``direct``: delta lights, exact at any spp) and ``ao`` with
                   d_max = inf (every BSDF white, a constant environment of radiance 1 and no other light,
                   integrator ``direct``: then the radiance is (1/π) ∫ V cos θ dω, the ``ao`` effect).
                   Mitsuba's film integrates each pixel's area (box filter) while ldbench's references
                   evaluate the pixel centre: the two agree to the reference's noise except on pixels
                   that straddle a silhouette or a shadow edge.
``camera.json``    origin, target, up, fov_y (degrees, vertical), width, height, the view matrix (world →
                   camera, OpenGL convention: camera looks down −z, column vectors, row-major lists), the
                   G-buffer's projection matrix with its near/far planes, the pixel convention, and
                   ``rays.npz`` beside it: the origin and unit direction of every pixel's view ray
``light.json``     each light: position, target, up, intensity (W/sr, RGB), cutoff_angle and beam_width
                   (degrees; Mitsuba ``spot`` fall-off), ``point`` for cutoff_angle = 180
``batch.npz``      ``rays``: origin (N,3), direction (N,3), tmax (N,), normal (N,3), pixel (N,) of the
                   batch ldbench hands every method, in its order; ``vpl_range``: the VPLs (position,
                   normal, incident, flux, area, texel) and their 6N rays (``ray_origin``,
                   ``ray_direction``, ``ray_tmax``), plus ``cap`` and ``mode``
=================  ========================================================================================

Pixel convention: pixel (i, j), column i from the left, row j from the **top**, is the ray through the
pixel centre (i + ½, j + ½): d ∝ x·right + y·up + forward with x = (2(i + ½)/W − 1)·tan(fov_y/2)·W/H and
y = (1 − 2(j + ½)/H)·tan(fov_y/2) (:meth:`ldbench.core.scene.Camera.primary_rays`). Images are stored with
row 0 at the top.
"""
from __future__ import annotations

import json
import math
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np

from ldbench.core.errors import LdbenchError
from ldbench.core.files import atomic_write_text
from ldbench.core.plugins import ldbench_info
from ldbench.core.scenes import load_scene
from ldbench.harness.rundir import QUESTION, RunDir
from ldbench.references import EXACT
from .arrays import save_arrays

# Heavy: trimesh (0.4 s) is imported by _write_question() alone, which writes the scene's meshes.

PIXEL_CONVENTION = ("pixel (i, j): column i from the left, row j from the top; its ray goes through the "
                    "pixel centre (i + 0.5, j + 0.5): d = normalize(x right + y up + forward), "
                    "x = (2 (i + 0.5) / W - 1) tan(fov_y / 2) W / H, y = (1 - 2 (j + 0.5) / H) tan(fov_y / 2); "
                    "images: row 0 at the top")


def _v(a) -> str:
    return ", ".join(f"{float(x):.9g}" for x in a)


def _look_at_up(position, target, up) -> list:
    """``up``, or the axis least aligned with the view direction when ``up`` is parallel to it."""
    d = np.subtract(target, position, dtype=np.float64)
    d /= np.linalg.norm(d)
    if np.linalg.norm(np.cross(d, up)) > 1e-6 * np.linalg.norm(up):
        return [float(x) for x in up]
    return [float(x) for x in np.eye(3)[int(np.argmin(np.abs(d)))]]


def xml_renders(effect) -> bool:
    """Whether ``scene.xml`` renders ``effect``'s reference (module docstring)."""
    return effect.name == "direct" or (effect.name == "ao" and math.isinf(effect.d_max))


def mitsuba_xml(scene, effect, width: int, height: int, spp: int, seed: int) -> str:
    """The Mitsuba 3 XML of the module docstring (meshes as ``meshes/mesh<i>.ply``)."""
    ao = effect.name == "ao"
    cam = scene.camera
    lines = ['<?xml version="1.0" encoding="utf-8"?>',
             f"<!-- ldbench export: {scene.name}, effect {effect.label()}, {width}x{height}; "
             f"{'renders the reference' if xml_renders(effect) else 'geometry, light and camera only'} -->",
             '<scene version="3.0.0">']
    integ = ("direct" if xml_renders(effect) else "path")
    lines += [f'  <integrator type="{integ}">']
    if integ == "direct":
        lines += ['    <integer name="emitter_samples" value="1"/>',
                  f'    <integer name="bsdf_samples" value="{1 if ao else 0}"/>']
    lines += ["  </integrator>",
              '  <sensor type="perspective">',
              '    <string name="fov_axis" value="y"/>',
              f'    <float name="fov" value="{cam.fov_y:.9g}"/>',
              '    <transform name="to_world">',
              f'      <lookat origin="{_v(cam.origin)}" target="{_v(cam.target)}" up="{_v(cam.up)}"/>',
              "    </transform>",
              '    <sampler type="independent">',
              f'      <integer name="sample_count" value="{int(spp)}"/>',
              f'      <integer name="seed" value="{int(seed)}"/>',
              "    </sampler>",
              '    <film type="hdrfilm">',
              f'      <integer name="width" value="{int(width)}"/>',
              f'      <integer name="height" value="{int(height)}"/>',
              '      <string name="pixel_format" value="rgb"/>',
              '      <rfilter type="box"/>',
              "    </film>",
              "  </sensor>"]
    for i, m in enumerate(scene.meshes):
        if len(m.faces) == 0:
            continue
        albedo = (1.0, 1.0, 1.0) if ao else m.albedo
        bsdf = ['    <bsdf type="twosided"><bsdf type="diffuse">',
                f'      <rgb name="reflectance" value="{_v(albedo)}"/>',
                "    </bsdf></bsdf>"]
        if effect.name == "oit" and m.opacity < 1.0:  # the one effect that reads it (ldbench/core/effects/oit.py)
            bsdf = ['    <bsdf type="mask">', f'    <float name="opacity" value="{m.opacity:.17g}"/>', *bsdf,
                    "    </bsdf>"]
        lines += [f'  <shape type="ply" id={quoteattr(f"mesh{i}")}>',
                  f'    <string name="filename" value="meshes/mesh{i}.ply"/>',
                  '    <boolean name="face_normals" value="true"/>',
                  *bsdf,
                  "  </shape>"]
    if ao:
        lines += ['  <emitter type="constant"><rgb name="radiance" value="1, 1, 1"/></emitter>']
    else:
        for i, lt in enumerate(scene.lights):
            if lt.is_point:
                lines += ['  <emitter type="point">', f'    <point name="position" value="{_v(lt.position)}"/>',
                          f'    <rgb name="intensity" value="{_v(lt.intensity)}"/>', "  </emitter>"]
            else:
                up = _look_at_up(lt.position, lt.target, lt.up)
                lines += ['  <emitter type="spot">', '    <transform name="to_world">',
                          f'      <lookat origin="{_v(lt.position)}" target="{_v(lt.target)}" up="{_v(up)}"/>',
                          "    </transform>", f'    <rgb name="intensity" value="{_v(lt.intensity)}"/>',
                          f'    <float name="cutoff_angle" value="{lt.cutoff_angle:.9g}"/>']
                if lt.beam_width is not None:
                    lines += [f'    <float name="beam_width" value="{lt.beam_width:.9g}"/>']
                lines += ["  </emitter>"]
    lines += ["</scene>", ""]
    return "\n".join(lines)


def camera_json(scene, width: int, height: int) -> dict:
    """The camera of ``camera.json`` (module docstring), with the G-buffer's own near/far planes."""
    cam = scene.camera
    r, u, f = cam.basis()
    lo, hi = scene.bounds()
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    depth = (corners - np.asarray(cam.origin)) @ f  # as ldbench.methods.gbuffer.SceneGeometry.near_far
    diag = float(np.linalg.norm(hi - lo))
    far = max(float(depth.max()), 1e-3 * diag) * 1.01 + 1e-3 * diag
    near = max(float(depth.min()) * 0.99, far * 1e-4)
    return {"origin": list(cam.origin), "target": list(cam.target), "up": list(cam.up), "fov_y": cam.fov_y,
            "width": width, "height": height, "right": r.tolist(), "up_orthonormal": u.tolist(),
            "forward": f.tolist(), "view_matrix": cam.view_matrix().tolist(),
            "projection_matrix": cam.projection_matrix(width / height, near, far).tolist(),
            "near": near, "far": far, "matrix_convention": "column vectors (p' = M p), rows listed first; "
                                                           "OpenGL clip space, camera looks down -z",
            "pixel_convention": PIXEL_CONVENTION, "rays": "rays.npz (origin, direction: (H*W, 3), row-major)"}


def lights_json(scene) -> list:
    return [{"type": "point" if lt.is_point else "spot", "position": list(lt.position), "target": list(lt.target),
             "up": list(lt.up), "intensity": list(lt.intensity), "cutoff_angle": lt.cutoff_angle,
             "beam_width": lt.beam_width, "units": "intensity W/sr (RGB); angles in degrees (Mitsuba spot)"}
            for lt in scene.lights]


def export_question(question, out) -> Path:
    """Write the files of the module docstring for ``question`` (:class:`ldbench.harness.score.Question`) into
    the folder ``out``, as ``run --out`` writes a run (:mod:`ldbench.harness.rundir`): into a temporary folder
    that then replaces ``out`` at once. ``out`` may be new, empty, or an earlier export holding nothing but
    what export writes; anything else (a user's folder, an export beside which an answer was saved) is
    refused before any work."""
    rd = RunDir(out, QUESTION)
    rd.check()
    scene = _load(question)
    with rd as tmp:
        _write_question(question, scene, tmp)
    return Path(out)


def _load(question):
    scene = load_scene(question.scene, **question.scene_params)
    question.effect.check_scene(scene)
    return scene


def _write_question(question, scene, out: Path) -> None:
    import trimesh

    effect, w, h = question.effect, question.width, question.height
    (out / "meshes").mkdir(parents=True, exist_ok=True)
    for i, m in enumerate(scene.meshes):
        if len(m.faces):
            trimesh.Trimesh(np.asarray(m.vertices, np.float64), np.asarray(m.faces), process=False).export(
                out / "meshes" / f"mesh{i}.ply")
    v, f, mid, albedo = scene.merged()
    merged = trimesh.Trimesh(np.asarray(v, np.float64), np.asarray(f), process=False)
    merged.face_attributes["material"] = mid.astype(np.int32)
    merged.export(out / "scene.ply", include_attributes=True)
    atomic_write_text(out / "scene.xml", mitsuba_xml(scene, effect, w, h, question.spp, question.seed))
    cam = camera_json(scene, w, h)
    atomic_write_text(out / "camera.json", json.dumps(cam, indent=1))
    o, d = scene.camera.primary_rays(w, h)
    save_arrays(out / "rays.npz", dict(origin=o.astype(np.float32), direction=d.astype(np.float32)))
    atomic_write_text(out / "light.json", json.dumps(lights_json(scene), indent=1))
    files = {"scene.ply": "all triangles (face property material)", "meshes/": "one PLY per mesh",
             "scene.xml": "Mitsuba 3 scene", "camera.json": "camera and pixel convention",
             "rays.npz": "every pixel's view ray", "light.json": "the lights"}
    spec = effect.spec
    if spec.output != "image":
        batch = spec.inputs(scene, w, h, effect.params, question.seed, exact=EXACT)
        arrays, files["batch.npz"] = spec.export_arrays(batch, w, h)
        save_arrays(out / "batch.npz", arrays)
    info = ldbench_info()
    q = {"scene": question.scene, "scene_params": question.scene_params, "scene_name": scene.name,
         "scene_hash": scene.content_hash(), "effect": effect.key(), "width": w, "height": h,
         "spp": question.spp, "seed": question.seed,
         "materials": [{"mesh": i, "albedo": [float(a) for a in m.albedo], "opacity": float(m.opacity)}
                       for i, m in enumerate(scene.meshes)],
         "xml_renders": xml_renders(effect), "ldbench_version": info["version"], "ldbench_commit": info["commit"],
         "files": files,
         "answer": {"image": "answer.exr (linear) or answer.png (+ transfer in answer.json), H x W, row 0 at top",
                    "rays": "answer.npy / .npz (t) / .csv (column t)", "vpl_range": "answer.npz (range, t)",
                    "optional": "mask.png, answer.json (method, params, stage_ms, memory, ...)"}}
    atomic_write_text(out / "question.json", json.dumps(q, indent=1, default=str))
