"""The local executor: every job in this process, one after the other, on the driver's GL context
(``ldbench run`` without ``--executor``). References first (each once), then the jobs in suite order."""
from __future__ import annotations

from ..runner import RunContext, _progress, prepare, prepare_key, release_inputs, run_job


class LocalExecutor:
    uses_driver_gpu = True

    def run(self, plan, out, *, gpu, progress: bool = True) -> list[dict]:
        ctx = RunContext(gpu=gpu, machine=plan.machine, git=plan.git, run_id=plan.run_id,
                         suite_name=plan.suite_name, out=out, save_arrays=plan.save_arrays)
        prepared: dict = {}
        try:
            keys = plan.keys()
            for key in _progress(keys, len(keys), "references", progress):
                prepared[key] = prepare(plan.scenes[key[0]], key, cache=plan.reference_cache, progress=progress)
            return [run_job(ctx, job, prepared[prepare_key(job)])
                    for job in _progress(plan.jobs, len(plan.jobs), "runs", progress)]
        finally:
            release_inputs(prepared)
