"""The local executor: every job in this process, one after the other, on the driver's GL context
(``ldbench run`` without ``--executor``). References first (each once), then the jobs in suite order.

Faults, as on the Ray executor: bad input (LdbenchError) while preparing stops the run; any other
exception of a reference marks its jobs ``error: reference failed: ...``, of a job that job's row
(:func:`~ldbench.harness.runner.run_job`); the other rows are kept and the run completes.

With ``writers`` > 0 (``ldbench run --writers N``) a job's scoring and saving go to N writer processes
(:mod:`ldbench.harness.writers`) while this process renders the next jobs: the same rows, in the same order.

At the end one line says where the time went (``ldbench: local: ...``, :mod:`ldbench.harness.phases`), the
split each Ray worker logs too; with writers, their own split after a ``;``."""
from __future__ import annotations

import logging
import time
from contextlib import nullcontext

from ldbench.core.errors import LdbenchError
from ..phases import Phases
from ..runner import (Finish, RunContext, progress_bar, error_text, failed_row, prepare, prepare_key, release_inputs,
                      run_job, start_job)
from ..writers import Writers, default_writers


class LocalExecutor:
    uses_driver_gpu = True

    def __init__(self, writers: int | None = None):
        self.writers = writers  # writer processes (ldbench/harness/writers.py); None: default_writers

    def writer_count(self, plan) -> int:
        """The writers this run gets: ``writers``, else :func:`default_writers` for the device; never more
        than there are jobs to hand over (none for one job, where nothing can overlap, unless asked)."""
        if self.writers is not None:
            return min(self.writers, len(plan.jobs))
        return min(default_writers(plan.machine.get("device")), max(len(plan.jobs) - 1, 0))

    def run(self, plan, out, *, gpu, progress: bool = True) -> list[dict]:
        phases, t0 = Phases(), time.perf_counter()
        ctx = RunContext(gpu=gpu, machine=plan.machine, git=plan.git, run_id=plan.run_id,
                         suite_name=plan.suite_name, out=out, save_arrays=plan.save_arrays, phases=phases,
                         job_timeout=plan.job_timeout)
        prepared: dict = {}
        failed: dict = {}  # key -> why its reference could not be made
        n = self.writer_count(plan)
        try:
            # the writers start first: their imports overlap the references
            with Writers(n, phases=phases) if n else nullcontext() as pool:
                keys = plan.keys()
                for key in progress_bar(keys, len(keys), "references", progress):
                    try:
                        prepared[key] = prepare(plan.scenes[key[0]], key, cache=plan.reference_cache,
                                                progress=progress, phases=phases)
                    except LdbenchError:
                        raise
                    except Exception as e:  # noqa: BLE001 - its jobs' rows say so
                        failed[key] = f"error: reference failed: {error_text(e)}"
                rows = []
                for i, job in enumerate(progress_bar(plan.jobs, len(plan.jobs), "runs", progress)):
                    key = prepare_key(job)
                    if key in failed:
                        row = failed_row(plan, job, failed[key])
                    elif pool is None:
                        row = run_job(ctx, job, prepared[key])
                    else:
                        started = start_job(ctx, job, prepared[key])
                        if isinstance(started, Finish):
                            pool.submit(i, key, prepared[key], started)
                            continue
                        row = started
                    if pool is None:
                        rows.append(row)
                    else:
                        pool.put(i, row)
                if pool is not None:
                    rows = pool.rows()
            line = (f"local: {len(keys)} references, {len(plan.jobs)} jobs in {time.perf_counter() - t0:.1f} s: "
                    f"{Phases.text(phases.as_dict())}")
            if pool is not None:
                line += f"; {pool.text()}"
            logging.getLogger(__name__).info(line)
            return rows
        finally:
            release_inputs(prepared)
