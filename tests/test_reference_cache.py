"""The reference cache (ldbench/references/cache.py) uses an entry only when its file name, its JSON and the
key in its EXR header agree."""
import shutil

import numpy as np
import pytest

from testkit import cornell_like
from ldbench.core.effects import Effect

references = pytest.importorskip("ldbench.references")
from ldbench.references import render_reference  # noqa: E402
from ldbench.core.exr import read_exr_header  # noqa: E402


def test_exr_copied_over_another_entry_is_a_miss(tmp_path):
    s = cornell_like()
    kw = dict(width=16, height=12, cache_dir=tmp_path, progress=False)
    a = render_reference(s, Effect("ao"), spp=4, **kw)
    b = render_reference(s, Effect("ao", d_max=0.2), spp=4, **kw)
    ka, kb = a.meta["key"], b.meta["key"]
    assert read_exr_header(tmp_path / f"{kb}.exr")["ldbench_key"] == kb
    assert render_reference(s, Effect("ao", d_max=0.2), spp=4, **kw).meta["cached"] is True
    shutil.copyfile(tmp_path / f"{ka}.exr", tmp_path / f"{kb}.exr")  # a valid EXR, the wrong entry
    again = render_reference(s, Effect("ao", d_max=0.2), spp=4, **kw)
    assert again.meta["cached"] is False  # re-rendered, not a's image under b's name
    assert np.array_equal(again.mean, b.mean) and not np.array_equal(again.mean, a.mean)
    assert read_exr_header(tmp_path / f"{kb}.exr")["ldbench_key"] == kb  # and stored again
    assert render_reference(s, Effect("ao", d_max=0.2), spp=4, **kw).meta["cached"] is True


def test_default_cache_dir_rules(monkeypatch, tmp_path):
    """LDBENCH_CACHE wins; a checkout caches beside its sources; an installed package (no pyproject.toml
    beside it) uses the user cache, never its own, possibly read-only, folder."""
    from ldbench.references import cache

    monkeypatch.setenv("LDBENCH_CACHE", str(tmp_path / "c"))
    assert cache.default_cache_dir() == tmp_path / "c"
    monkeypatch.delenv("LDBENCH_CACHE")
    assert cache.default_cache_dir().parts[-2:] == (".cache", "references")
    fake = tmp_path / "site" / "references" / "cache.py"
    fake.parent.mkdir(parents=True)
    monkeypatch.setattr(cache, "__file__", str(fake))
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert cache.default_cache_dir() == tmp_path / "xdg" / "ldbench" / "references"


def _rewrite_pixels(path, fn, digest=None):
    """Rewrite an entry's EXR with its pixels changed by ``fn``, its header key kept (and, with
    ``digest``, a pixel checksum made to match)."""
    from ldbench.core.exr import read_exr, write_exr

    ch = read_exr(path)
    header = read_exr_header(path)
    ch = {k: fn(k, v) for k, v in ch.items()}
    if digest is not None:
        header["ldbench_pixels"] = digest(ch)
    write_exr(path, ch, header={k: v for k, v in header.items() if k.startswith("ldbench_")})
    return ch


def test_nan_pixels_under_the_right_key_are_a_miss(tmp_path):
    """An EXR whose header key is right but whose pixels are NaN (damaged, edited) is not used: the
    pixel checksum in the JSON and the header does not match; re-rendered, the entry is stored again."""
    s = cornell_like()
    kw = dict(width=16, height=12, cache_dir=tmp_path, progress=False)
    a = render_reference(s, Effect("ao"), spp=4, **kw)
    exr = tmp_path / f"{a.meta['key']}.exr"
    _rewrite_pixels(exr, lambda k, v: np.full_like(v, np.nan) if k.startswith("mean") else v)
    again = render_reference(s, Effect("ao"), spp=4, **kw)
    assert again.meta["cached"] is False and np.array_equal(again.mean, a.mean)
    assert render_reference(s, Effect("ao"), spp=4, **kw).meta["cached"] is True


def test_non_finite_entry_with_a_matching_checksum_is_a_miss(tmp_path):
    """Even a NaN entry whose checksums agree (written so by something else) is never used."""
    import json

    from ldbench.references import cache

    s = cornell_like()
    kw = dict(width=16, height=12, cache_dir=tmp_path, progress=False)
    a = render_reference(s, Effect("ao"), spp=4, **kw)
    key = a.meta["key"]

    def digest(ch):
        mean, var = ch["mean.Y"][..., None], ch["variance.Y"][..., None]
        return cache.pixels_digest(mean, var, ch["mask"])

    ch = _rewrite_pixels(tmp_path / f"{key}.exr", lambda k, v: np.where(v >= 0, np.nan, v).astype(np.float32)
                         if k == "mean.Y" else v, digest)
    doc = json.loads((tmp_path / f"{key}.json").read_text())
    doc["pixels"] = digest(ch)
    (tmp_path / f"{key}.json").write_text(json.dumps(doc))
    assert render_reference(s, Effect("ao"), spp=4, **kw).meta["cached"] is False


def test_a_non_finite_reference_never_scores_a_row():
    """Whatever produced it, a reference with NaN where the camera sees a surface stops the run with one
    line before any method is scored against it."""
    from types import SimpleNamespace

    from ldbench.harness.checks import finite_reference
    from ldbench.core.errors import LdbenchError

    mean = np.ones((4, 4, 1), np.float32)
    mask = np.ones((4, 4), bool)
    ok = SimpleNamespace(mean=mean, variance=np.zeros_like(mean), mask=mask)
    finite_reference(cornell_like(), ok, "ao")
    mean2 = mean.copy()
    mean2[1, 2] = np.nan
    with pytest.raises(LdbenchError, match="1 non-finite pixel"):
        finite_reference(cornell_like(), SimpleNamespace(mean=mean2, variance=ok.variance, mask=mask), "ao")
    mask2 = mask.copy()
    mask2[1, 2] = False  # background: not scored, not refused
    finite_reference(cornell_like(), SimpleNamespace(mean=mean2, variance=ok.variance, mask=mask2), "ao")
    # a NaN variance is refused too, except with one sample per pixel, where it is undefined
    var = ok.variance.copy()
    var[0, 0] = np.nan
    with pytest.raises(LdbenchError, match="1 non-finite pixel"):
        finite_reference(cornell_like(), SimpleNamespace(mean=mean, variance=var, mask=mask, meta={"spp": 4}), "ao")
    finite_reference(cornell_like(), SimpleNamespace(mean=mean, variance=var, mask=mask, meta={"spp": 1}), "ao")


def test_a_run_stops_before_scoring_against_a_non_finite_reference(tmp_path, monkeypatch):
    import ldbench.references as refs
    from ldbench.core.errors import LdbenchError
    from ldbench.harness.executors import run_jobs
    from ldbench.harness.suite import suite_from_dict

    real = refs.render_reference

    def nan_reference(*a, **k):
        r = real(*a, **k)
        r.mean[r.mask] = np.nan
        return r

    monkeypatch.setattr(refs, "render_reference", nan_reference)
    suite = suite_from_dict({"suite": {"size": "16x16", "spp": 2, "warmup": 0, "frames": 1},
                             "run": [{"scene": "cornell", "effect": "ao", "methods": ["hbao"]}]}, name="t")
    with pytest.raises(LdbenchError, match="non-finite"):
        run_jobs(suite, tmp_path / "run", progress=False, report=False)
    assert not list(tmp_path.iterdir())
