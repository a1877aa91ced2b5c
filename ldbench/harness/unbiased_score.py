"""``ldbench score --test unbiased``: the glue between :mod:`ldbench.harness.score` and the statistics of
:mod:`ldbench.core.unbiased` (reading the answer's variance, running the test, writing its maps).

The answer states its per-pixel variance of the mean one of two ways:

- ``variance``: an image (EXR, linear, the answer's channels) holding the variance of the mean, i.e. the
  sample variance divided by the sample count;
- ``samples`` N (≥ 2) with ``second_moment``: an EXR of the per-pixel mean of the squared samples; the
  variance of the mean is then ``(M₂ − M₁²) / (N − 1)`` with M₁ the answer itself.

With ``samples`` known the per-pixel statistic is Welch's t, else the normal z.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ldbench.core.errors import LdbenchError
from ldbench.core.exr import read_answer_channels, write_exr
from ldbench.core.imageio import write_png
from ldbench.core.metrics import colorize

# Heavy: ldbench.core.unbiased imports scipy.stats; it is imported by the functions that run the test, so the runner
# and the scoring modules that import this one start without it.

TESTS = ("unbiased",)
#: Files of the folder layout (``ldbench score --from``) that state an answer's variance.
VARIANCE_NAMES = {"variance": "variance.exr", "second_moment": "second_moment.exr"}


def check_test_args(test, variance, second_moment, samples, alpha, correction) -> dict:
    """The :class:`~ldbench.harness.score.Answer` fields of a test, checked (one line for each bad value)."""
    from ldbench.core.unbiased import CORRECTIONS

    if test is not None and test not in TESTS:
        raise LdbenchError(f"test must be one of {', '.join(TESTS)}, got {test!r}")
    if samples is not None:
        if isinstance(samples, bool) or not isinstance(samples, (int, np.integer)) or samples < 2:
            raise LdbenchError(f"samples (the answer's samples per pixel) must be an integer >= 2, got {samples!r}")
        samples = int(samples)
    if isinstance(alpha, bool) or not isinstance(alpha, (int, float)) or not 0.0 < float(alpha) < 1.0:
        raise LdbenchError(f"alpha must be a number in (0, 1), got {alpha!r}")
    if correction not in CORRECTIONS:
        raise LdbenchError(f"correction must be one of {', '.join(CORRECTIONS)}, got {correction!r}")
    return {"test": test, "variance": None if variance is None else Path(variance),
            "second_moment": None if second_moment is None else Path(second_moment), "samples": samples,
            "alpha": float(alpha), "correction": correction}


def read_exr_image(path, channels: int) -> np.ndarray:
    """H×W×channels float32 of a linear EXR (channel ``Y``, or ``R, G, B``; grey repeated for colour)."""
    path = Path(path)
    if not path.is_file():
        raise LdbenchError(f"file not found: {path}")
    if path.suffix.lower() != ".exr":
        raise LdbenchError(f"{path.name}: must be an EXR (linear float values)")
    try:
        img = read_answer_channels(path)
    except (OSError, ValueError) as e:
        raise LdbenchError(f"cannot read {path}: {e}") from None
    if channels == 3 and img.shape[-1] == 1:
        img = np.repeat(img, 3, -1)
    elif channels == 1 and img.shape[-1] == 3:
        if not (np.array_equal(img[..., 0], img[..., 1]) and np.array_equal(img[..., 0], img[..., 2])):
            raise LdbenchError(f"{path.name}: a one-channel effect needs a Y channel or R = G = B")
        img = img[..., :1]
    return img


def answer_variance(answer, image: np.ndarray, channels: int) -> np.ndarray:
    """H×W×C variance of the mean of ``image`` (the answer) from what ``answer`` states (module docstring)."""
    from ldbench.core.unbiased import variance_of_mean

    var_path = getattr(answer, "variance", None)
    m2_path = getattr(answer, "second_moment", None)
    n = getattr(answer, "samples", None)
    if var_path is not None and m2_path is not None:
        raise LdbenchError("give the answer's variance of the mean or its second moment, not both")
    if var_path is not None:
        var = read_exr_image(var_path, channels)
    elif m2_path is not None:
        if n is None:
            raise LdbenchError("a second-moment image needs the answer's samples per pixel (--samples N)")
        m2 = read_exr_image(m2_path, channels)
        if m2.shape != image.shape:
            raise LdbenchError(f"{Path(m2_path).name}: shape {m2.shape[:2]} differs from the answer's {image.shape[:2]}")
        var = variance_of_mean(image, m2, n).astype(np.float32)
    else:
        raise LdbenchError("--test unbiased needs the answer's variance of the mean: --variance FILE.exr, or "
                           "--samples N with --second-moment FILE.exr")
    if var.shape != image.shape:
        raise LdbenchError(f"the variance image is {var.shape[1]}x{var.shape[0]}, the answer {image.shape[1]}x"
                           f"{image.shape[0]}")
    return var


def run_test(test: str, question, answer, result, reference, spec, *, alpha: float, correction: str):
    """(:class:`~ldbench.core.unbiased.UnbiasedResult`, columns) of ``test`` on one scored answer."""
    from ldbench.core.unbiased import unbiased_test

    if test not in TESTS:
        raise LdbenchError(f"unknown test {test!r} (known: {', '.join(TESTS)})")
    if spec.output != "image":
        raise LdbenchError(f"--test unbiased compares images; effect {question.effect.name!r} answers "
                           f"{spec.output}")
    variance = getattr(reference, "variance", None)
    if variance is None:
        raise LdbenchError(f"the {question.effect.name!r} reference has no per-pixel variance to test against")
    image = np.asarray(result.image, np.float32)
    if image.ndim == 2:
        image = image[..., None]
    var = answer_variance(answer, image, spec.channels)
    missing = None if result.mask is None else ~np.asarray(result.mask, bool)
    tested = np.asarray(reference.mask, bool).copy()
    if missing is None:
        tested[:] = True               # every pixel has a value: all are tested (background exactly)
    else:
        tested |= ~missing             # background pixels the answer gave a value are tested too
        missing = missing & np.asarray(reference.mask, bool)
    meta = getattr(reference, "meta", {}) or {}
    n_ref = meta.get("spp")
    res = unbiased_test(image, var, reference.mean, variance, n_answer=getattr(answer, "samples", None),
                        n_reference=n_ref if (n_ref or 0) >= 2 else None, mask=tested, missing=missing,
                        alpha=alpha, correction=correction)
    return res, res.columns()


def save_maps(res, folder: Path, label: str) -> dict:
    """Write ``<label>-unbiased-p.exr`` (per-pixel p, NaN = not tested), ``<label>-unbiased-p.png``
    (−log10 p, magma, white = the corrected per-pixel threshold) and ``<label>-unbiased-reject.png``
    (:data:`ldbench.core.unbiased.REJECT_COLOURS`); returns their names for the row's ``images``."""
    from ldbench.core.unbiased import reject_map_rgb, sidak_threshold

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    write_exr(str(folder / f"{label}-unbiased-p.exr"), {"Y": res.p_map.astype(np.float32)})
    with np.errstate(divide="ignore"):
        lp = -np.log10(np.clip(np.nan_to_num(res.p_map, nan=1.0), 1e-300, 1.0))
    vmax = -np.log10(sidak_threshold(res.alpha, max(res.tested, 1)))
    write_png(folder / f"{label}-unbiased-p.png", colorize(lp, vmax=vmax))
    write_png(folder / f"{label}-unbiased-reject.png", reject_map_rgb(res.reject_map))
    return {"unbiased_p": f"{label}-unbiased-p.png", "unbiased_p_exr": f"{label}-unbiased-p.exr",
            "unbiased_reject": f"{label}-unbiased-reject.png"}


