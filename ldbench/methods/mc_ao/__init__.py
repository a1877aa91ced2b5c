"""``mc-ao``: brute-force Monte Carlo ambient occlusion through the exact ray oracle: an unbiased method.

Not a real-time method: a ground-truth-grade estimator that declares itself **unbiased** (``unbiased =
True``), so that a suite can test it with ``test = "unbiased"`` (docs/reference/cli.md, "`score --test unbiased`").
It is left out of a ``[[run]]``'s ``methods = "all"``; name it.

Per pixel whose primary ray hits (the harness's exact primary hits, :attr:`Method.exact`), ``spp`` rays of
the ``rays`` effect's kind ``ao`` (cosine-distributed about the camera-facing normal from the spawn
origin, ``t_max = d_max``; directions from ldbench's numpy PCG64 streams, :mod:`ldbench.core.conventions`,
independent of the reference's Mitsuba streams) are traced by the harness's ray oracle
(:attr:`Method.oracle`, Mitsuba's closest hit). A ray's value is the ``ao`` integrand (1 when it escapes;
0 on a hit for ``step``, (t/d_max)² for ``quadratic``); the image is the per-pixel sample mean and
``arrays["variance"]`` its variance of the mean (unbiased sample variance / spp), ``counters["samples"]`` =
spp. Background pixels are 1 with variance 0. The ``trace`` stage wraps CPU/oracle work: its GPU time
means nothing.

Parameters: ``ldbench methods mc-ao`` (docs/reference/parameters.md).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ldbench.core.effects.rays import RaysParams, make_batch
from ldbench.core.errors import LdbenchError
from ldbench.core.mc import ao_values, pixel_mean_variance
from ldbench.core.params import ParamsBase, param
from ldbench.methods.base import Method, Result


@dataclass(frozen=True)
class McAoParams(ParamsBase):
    spp: int = param(64, "cosine-distributed rays per hit pixel (the estimate's samples)", lo=2, hi=1024)
    seed: int = param(0, "seed of the direction streams (mixed with the run's --seed)", lo=0, hi=2**31 - 1)


class McAo(Method):
    name = "mc-ao"
    paper = "ground truth"
    effects = frozenset({"ao"})
    Params = McAoParams
    unbiased = True   # gives arrays["variance"]: a suite may run it with test = "unbiased"
    in_all = False    # not one of a [[run]]'s methods = "all"

    def setup(self, gpu, scene):
        self.gpu, self.scene = gpu, scene
        if self.oracle is None or getattr(self, "exact", None) is None:
            raise LdbenchError("method 'mc-ao' needs the harness's ray oracle and exact primary hits")

    def frame(self, view, effect, inputs=None):
        spp = int(self.params.spp)
        d_max, falloff = float(effect.d_max), str(effect.falloff)
        with self.gpu.stage("trace"):
            batch = make_batch(self.scene, view.width, view.height,
                               RaysParams(ray_kind="ao", rays_per_pixel=spp, d_max=d_max),
                               self.seed_for(self.params.seed), self.exact)
            t = np.asarray(self.exact_distances(self.scene, batch))
        mean, var = pixel_mean_variance(ao_values(t, d_max, falloff), batch.pixel, spp, view.width, view.height)
        return Result(image=mean, arrays={"variance": var}, counters={"samples": spp, "rays": int(len(t))})
