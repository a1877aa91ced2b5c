import os
from pathlib import Path

import pytest

# The shared scene mirror beside the checkout (or LDBENCH_SHARED). Tests that need it skip with a reason
# containing SHARED_SKIP, and pytest_terminal_summary counts them in one loud line.
SHARED = Path(os.environ.get("LDBENCH_SHARED") or Path(__file__).resolve().parents[1].parent / "shared")
SHARED_SCENES = SHARED / "scenes"
SHARED_SKIP = "shared scenes not present"
needs_shared_scenes = pytest.mark.skipif(not SHARED_SCENES.is_dir(), reason=f"{SHARED_SKIP} ({SHARED_SCENES})")


@pytest.fixture(scope="session")
def gpu():
    """One headless GL context for the whole test session (llvmpipe on CI)."""
    from ldbench.core.gpu import Gpu

    g = Gpu()
    yield g
    g.release()


@pytest.fixture(scope="session", autouse=True)
def _isolated_cache(tmp_path_factory):
    """Reference cache in a per-session temp folder unless LDBENCH_CACHE is set. Registered real scenes
    are read from the shared mirror (loading only reads and verifies), else from an empty folder: tests
    never touch the user's scene cache."""
    if "LDBENCH_CACHE" not in os.environ:
        os.environ["LDBENCH_CACHE"] = str(tmp_path_factory.mktemp("ref-cache"))
    if "LDBENCH_SCENES" not in os.environ:
        os.environ["LDBENCH_SCENES"] = str(SHARED_SCENES if SHARED_SCENES.is_dir()
                                           else tmp_path_factory.mktemp("scene-cache"))
    yield


def pytest_collection_modifyitems(config, items):
    if os.environ.get("LDBENCH_SLOW") == "1":
        return
    skip = pytest.mark.skip(reason="slow; set LDBENCH_SLOW=1")
    for it in items:
        if "slow" in it.keywords:
            it.add_marker(skip)


def _skip_reason(report) -> str:
    lr = report.longrepr
    return str(lr[2] if isinstance(lr, tuple) and len(lr) == 3 else lr or "")


def pytest_terminal_summary(terminalreporter, exitstatus, config):
    """One loud line when tests skipped for lack of the shared scenes (never a silent skip)."""
    n = sum("shared scenes" in _skip_reason(r).lower() for r in terminalreporter.stats.get("skipped", []))
    if n:
        terminalreporter.write_sep(
            "!", f"{n} test{'s' if n != 1 else ''} SKIPPED: the shared scenes are missing ({SHARED_SCENES}); real "
                 f"scenes, their checksums and `scenes fetch --from` went untested", red=True, bold=True)
    c = sum("chromium not installed" in _skip_reason(r).lower() for r in terminalreporter.stats.get("skipped", []))
    if c:
        terminalreporter.write_sep(
            "!", f"{c} test{'s' if c != 1 else ''} SKIPPED: chromium is not installed; the report's image viewer "
                 f"went untested in a browser", yellow=True, bold=True)