def method_test(test: str, result, reference, spec, folder, label: str, *, alpha: float = 0.01,
                correction: str = "sidak"):
    """(columns, maps) of a suite's ``test = "unbiased"`` on a method's frame: the method's
    ``arrays["variance"]`` (variance of the mean) and ``counters["samples"]`` (samples per pixel)."""
    from ldbench.core.unbiased import unbiased_test

    if test not in TESTS:
        raise LdbenchError(f"unknown test {test!r} (known: {', '.join(TESTS)})")
    var = (result.arrays or {}).get("variance")
    if var is None:
        raise LdbenchError("test = \"unbiased\": the method gave no arrays[\"variance\"] (variance of the mean)")
    image = np.asarray(result.image, np.float32)
    image = image[..., None] if image.ndim == 2 else image
    var = np.asarray(var, np.float32)
    var = var[..., None] if var.ndim == 2 else var
    n = (result.counters or {}).get("samples")
    meta = getattr(reference, "meta", {}) or {}
    n_ref = meta.get("spp")
    missing = None if result.mask is None else ~np.asarray(result.mask, bool) & np.asarray(reference.mask, bool)
    res = unbiased_test(image, var, reference.mean, reference.variance,
                        n_answer=int(n) if n is not None and int(n) >= 2 else None,
                        n_reference=n_ref if (n_ref or 0) >= 2 else None, missing=missing, alpha=alpha,
                        correction=correction)
    return res.columns(), save_maps(res, folder, label)
