"""Effects: what a method computes and the reference renders (docs/design.md, "Effects").

One module per effect, each defining one :class:`~ldbench.core.effects.base.EffectSpec` subclass; they are
discovered, never listed by hand. An :class:`Effect` is a *value*: the effect's name plus its validated
parameters. It is hashed into reference-cache keys and written into records.

========  =======================================================================  ==========  ==============
effect    definition                                                               output      needs a light
========  =======================================================================  ==========  ==============
ao        (1/π)∫ V cos θ dω over the camera-facing hemisphere, V = 1 − ρ(t)        image       no
direct    radiance from the spot light after one diffuse reflection, hard shadows  image       yes
indirect  radiance after exactly one diffuse bounce of the spot light (LDDE)       image       yes
rays      hit distance of a harness-built ray batch (diffuse/glossy/shadow/ao)     per ray     shadow rays
vpl_range range of the VPLs of the spot's reflective shadow map from 6 rays each     per VPL     yes
oit       front-to-back "over" of every transparent surface (opacity per mesh)     image       no
glossy_   one bounce of the spot light off a normalized Phong lobe at the visible    image       yes
indirect  surface
soft_     direct light of a spherical light of the spot's intensity, soft shadows   image       yes
shadows
========  =======================================================================  ==========  ==============

Each spec module holds the full definition, its parameters, the inputs the harness builds, the
reference backend and the metrics.
"""
from .base import Effect, EffectSpec, effect_from_key, get_spec, registry

__all__ = ["Effect", "EffectSpec", "effect_from_key", "get_spec", "registry", "EFFECTS"]


def __getattr__(name):
    if name == "EFFECTS":  # the registered effect names (discovered lazily: the modules import harness)
        return tuple(registry())
    raise AttributeError(name)
