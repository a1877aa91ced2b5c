"""Concurrency on the device that runs the suite: every layered structure and every OIT method, rendered three
times by one instance, repeats its frames bit for bit, with the same counters, and violates none of its
invariants (every fragment stored, lists in depth order, no pool overflow, no lost lock). Races that llvmpipe's
in-order shading hides show on a GPU: scripts/gpu/test.sh runs this file there whenever a kernel changes.

Not in the list: ``mlab`` with ``sync = spinlock`` and more fragments than ``k`` in a pixel, whose merges take
the order the GPU grants the lock (MLAB's compression is order-dependent);
tests/test_oit_approx.py::test_mlab_spinlock_keeps_every_fragment checks its lock by the order-free
transmittance instead."""
from __future__ import annotations

import numpy as np
import pytest

from ldbench.core.effects import Effect
from ldbench.methods.base import View, get_method
from test_oit import stack_scene
from testkit import cornell_like

#: (method, effect, parameters, scene): the defaults, and every structure layout and build a race could break
CASES = {
    "ldm": ("ldm", "ao", dict(directions=8, resolution=32), "cornell"),
    "ldm-linear": ("ldm", "ao", dict(directions=8, resolution=32, layout="linear"), "cornell"),
    "ldm-raster-sorted-insert": ("ldm", "ao", dict(directions=8, resolution=32, build="raster", sorted_insert=True),
                                 "cornell"),
    "ldm-raster-count-pool": ("ldm", "ao", dict(directions=8, resolution=32, build="raster", pool="count"),
                              "cornell"),
    "ldi": ("ldi", "indirect", {}, "cornell"),
    "cdi-vpl": ("cdi-vpl", "indirect", {}, "cornell"),
    "ll-oit": ("ll-oit", "oit", {}, "stack"),
    "mlab-spinlock-k16": ("mlab", "oit", dict(k=16, sync="spinlock"), "stack"),
    "mlab-auto-k3": ("mlab", "oit", dict(k=3), "stack"),  # interlock where the GL has it (ordered merges)
    "wboit": ("wboit", "oit", {}, "stack"),
    "depth-peeling": ("depth-peeling", "oit", {}, "stack"),
    "dual-depth-peeling": ("dual-depth-peeling", "oit", {}, "stack"),
    "alpha-blend": ("alpha-blend", "oit", {}, "stack"),
}
SIZE = 32
#: Bit for bit, except cdi-vpl's shading: the VPL grid's cells list their VPLs in the order atomicAdd hands out
#: the slots (ldbench/methods/cdi_vpl/grid.glsl), so a pixel sums the same positive terms in another order; that moves
#: a sum of n terms by at most (n − 1)·2^-24 of itself (n ≤ 64 here: 4e-6; measured 1.3e-7 on llvmpipe).
REL = {"cdi-vpl": 4e-6}
#: counters that may change after the first frame: a growing pool sizes itself on it (two build passes)
FIRST_FRAME_ONLY = {"build_passes"}


def _frames(gpu, method, effect, params, scene, n=3):
    cls = get_method(method)
    sc = cornell_like() if scene == "cornell" else stack_scene()
    m = cls(cls.Params.from_dict(params, method=method))
    m.setup(gpu, sc)
    try:
        if m.params.__class__.__name__ == "MLABParams" and params.get("k") == 3 and m.sync == "spinlock":
            pytest.skip("mlab k=3 merges: ordered only under the interlock, which this GL lacks")
        return [m.frame(View(sc.camera, SIZE, SIZE), Effect(effect)).resolve() for _ in range(n)]
    finally:
        m.release()


@pytest.mark.parametrize("case", list(CASES))
def test_frames_repeat_and_invariants_hold(gpu, case):
    method, effect, params, scene = CASES[case]
    rs = _frames(gpu, method, effect, params, scene)
    first = np.asarray(rs[0].image)
    assert np.isfinite(first).all() and (rs[0].mask is None or np.asarray(rs[0].mask).sum() > 0)
    for i, r in enumerate(rs, 1):
        assert r.invariants == [], f"frame {i}: {r.invariants}"
        img = np.asarray(r.image)
        if case in REL:
            err = np.abs(img - first).max() / max(float(np.abs(first).max()), 1e-30)
            assert err <= REL[case], f"frame {i} differs from frame 1 by {err:.3g} of the image's peak"
        else:
            assert np.array_equal(img, first), f"frame {i} differs from frame 1 by {np.abs(img - first).max():.3g}"
        ints = lambda c: {k: v for k, v in c.items() if isinstance(v, (int, np.integer)) and k not in FIRST_FRAME_ONLY}
        counts, want = ints(r.counters), ints(rs[0].counters)
        assert counts == want, f"frame {i}: counters {counts} != {want}"
    c = rs[0].counters
    for stored, total in (("stored", "fragments"), ("layers_stored", "fragments")):
        if stored in c and total in c and not c.get("merges"):
            assert c[stored] == c[total], (stored, c[stored], total, c[total])
    assert int(c.get("overflow") or 0) == 0 and int(c.get("lost") or 0) == 0
