"""One overflow rule for every adapter built on a layered structure (ldbench/methods/invariants.py): fragments a
full pool dropped are a violated invariant, whatever the pool policy (``pool = "fixed"`` included), and the
runner marks the row ``degraded``. ``ldm`` and ``ll-oit`` are the adapters with a ``pool`` parameter; ``ldi``
and ``cdi-vpl`` list their structures' overflow by the same helper (theirs can only overflow at the
SSBO size limit).

Broken on purpose once (and seen failing): the helper not adding the overflow line (the rule as before:
``fixed`` pools silent) fails every test here (ll-oit's too: it no longer holds its own pool to a separate
rule); the runner not marking rows whose invariants are listed fails
``test_a_fixed_pool_that_overflows_degrades_the_row``."""
from __future__ import annotations

import pytest

from ldbench.core.effects import Effect
from ldbench.methods.base import View, get_method
from testkit import cornell_like


def _frame(gpu, method, effect, size=16, inputs=None, **params):
    cls = get_method(method)
    scene = cornell_like()
    m = cls(cls.Params.from_dict(params, method=method))  # the earlier flat names (pool) through renamed
    m.setup(gpu, scene)
    try:
        if inputs is not None:
            inputs = inputs(scene)
            inputs.upload(gpu)
        return m.frame(View(scene.camera, size, size), Effect(effect), inputs).resolve()
    finally:
        m.release()


CASES = {
    "ldm-ao": ("ldm", "ao", None, dict(directions=8, resolution=16)),
    "ldm-linear": ("ldm", "ao", None, dict(directions=8, resolution=16, layout="linear")),
    "ll-oit": ("ll-oit", "oit", None, {}),
}


@pytest.mark.parametrize("case", list(CASES))
def test_overflow_of_a_fixed_pool_is_a_violated_invariant(gpu, case):
    method, effect, inputs, kw = CASES[case]
    r = _frame(gpu, method, effect, inputs=inputs, pool="fixed", pool_capacity=10, **kw)
    lost = r.counters["overflow"]
    assert lost > 0 and r.counters["fragments"] - lost <= 10
    assert [v for v in r.invariants if "pool overflow" in v] == \
        [f"{lost} of {r.counters['fragments']} fragments not stored (pool overflow)"], r.invariants
    # a pool large enough: nothing lost, nothing listed
    ok = _frame(gpu, method, effect, inputs=inputs, pool="fixed", pool_capacity=1 << 20, **kw)
    assert ok.counters["overflow"] == 0 and ok.invariants == []


def test_a_fixed_pool_that_overflows_degrades_the_row(tmp_path):
    """The case that passed as ``ok`` before: ldm with a fixed pool keeping 10 fragments."""
    from ldbench.harness.executors import run_jobs
    from ldbench.harness.suite import suite_from_dict

    suite = suite_from_dict({"suite": {"size": "16x16", "warmup": 0, "frames": 1},
                             "run": [{"scene": "cornell", "effect": "ao", "methods": ["ldm"],
                                      "params": {"ldm": {"directions": 8, "resolution": 16, "pool": "fixed",
                                                         "pool_capacity": 10}}}]}, name="t")
    df = run_jobs(suite, tmp_path / "run", progress=False, report=False)
    status = df["status"].iloc[0]
    assert status.startswith("degraded") and "fragments not stored (pool overflow)" in status, status
