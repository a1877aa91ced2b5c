"""Parameter groups (ldbench/methods/base.py ``group``): the flat dotted view, the earlier names, the errors."""
from __future__ import annotations

import pytest

from ldbench.core.errors import LdbenchError
from ldbench.harness.suite import suite_from_dict
from ldbench.methods.base import registry
from ldbench.methods.structures import StructureSpec


@pytest.mark.parametrize("name", sorted(registry()))
def test_flat_view_round_trips(name):
    P = registry()[name].Params
    d = P().to_dict()
    assert tuple(d) == P.field_names() and all(isinstance(k, str) for k in d)
    assert P.from_dict(d, method=name) == P()
    assert P.from_dict({k: str(v) if isinstance(v, (int, float)) and not isinstance(v, bool) else v
                        for k, v in d.items()}, method=name) == P()


@pytest.mark.parametrize("name", sorted(registry()))
def test_every_earlier_name_leads_to_a_current_one(name):
    P = registry()[name].Params
    names = set(P.field_names())
    for old, new in P.renamed.items():
        assert old not in names and new in names, (old, new)
        if old in P.renamed_values:
            for v, items in P.renamed_values[old].items():
                assert set(items) <= names and P.from_dict({old: v}, method=name) == P.from_dict(items, method=name)
        elif old not in ("build", "raster"):  # ldi: build and raster together name the source (test_ldi)
            v = P().to_dict()[new]
            assert P.from_dict({old: v}, method=name).to_dict()[new] == v


def test_grouped_values_and_errors():
    from ldbench.methods.ldm import LdmParams

    p = LdmParams.from_dict({"structure.layout": "linear", "structure.source": "splat", "indirect.photons": 64,
                             "trace.bias": "0.5"})
    assert isinstance(p.structure, StructureSpec) and p.structure.source == "splat" and p.trace.bias == 0.5
    assert p.to_dict()["indirect.photons"] == 64 and "photons" not in p.to_dict()
    assert LdmParams.from_dict({"layout": "linear", "build": "splat", "photons": 64, "bias": 0.5}) == p
    with pytest.raises(LdbenchError, match=r"parameter trace.bias=-1.0 below its minimum"):
        LdmParams.from_dict({"trace.bias": -1})
    with pytest.raises(LdbenchError, match="unknown parameter 'trace.nope'"):
        LdmParams.from_dict({"trace.nope": 1})
    with pytest.raises(LdbenchError, match="structure.assembly='sort' needs structure.layout='linear'"):
        LdmParams.from_dict({"assembly": "sort"})
    with pytest.raises(LdbenchError, match="structure.source='peel' not one of"):  # a spec given whole, too
        LdmParams(structure=StructureSpec(layout="linear", source="peel"))
    # a method's fixed structure fields stay fixed
    from ldbench.methods.ll_oit import LLOITParams

    s = LLOITParams.from_dict({"pool": "count"}).structure
    assert (s.layout, s.payload, s.sorted_insert, s.pool) == ("linked", ("material",), False, "count")
    with pytest.raises(LdbenchError, match="unknown parameter 'structure.sorted_insert'"):
        LLOITParams.from_dict({"structure.sorted_insert": True})


def test_suites_take_dotted_nested_and_earlier_names():
    runs = [{"scene": "cornell", "effect": "ao", "methods": ["ldm"], "params": {"ldm": p}} for p in (
        {"structure": {"source": ["raster", "splat"]}, "indirect.photons": 64},
        {"build": ["raster", "splat"], "photons": 64})]
    from ldbench.methods.ldm import LdmParams

    got = [[LdmParams.from_dict(dict(j.params)) for j in suite_from_dict({"suite": {"size": "16x16"}, "run": [r]},
                                                                         name="t").jobs] for r in runs]
    assert got[0] == got[1] and [p.structure.source for p in got[0]] == ["raster", "splat"]


@pytest.mark.parametrize("in_suite,sets,want", [
    ('build = "raster"', ["ldm.structure.source=splat"], ("splat", "linked")),   # the suite's earlier name
    ('structure.source = "raster"', ["ldm.build=splat"], ("splat", "linked")),   # the --set's earlier name
    ('layout = "linked"', ["ldm.structure.layout=linear", "ldm.assembly=sort"], ("splat", "linear"))])
def test_set_overrides_a_suite_parameter_under_either_name(tmp_path, in_suite, sets, want):
    from ldbench.harness.cli import build_parser, suite_from_args
    from ldbench.methods.ldm import LdmParams

    suite = tmp_path / "s.toml"
    suite.write_text('[suite]\nsize = "16x16"\n[[run]]\nscene = "cornell"\neffect = "ao"\nmethods = ["ldm"]\n'
                     f'[run.params.ldm]\n{in_suite}\n')
    args = build_parser().parse_args(["run", str(suite), *[a for s in sets for a in ("--set", s)]])
    (job,) = suite_from_args(args).jobs
    s = LdmParams.from_dict(dict(job.params)).structure
    assert (s.source, s.layout) == want


def test_set_completes_an_earlier_ldi_build(tmp_path):
    """``raster`` applied to the suite's ``build = single_pass`` (the two earlier names of one source)."""
    from ldbench.harness.cli import build_parser, suite_from_args
    from ldbench.methods.ldi import LdiParams

    suite = tmp_path / "s.toml"
    suite.write_text('[suite]\nsize = "16x16"\n[[run]]\nscene = "cornell"\neffect = "rays"\nmethods = ["ldi"]\n'
                     '[run.params.ldi]\nbuild = "single_pass"\n')
    args = build_parser().parse_args(["run", str(suite), "--set", "ldi.raster=splat"])
    (job,) = suite_from_args(args).jobs
    assert LdiParams.from_dict(dict(job.params)).structure.source == "splat"
