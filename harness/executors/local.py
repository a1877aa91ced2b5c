"""The local executor: every job in this process, one after the other, on the driver's GL context
(``ldbench run`` without ``--executor``). References first (each once), then the jobs in suite order."""
from __future__ import annotations

from ..runner import RunContext, progress_bar, prepare, prepare_key, release_inputs, run_job


class LocalExecutor:
    uses_driver_gpu = True

    def run(self, plan, out, *, gpu, progress: bool = True) -> list[dict]:
        ctx = RunContext(gpu=gpu, machine=plan.machine, git=plan.git, run_id=plan.run_id,
                         suite_name=plan.suite_name, out=out)
        prepared: dict = {}
        try:
            keys = plan.keys()
            for key in progress_bar(keys, len(keys), "references", progress):
                prepared[key] = prepare(plan.scenes[key[0]], key, cache=plan.reference_cache, progress=progress)
            return [run_job(ctx, job, prepared[prepare_key(job)])
                    for job in progress_bar(plan.jobs, len(plan.jobs), "runs", progress)]
        finally:
            release_inputs(prepared)
