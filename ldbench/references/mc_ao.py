"""A truly unbiased ``ao`` estimator independent of the reference's sampling: brute-force Monte Carlo
through the ``rays`` oracle, for ``ldbench score --test unbiased`` (docs/reference/cli.md).

Per hit pixel ``spp`` rays of kind ``ao`` (:mod:`ldbench.core.effects.rays`: cosine-distributed about the
camera-facing normal from the reference's own spawn origin, ``t_max = d_max``, directions from ldbench's
numpy PCG64 streams of :mod:`ldbench.core.conventions`, *not* Mitsuba's PCG32/TEA streams) are traced
by :func:`ldbench.references.rays.trace_oracle` (Mitsuba's closest hit). Each ray's value is the ``ao``
integrand (1 − ρ(t); ρ = 1 for ``step``, 1 − (t/d_max)² for ``quadratic``; 1 when it escapes), and per
pixel the sample mean and the variance of the mean (unbiased sample variance / spp) are returned, the
same statistics as :func:`ldbench.references.render_reference`. Background pixels are 1 with variance 0.
"""
from __future__ import annotations

from ldbench.core.effects.rays import RaysParams
from ldbench.core.errors import LdbenchError
from ldbench.core.mc import ao_values, pixel_mean_variance

from .rays import make_batch, trace_oracle


def render_mc_ao(scene, effect, *, width: int, height: int, spp: int, seed: int = 0):
    """(mean, variance of the mean, mask) of the ``ao`` ``effect`` on ``scene``: H×W×1, H×W×1, H×W bool."""
    if effect.name != "ao":
        raise LdbenchError(f"the Monte Carlo oracle estimator renders ao, not {effect.name}")
    if isinstance(spp, bool) or not isinstance(spp, int) or not 2 <= spp <= 1024:
        raise LdbenchError(f"spp must be an integer in [2, 1024], got {spp!r}")
    d_max, falloff = float(effect.d_max), str(effect.falloff)
    params = RaysParams(ray_kind="ao", rays_per_pixel=spp, d_max=d_max)
    batch = make_batch(scene, width, height, params, seed)
    t = trace_oracle(scene, batch).t
    mean, var = pixel_mean_variance(ao_values(t, d_max, falloff), batch.pixel, spp, width, height)
    return mean, var, batch.primary_mask
