"""The references of the effects, by key: which renderer answers an effect spec's ``reference_key``, and
the exact geometry (:data:`EXACT`) the effects build their inputs from.

The effect specs (:mod:`ldbench.core.effects`) stand below this package and never import it: a spec names its
ground truth by key and builds its inputs from an ``exact`` object handed in. The harness wires the two
(:func:`ldbench.harness.runner.prepare`): ``spec.inputs(..., exact=EXACT)``, then :func:`render_effect`.

==================  ==================================================  ==============================
key                 renderer                                            effects
==================  ==================================================  ==============================
``image``           :func:`ldbench.references.render.render_reference`          ``ao``, ``direct``, ``indirect``
``glossy_indirect`` :func:`ldbench.references.glossy_indirect.render_glossy_indirect`  ``glossy_indirect``
``soft_shadows``    :func:`ldbench.references.soft_shadows.render_soft_shadows`  ``soft_shadows``
``oit``             :func:`ldbench.references.oit.render_oit` (exact)           ``oit``
``rays``            :func:`ldbench.references.rays.trace_oracle` (exact)        ``rays``
``vpl_range``       :func:`ldbench.references.vpl_range.exact_ranges` (exact)   ``vpl_range``
==================  ==================================================  ==============================
"""
from __future__ import annotations

import sys
from types import SimpleNamespace

from ldbench.core.effects.base import EffectSpec
from ldbench.core.errors import LdbenchError

from . import glossy_indirect, oit, rays, render as _render, soft_shadows, vpl_range

#: {reference key: (module, function name, how it is called)}, the module None for this package itself:
#: "image" renderers take the view and sampling arguments, "exact" ones the scene and the effect's inputs.
#: The function is looked up when called, so that what a caller patches (``ldbench.references.render_reference``)
#: is what runs.
RENDERERS = {
    "image": (None, "render_reference", "image"),
    "glossy_indirect": (glossy_indirect, "render_glossy_indirect", "image"),
    "soft_shadows": (soft_shadows, "render_soft_shadows", "image"),
    "oit": (oit, "render_oit", "oit"),
    "rays": (rays, "trace_oracle", "exact"),
    "vpl_range": (vpl_range, "exact_ranges", "exact"),
}

#: The exact geometry of the effects' inputs (:mod:`ldbench.core.effects.base`): Mitsuba 3 on the same triangles.
EXACT = SimpleNamespace(primary_hits=_render.primary_hits, rsm_hits=vpl_range.rsm_hits, epsilons=rays.epsilons)


def render_effect(scene, effect, *, width: int, height: int, spp: int, seed: int = 0, inputs=None, cache: bool = True,
           progress: bool = True):
    """The ground truth of ``effect`` (an :class:`ldbench.core.effects.Effect`) on ``scene`` for ``inputs``."""
    spec = effect.spec
    if type(spec).render_reference is not EffectSpec.render_reference:
        return spec.render_reference(scene, effect.params, width=width, height=height, spp=spp, seed=seed,
                                     inputs=inputs, exact=EXACT)  # an effect bringing its own ground truth
    key = spec.reference_key
    if key not in RENDERERS:
        raise LdbenchError(f"no reference renders effect {effect.name!r} (reference key {key!r})")
    module, name, kind = RENDERERS[key]
    fn = getattr(module or sys.modules[__package__], name)
    if kind == "exact":
        return fn(scene, inputs)
    if kind == "oit":
        return fn(scene, width, height)
    return fn(scene, effect, width=width, height=height, spp=spp, seed=seed, cache=cache, progress=progress)


def trace(scene, batch):
    """Exact hit distances of a :class:`ldbench.core.effects.rays.RayBatch` (inf = miss): the ray oracle,
    handed by the harness to adapters whose parameters ask for an exact baseline (``Method.oracle``)."""
    return rays.trace_oracle(scene, batch).t
