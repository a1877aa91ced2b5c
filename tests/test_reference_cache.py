"""The reference cache (references/cache.py) uses an entry only when its file name, its JSON and the
key in its EXR header agree."""
import shutil

import numpy as np
import pytest

from testkit import cornell_like
from harness.effects import Effect

references = pytest.importorskip("references")
from references import render_reference  # noqa: E402
from references.exr import read_exr_header  # noqa: E402


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
    from references import cache

    monkeypatch.setenv("LDBENCH_CACHE", str(tmp_path / "c"))
    assert cache.default_cache_dir() == tmp_path / "c"
    monkeypatch.delenv("LDBENCH_CACHE")
    assert cache.default_cache_dir().parts[-2:] == (".cache", "references")
    fake = tmp_path / "site" / "references" / "cache.py"
    fake.parent.mkdir(parents=True)
    monkeypatch.setattr(cache, "__file__", str(fake))
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert cache.default_cache_dir() == tmp_path / "xdg" / "ldbench" / "references"
