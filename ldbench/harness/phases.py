"""Where a process's run time goes: seconds (and calls) per phase of its work, summed over the references
and jobs it made, for the one line per process that ``ldbench run`` logs at the end (``local:`` for the
serial run, ``ray:`` for the Ray driver and each worker; docs/how-to/run-on-ray.md). Both executors time the same phases
of :func:`~ldbench.harness.runner.prepare` and :func:`~ldbench.harness.runner.run_job`, so a worker slower
than the serial process shows which phase grew.

With ``--writers N`` (ldbench/harness/writers.py) the local line has two parts: the main thread's phases,
then, after a ``;``, the writer processes' own (``score``, ``save``, ``row``), summed over the writers and
overlapping the main thread's: the main thread's share of them is its ``handoff`` and ``wait``.

=====================  =========================================================================
``inputs``             the effect's harness inputs (``EffectSpec.inputs``)
``reference render``   a reference rendered by Mitsuba (and stored in the cache)
``reference cache``    a reference loaded from the cache
``checks``             the reference's checks (the camera sees geometry, finite values)
``receive``            (Ray worker) a job group's inputs and reference taken from the object store
``setup``              ``method.setup`` and the inputs' upload to the GPU
``frames``             the warm-up and measured frames and the result's read-back
``release``            ``method.release``
``score``              the effect's metrics (PSNR, SSIM, FLIP, ...)
``save``               the images (EXR, PNG previews, error maps) and ``--save-arrays``
``handoff``            (``--writers N``) a job's result, and once per writer and reference its inputs and
                       reference, pickled and sent to a writer process
``wait``               (``--writers N``) the main thread waiting for a writer: all N busy when a job is
                       ready, and the jobs still in flight at the end
``row``                the rest of a job: the method object, the row's columns
``files``              (Ray worker) a group's staging folder, and its files read back when the driver
                       cannot see it
``put``, ``merge``     (Ray driver) what it puts into the object store; a group's files moved or written
                       into the run directory
=====================  =========================================================================
"""
from __future__ import annotations

import time
from contextlib import contextmanager

ORDER = ("inputs", "reference render", "reference cache", "checks", "receive", "setup", "frames", "release",
         "score", "save", "handoff", "wait", "row", "files", "put", "merge")


class Phases:
    """Seconds and calls per phase name (see the module docstring), added up over one process's calls."""

    def __init__(self):
        self.seconds: dict = {}
        self.calls: dict = {}

    def add(self, name: str, seconds: float, calls: int = 1) -> None:
        self.seconds[name] = self.seconds.get(name, 0.0) + float(seconds)
        self.calls[name] = self.calls.get(name, 0) + int(calls)

    @contextmanager
    def __call__(self, name: str):
        """Time the block as one call of ``name`` (also when it raises)."""
        t0 = time.perf_counter()
        try:
            yield
        finally:
            self.add(name, time.perf_counter() - t0)

    def merge(self, split: dict) -> None:
        """Add a ``{name: [seconds, calls]}`` split (:meth:`as_dict` of another process's phases)."""
        for k, (seconds, calls) in split.items():
            self.add(k, seconds, calls)

    def total(self) -> float:
        return sum(self.seconds.values())

    def as_dict(self) -> dict:
        """``{name: [seconds, calls]}`` (what a Ray worker sends the driver)."""
        return {k: [self.seconds[k], self.calls[k]] for k in self.seconds}

    @staticmethod
    def text(split: dict) -> str:
        """``{name: [seconds, calls]}`` as one line, in :data:`ORDER` (other names after):
        ``setup 162× 3.2 s, frames 162× 40.1 s, ...``."""
        names = [k for k in ORDER if k in split] + sorted(k for k in split if k not in ORDER)
        return ", ".join(f"{k} {int(split[k][1])}× {split[k][0]:.1f} s" for k in names) or "nothing timed"
