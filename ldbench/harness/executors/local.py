"""The local executor: every job in this process, one after the other, on the driver's GL context
(``ldbench run`` without ``--executor``). References first (each once), then the jobs in suite order.

Faults, as on the Ray executor: bad input (LdbenchError) while preparing stops the run; any other
exception of a reference marks its jobs ``error: reference failed: ...``, of a job that job's row
(:func:`~ldbench.harness.runner.run_job`); the other rows are kept and the run completes.

At the end one line says where the time went (``ldbench: local: ...``, :mod:`ldbench.harness.phases`), the
split each Ray worker logs too."""
from __future__ import annotations

import logging
import time

from ldbench.core.errors import LdbenchError
from ..phases import Phases
from ..runner import RunContext, progress_bar, error_text, failed_row, prepare, prepare_key, release_inputs, run_job


class LocalExecutor:
    uses_driver_gpu = True

    def run(self, plan, out, *, gpu, progress: bool = True) -> list[dict]:
        phases, t0 = Phases(), time.perf_counter()
        ctx = RunContext(gpu=gpu, machine=plan.machine, git=plan.git, run_id=plan.run_id,
                         suite_name=plan.suite_name, out=out, save_arrays=plan.save_arrays, phases=phases,
                         job_timeout=plan.job_timeout)
        prepared: dict = {}
        failed: dict = {}  # key -> why its reference could not be made
        try:
            keys = plan.keys()
            for key in progress_bar(keys, len(keys), "references", progress):
                try:
                    prepared[key] = prepare(plan.scenes[key[0]], key, cache=plan.reference_cache, progress=progress,
                                            phases=phases)
                except LdbenchError:
                    raise
                except Exception as e:  # noqa: BLE001 - its jobs' rows say so
                    failed[key] = f"error: reference failed: {error_text(e)}"
            rows = [failed_row(plan, job, failed[prepare_key(job)]) if prepare_key(job) in failed
                    else run_job(ctx, job, prepared[prepare_key(job)])
                    for job in progress_bar(plan.jobs, len(plan.jobs), "runs", progress)]
            logging.getLogger(__name__).info(f"local: {len(keys)} references, {len(plan.jobs)} jobs in "
                                             f"{time.perf_counter() - t0:.1f} s: {Phases.text(phases.as_dict())}")
            return rows
        finally:
            release_inputs(prepared)
