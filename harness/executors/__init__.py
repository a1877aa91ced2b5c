"""Executors: who runs the jobs of a :class:`~harness.runner.RunPlan`.

An executor has ``uses_driver_gpu`` (whether the jobs use the GL context of the process that holds the
run directory) and ``run(plan, out, *, gpu, progress) -> rows`` (one record row per ``plan.jobs``
entry, in that order; images written under ``out``). The run directory itself (lock, partial folder,
results files, commit or abort) stays with :func:`harness.runner.run_jobs`, whatever the executor.

================  ==================================================================================
``local``         this process, one job after the other (the default; :mod:`.local`)
``ray``           one Ray task per job group on a local or remote Ray cluster (:mod:`.ray`,
                  ``pip install 'ldbench[ray]'``; docs/ray.md)
================  ==================================================================================
"""
from __future__ import annotations

from ..errors import LdbenchError

EXECUTORS = ("local", "ray")


def get_executor(executor=None, **options):
    """An executor object from a name (None = ``local``) and its options, or ``executor`` itself."""
    if executor is None or executor == "local":
        if options:
            raise LdbenchError(f"--executor local takes no {', '.join('--' + k for k in options)}")
        from .local import LocalExecutor
        return LocalExecutor()
    if executor == "ray":
        from .ray import RayExecutor
        return RayExecutor(**options)
    if isinstance(executor, str):
        raise LdbenchError(f"unknown executor {executor!r} (known: {', '.join(EXECUTORS)})")
    return executor
