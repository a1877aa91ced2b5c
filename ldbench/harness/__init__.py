"""ldbench: benchmark and validation of real-time GI through rasterized layered depth structures.

The public reader of a run's results is :func:`read_results` (:func:`ldbench.harness.records.read_results`;
docs/reference/results-columns.md); it is imported on first use, so ``import harness`` stays light.
"""

__all__ = ["read_results"]


def __getattr__(name):
    if name == "read_results":
        from .records import read_results

        return read_results
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
