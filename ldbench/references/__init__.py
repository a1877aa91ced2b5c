"""Mitsuba 3 ground truth for ldbench (docs/design.md, "Effects").

```python
from references import render_reference
ref = render_reference(scene, Effect("ao"), width=256, height=256, spp=1024)
ref.mean, ref.variance, ref.mask, ref.meta
```

- :func:`render_effect` and :data:`EXACT` (:mod:`ldbench.references.registry`): the ground truth of any effect by
  its spec's ``reference_key``, and the exact geometry the effects build their inputs from.
- :func:`render_reference` (:mod:`ldbench.references.render`): ``ao``, ``direct``, ``indirect`` references with
  per-pixel variance of the mean, primary rays through pixel centres, whole-wavefront sampling, cache.
- :func:`choose_variant` (:mod:`ldbench.references.variant`): ``cuda_ad_rgb`` if CUDA works, else
  ``llvm_ad_rgb`` with ``DRJIT_LIBLLVM_PATH`` pointed at a libLLVM ≥ 17.
- :mod:`ldbench.core.exr`: ``write_exr`` / ``read_exr`` (atomic OpenEXR I/O, reused by the runner).
- :mod:`ldbench.references.integrators`: the Mitsuba scene build and the estimators.
"""
from .cache import REFERENCE_VERSION, default_cache_dir
from ldbench.core.exr import read_exr, read_image, write_exr, write_image
from .registry import EXACT, render_effect, trace
from .render import Reference, primary_hits, render_reference
from .variant import choose_variant, setup_llvm_env

__all__ = [
    "render_effect", "EXACT", "trace", "render_reference", "Reference", "choose_variant", "setup_llvm_env", "primary_hits",
    "REFERENCE_VERSION", "default_cache_dir", "write_exr", "read_exr", "write_image", "read_image",
]
