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


def pytest_configure(config):
    """Ctrl-C works in every test process: a shell runs a background job (``make test &``) with SIGINT
    ignored, which Python then leaves ignored, and the tests of Ctrl-C would wait for an interrupt that
    never comes. The process's own children start with the default handler again."""
    import signal

    if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)


@pytest.hookimpl(tryfirst=True)  # before `-m slow` selects
def pytest_collection_modifyitems(config, items):
    for it in items:
        # a local Ray cluster (tests/test_executor_ray.py's `cluster`): its workers' start-up and Mitsuba JIT
        # cannot be made cheap, so its tests are the slow tier; the executor's logic without a cluster is not
        if "cluster" in getattr(it, "fixturenames", ()):
            it.add_marker(pytest.mark.slow)
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


def _os_handler(signum: int) -> int:
    """The process's handler for ``signum`` as the kernel has it (0 = default, 1 = ignored, else an
    address): native code can change it behind Python's back."""
    import ctypes

    libc = ctypes.CDLL(None, use_errno=True)
    old = ctypes.create_string_buffer(256)  # struct sigaction: its first member is the handler
    libc.sigaction(signum, None, old)
    return int.from_bytes(old.raw[:ctypes.sizeof(ctypes.c_void_p)], "little")


@pytest.fixture(autouse=True)
def _signals_left_as_found(request):
    """A test leaves SIGINT's and SIGTERM's handlers and the main thread's signal mask as it found them:
    one that leaked an ignored or blocked SIGINT once made every later Ctrl-C test of its worker fail."""
    import signal

    def state():
        return (signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM),
                signal.pthread_sigmask(signal.SIG_BLOCK, []), _os_handler(signal.SIGINT))

    before = state()
    yield
    after = state()
    if after != before:
        signal.signal(signal.SIGINT, before[0])
        signal.signal(signal.SIGTERM, before[1])
        signal.pthread_sigmask(signal.SIG_SETMASK, before[2])
        if after[3] != before[3]:  # native code replaced Python's C handler: put Python's back
            signal.signal(signal.SIGINT, signal.SIG_DFL)
            signal.signal(signal.SIGINT, before[0])
        pytest.fail(f"the test changed the signal handlers or mask: {before} -> {after}")
