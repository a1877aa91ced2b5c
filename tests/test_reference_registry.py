"""The references' registry (ldbench/references/registry.py): every effect's reference key has a renderer, and
render_effect hands each effect to the renderer of its key, with the arguments that renderer takes."""
import pytest

import ldbench.references as package
from ldbench.core.effects import Effect, registry
from ldbench.references import glossy_indirect, oit, rays, render_effect, soft_shadows, vpl_range
from ldbench.references import registry as R

#: effect -> (module of references, function, how it is called): the ground truth of each effect
EXPECTED = {
    "ao": (package, "render_reference", "image"),
    "direct": (package, "render_reference", "image"),
    "indirect": (package, "render_reference", "image"),
    "glossy_indirect": (glossy_indirect, "render_glossy_indirect", "image"),
    "soft_shadows": (soft_shadows, "render_soft_shadows", "image"),
    "oit": (oit, "render_oit", "oit"),
    "rays": (rays, "trace_oracle", "exact"),
    "vpl_range": (vpl_range, "exact_ranges", "exact"),
}


def test_every_effect_names_a_known_reference():
    assert set(EXPECTED) == set(registry())
    for name, spec in registry().items():
        assert spec.reference_key in R.RENDERERS, name


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_render_effect_calls_the_renderer_of_the_effect(name, monkeypatch):
    module, fname, kind = EXPECTED[name]
    seen = {}

    def fake(*args, **kwargs):
        seen["args"], seen["kwargs"] = args, kwargs
        return "ref"

    monkeypatch.setattr(module, fname, fake)
    eff = Effect(name)
    assert render_effect("scene", eff, width=4, height=3, spp=2, seed=7, inputs="in", progress=False) == "ref"
    if kind == "exact":
        assert seen["args"] == ("scene", "in")
    elif kind == "oit":
        assert seen["args"] == ("scene", 4, 3)
    else:
        assert seen["args"] == ("scene", eff)
        assert seen["kwargs"] == dict(width=4, height=3, spp=2, seed=7, cache=True, progress=False)
