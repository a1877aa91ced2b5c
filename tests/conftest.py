import os
from pathlib import Path

import pytest

SHARED = Path(__file__).resolve().parents[1].parent / "shared"


@pytest.fixture(scope="session")
def gpu():
    """One headless GL context for the whole test session (llvmpipe on CI)."""
    from harness.gpu import Gpu

    g = Gpu()
    yield g
    g.release()


@pytest.fixture(scope="session", autouse=True)
def _isolated_cache(tmp_path_factory):
    """Reference cache in a per-session temp folder unless LDBENCH_CACHE is set."""
    if "LDBENCH_CACHE" not in os.environ:
        os.environ["LDBENCH_CACHE"] = str(tmp_path_factory.mktemp("ref-cache"))
    yield


def pytest_collection_modifyitems(config, items):
    if os.environ.get("LDBENCH_SLOW") == "1":
        return
    skip = pytest.mark.skip(reason="slow; set LDBENCH_SLOW=1")
    for it in items:
        if "slow" in it.keywords:
            it.add_marker(skip)
