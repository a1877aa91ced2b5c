"""Ctrl-C held back while native code starts that cannot be interrupted safely.

Dr.Jit and Mitsuba start (import, variant choice, first kernel) in C++ that calls back into Python: a
``KeyboardInterrupt`` raised inside it comes out as another exception (an ``ImportError`` "error while
initializing the extension", a failed variant) or aborts the process (SIGABRT, leaving the run's partial folder
and lock). :func:`deferred_interrupt` lets such a block finish and raises the ``KeyboardInterrupt`` right after
it, where ldbench's own clean-up runs; a second Ctrl-C during the block interrupts at once (the user insists).
"""
from __future__ import annotations

import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager


@contextmanager
def deferred_interrupt() -> Iterator[None]:
    """Run the block with SIGINT recorded instead of raised; raise ``KeyboardInterrupt`` after it when one
    came (a second one during the block is raised at once). Outside the main thread, or when SIGINT has a
    handler other than Python's default (an embedding application's), the block runs as it is."""
    if threading.current_thread() is not threading.main_thread() or \
            signal.getsignal(signal.SIGINT) is not signal.default_int_handler:
        yield
        return
    got: list[int] = []

    def record(signum, frame):
        if got:  # the second Ctrl-C: the user insists
            signal.signal(signal.SIGINT, signal.default_int_handler)
            raise KeyboardInterrupt
        got.append(signum)

    signal.signal(signal.SIGINT, record)
    try:
        yield
    finally:
        if signal.getsignal(signal.SIGINT) is record:
            signal.signal(signal.SIGINT, signal.default_int_handler)
    if got:
        raise KeyboardInterrupt
