"""``ldbench compare BASELINE RUN``: the regression gate of the nightly benchmark (docs/how-to/nightly-ci.md).

Both arguments are run directories (``results.parquet``, else ``results.csv``) or results files.
Rows are matched by :data:`DEFAULT_MATCH` (scene and its builder parameters, method, effect and its
parameters, method parameters, image size) or by the keys given with ``--match`` (e.g.
``--match scene,method,effect`` compares two *configurations* of the same method, such as 64 against
16 LDM directions). A match key that leaves two rows of one run indistinguishable is bad input. Method
parameters are matched in their canonical form (:func:`~ldbench.harness.compare.match.canonical_params`:
old names mapped through the adapter's ``Params.renamed``, values equal to the current default dropped), so
a parameter added with a default orphans no baseline row; a parameter the adapter no longer has keeps its
row apart (``missing``).

Every matched benchmark gets up to three checks:

time (``total_ms``)
    One-sided Mann-Whitney U test (:func:`scipy.stats.mannwhitneyu`, ``alternative="greater"``) of
    the run's raw per-frame samples (``raw_ms["total"]``, else ``raw_ms["wall"]``) against the
    baseline's: *is the run stochastically slower?* A regression needs **both** ``p < alpha``
    (default 0.01) **and** a median slow-down of at least ``min_effect`` (default 10 %), so that
    tiny but consistent shifts and noise do not fail the build. The exact test cannot reach
    ``p < alpha`` with too few frames (smallest one-sided p is ``1 / C(n+m, n)``: 5 + 5 frames give
    0.004, 4 + 4 give 0.014); such a check is reported ``inconclusive`` and never fails. A
    significant speed-up of at least ``min_effect`` is reported ``improved``.
    When the machines differ (``device``, ``gl_renderer``, ``driver`` or ``gpu_name``, and ``cpu`` when
    the device is the CPU; :func:`ldbench.core.device.timing_fields`) times are not comparable: a warning
    is printed and time checks are skipped; quality is still gated.
    On a software rasterizer (``device = cpu-software``, Mesa llvmpipe) time checks are skipped as
    well unless ``--cpu-time``: its frame times are wall clock on shared CPU cores, which move between
    identical runs far beyond the within-run spread the test sees (measured in docs/how-to/nightly-ci.md); the
    CPU nightly gates quality, the GPU nightly gates time.

quality (``psnr``, ``ssim``)
    A regression is a drop beyond ``max(tolerance, what the references' own Monte Carlo noise can
    explain)``; see :func:`~ldbench.harness.compare.stats.noise_bound` for the derivation. PSNR
    tolerance ``--tol-db`` (0.5 dB), SSIM tolerance ``--ssim-tol`` (0.01). A NaN in the run where the
    baseline was finite (a broken shader) is a regression. A NaN in the baseline (a broken baseline)
    compares nothing: the check is ``unchecked`` and fails, with a warning, unless
    ``--allow-nan-baseline``.

metrics of non-image effects (``rays``, ...)
    The effect spec's ``gate`` (:class:`ldbench.core.effects.base.EffectSpec`): each listed column may
    get worse by at most ``max(absolute, relative × |baseline|)``; both sides are exact (an oracle, no
    sampling noise), so the tolerances are fixed. A NaN where the baseline was finite is a regression; a
    NaN baseline is ``unchecked`` (as for images) where the run has a value or where no metric of the
    benchmark could be compared; NaN on both sides is a metric the configuration leaves undefined
    (``n/a``: the distances of shadow rays).

status
    A row whose ``status`` is ``degraded: …`` in RUN (an invariant of its data structure failed: nodes
    lost, lists unsorted, overflow) is a regression (``degraded``), as is any other status but
    ``"ok"`` (``failed``). A row of BASELINE that
    RUN lacks is ``missing`` and fails unless ``--allow-missing``; a row only in RUN is ``new`` (never
    fails). A baseline row that had failed is not compared (``fixed`` if RUN's is ok).

Exit status: 0 no regression, 1 regression, 2 bad input (:class:`~ldbench.core.errors.LdbenchError`).
A Markdown report (``compare.md`` in RUN's directory, or ``--md FILE``) holds one table row per
check: benchmark, metric, baseline, current, change, verdict, for a CI job summary. ``--json FILE``
writes the same verdicts for machines (:func:`~ldbench.harness.compare.render.to_json`): per check the
benchmark's match key, the metric, baseline and current values as numbers, the verdict and the thresholds
it was judged by, and the overall exit status.

Modules: :mod:`~ldbench.harness.compare.match` (matching rows, benchmark names),
:mod:`~ldbench.harness.compare.verdicts` (thresholds, checks), :mod:`~ldbench.harness.compare.stats` (the
time test, the noise bound), :mod:`~ldbench.harness.compare.gate` (the comparison),
:mod:`~ldbench.harness.compare.render` (Markdown, JSON, terminal), :mod:`~ldbench.harness.compare.arguments`
and :mod:`~ldbench.harness.compare.command` (the command line: its arguments, and its run). The package
imports none of them, so that building the command line does not import pandas and scipy.
"""

