"""The ``city`` scene (ldbench/core/scenes/city.py): archer2019's Rungholt stand-in, a procedural town of
gabled houses whose size follows ``triangles``."""
from __future__ import annotations

import numpy as np
import pytest

from ldbench.core.errors import LdbenchError
from ldbench.core.scenes import load_scene
from test_scenes import lit_fraction


@pytest.mark.parametrize("target", [16000, 50000, 300000])
def test_triangle_count_and_determinism(target):
    sc = load_scene("city", triangles=target)
    assert abs(sc.triangle_count / target - 1) < 0.01
    assert sc.params == {"triangles": target, "seed": 0}
    assert load_scene("city", triangles=target).content_hash() == sc.content_hash()
    assert load_scene("city", triangles=target, seed=1).content_hash() != sc.content_hash()
    v, f, _, _ = sc.merged()
    n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    assert np.linalg.norm(n, axis=1).min() > 1e-3  # no degenerate triangle
    lo, hi = sc.bounds()
    assert np.allclose(lo, [-208, 0, -208]) and hi[1] <= 20.0


def test_houses_face_outwards():
    """Walls and roofs of every house are wound counter-clockwise seen from outside."""
    sc = load_scene("city", triangles=16000)
    for m in sc.meshes[1:]:
        v = m.vertices.astype(np.float64).reshape(1024, -1, 3)
        f = m.faces.reshape(1024, -1, 3) - (np.arange(1024) * v.shape[1])[:, None, None]
        tri = np.take_along_axis(v[:, None], f[..., None], axis=2)  # (H, F, 3, 3)
        nrm = np.cross(tri[:, :, 1] - tri[:, :, 0], tri[:, :, 2] - tri[:, :, 0])
        out = ((tri.mean(2) - v.mean(1)[:, None]) * nrm).sum(-1)
        assert np.all(out > 0), m.name


def test_camera_and_light():
    sc = load_scene("city", triangles=16000)
    hit, lit = lit_fraction(sc, w=16, h=12)
    assert hit > 0.6 and lit > 0.5, (hit, lit)
    with pytest.raises(LdbenchError, match="triangles"):
        load_scene("city", triangles=1000)
