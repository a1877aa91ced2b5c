"""The one table of defaults of the commands that put a question to a scene: ``ldbench run`` (and a suite
that gives no value of its own), ``ldbench reference``, ``ldbench export`` and ``ldbench score --answer``.

One set for all of them, so a reference that ``ldbench reference`` renders with its defaults is the cache
entry a default ``run``, or the ``score`` of a default ``export``, reads: the reference cache key holds the
image size, spp and seed (ldbench/references/cache.py). The values are those the bundled suites rely on
(``suites/default.toml``: 128x128, 256 spp).

============  ==========  ===================================================================================
name          value       what
============  ==========  ===================================================================================
SIZE          128 x 128   image size when neither the command line, the suite nor the scene gives one (a
                          Mitsuba XML scene's ``<film>`` does: :func:`image_size`)
SPP           256         reference samples per pixel
SEED          0           seed of the effect's inputs and of the reference
WARMUP        2           frames run before timing starts (``run``)
FRAMES        5           timed frames per job (``run``)
JOB_TIMEOUT   3600 s      seconds one job may take before it becomes an error row (``run``; 0: no limit)
============  ==========  ===================================================================================
"""
from __future__ import annotations

SIZE = (128, 128)
SPP = 256
SEED = 0
WARMUP = 2
FRAMES = 5
#: An hour: well beyond any paper-scale job measured (the slowest, Figure 9's, takes minutes on llvmpipe).
JOB_TIMEOUT = 3600.0


def image_size(scene) -> tuple:
    """The image size of a question that gives none: the scene's film (``scene.params['film']``, a
    Mitsuba XML scene's ``<film>``), else :data:`SIZE`. Not yet checked against the size limits
    (:func:`ldbench.harness.suite.parse_size` does)."""
    film = scene.params.get("film")
    return tuple(film) if film else SIZE
