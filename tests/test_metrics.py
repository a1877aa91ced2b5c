import math

import numpy as np
import pytest

from ldbench.core import metrics as M
from ldbench.core.errors import LdbenchError


def _smooth(h=48, w=64, c=3, seed=0):
    """A smooth positive test image in [0.1, 0.9]."""
    y, x = np.mgrid[0:h, 0:w].astype(np.float32)
    chans = [0.5 + 0.4 * np.sin(x / (5 + k) + y / (7 + k) + k) for k in range(c)]
    return np.stack(chans, axis=2).astype(np.float32)


@pytest.mark.parametrize("c", [1, 3])
def test_identical_images(c):
    ref = _smooth(c=c)
    out = M.all_metrics(ref.copy(), ref)
    assert out["psnr"] == math.inf
    assert out["ssim"] == pytest.approx(1.0, abs=1e-6)
    assert out["flip"] == 0.0
    assert out["relmse"] == 0.0
    fl, fmap = M.flip(ref, ref)
    assert fl == 0.0 and fmap.shape == ref.shape[:2] and fmap.dtype == np.float32


@pytest.mark.parametrize("c", [1, 3])
def test_psnr_matches_formula_for_gaussian_noise(c):
    rng = np.random.default_rng(1)
    ref = np.full((64, 64, c), 0.5, np.float32)
    noise = rng.normal(0.0, 0.05, ref.shape)
    test = (ref + noise).astype(np.float32)
    mse = np.mean((test.astype(np.float64) - ref) ** 2)
    # data range defaults to max(ref) = 0.5
    assert M.psnr(test, ref) == pytest.approx(10 * np.log10(0.5 ** 2 / mse), rel=1e-9)
    assert M.psnr(test, ref, data_range=1.0) == pytest.approx(10 * np.log10(1.0 / mse), rel=1e-9)
    # and close to the expectation for sigma = 0.05
    assert M.psnr(test, ref) == pytest.approx(10 * np.log10(0.25 / 0.05 ** 2), abs=0.2)
    assert M.relmse(test, ref) == pytest.approx(np.mean(noise.astype(np.float32) ** 2 / (0.25 + 1e-2)), rel=1e-3)


def test_noise_lowers_ssim_and_raises_flip():
    ref = _smooth()
    rng = np.random.default_rng(2)
    test = np.clip(ref + rng.normal(0, 0.1, ref.shape), 0, 1).astype(np.float32)
    assert 0.0 < M.ssim(test, ref) < 0.9
    assert M.flip(test, ref)[0] > 0.01


def test_flip_nonzero_for_shifted_image():
    ref = _smooth()
    shifted = np.roll(ref, 3, axis=1)
    fl, fmap = M.flip(shifted, ref)
    assert fl > 0.01
    assert fmap.max() > 0


def test_flip_mean_matches_flip_evaluator_without_mask():
    import flip_evaluator

    ref = _smooth()
    test = np.roll(ref, 2, axis=0)
    _, expected, _ = flip_evaluator.evaluate(ref, test, "LDR", inputsRGB=False, applyMagma=False,
                                             parameters={"ppd": 67.0})
    assert M.flip(test, ref)[0] == pytest.approx(expected, rel=1e-4)


def test_hdr_flip_runs_on_values_above_one():
    ref = 4.0 * _smooth()
    test = 4.0 * np.roll(_smooth(), 2, axis=1)
    fl, _ = M.flip(test, ref, hdr=True)
    assert fl > 0 and M.flip(ref, ref, hdr=True)[0] == 0.0


def test_one_channel_equals_replicated_three_channels():
    ref1 = _smooth(c=1)
    rng = np.random.default_rng(3)
    test1 = np.clip(ref1 + rng.normal(0, 0.05, ref1.shape), 0, 1).astype(np.float32)
    ref3, test3 = np.repeat(ref1, 3, axis=2), np.repeat(test1, 3, axis=2)
    a, b = M.all_metrics(test1, ref1), M.all_metrics(test3, ref3)
    for k in ("psnr", "ssim", "flip", "relmse"):
        assert a[k] == pytest.approx(b[k], rel=1e-6), k
    # H x W is accepted as one channel
    assert M.psnr(test1[:, :, 0], ref1[:, :, 0]) == pytest.approx(a["psnr"])


@pytest.mark.parametrize("c", [1, 3])
def test_mask_excludes_background(c):
    ref = _smooth(c=c)
    h, w = ref.shape[:2]
    mask = np.zeros((h, w), bool)
    mask[10:38, 12:50] = True
    rng = np.random.default_rng(4)
    test = np.clip(ref + rng.normal(0, 0.05, ref.shape), 0, 1).astype(np.float32)
    corrupt = test.copy()
    corrupt[~mask] = rng.uniform(0, 1, corrupt[~mask].shape)  # background garbage only
    a, b = M.all_metrics(test, ref, mask=mask), M.all_metrics(corrupt, ref, mask=mask)
    for k in ("psnr", "ssim", "flip", "relmse"):
        assert a[k] == b[k], k
    assert np.array_equal(M.error_map(test, ref, mask=mask), M.error_map(corrupt, ref, mask=mask))
    # ... while without the mask the garbage counts
    assert M.psnr(corrupt, ref) < M.psnr(test, ref)
    # a perfect foreground is perfect whatever the background
    perfect = ref.copy()
    perfect[~mask] = 0.0
    assert M.psnr(perfect, ref, mask=mask) == math.inf
    assert M.ssim(perfect, ref, mask=mask) == pytest.approx(1.0)
    assert M.flip(perfect, ref, mask=mask)[0] == 0.0


def test_data_range_default_ignores_background():
    ref = np.full((16, 16, 1), 0.25, np.float32)
    mask = np.ones((16, 16), bool)
    mask[:4] = False
    ref[:4] = 10.0
    assert M.default_data_range(ref, mask=mask) == 0.25
    assert M.all_metrics(ref, ref, mask=mask)["metric_settings"]["psnr"]["data_range"] == 0.25


@pytest.mark.parametrize("c", [1, 3])
def test_all_black_reference_falls_back_to_data_range_one(c):
    """default_data_range's documented fallback: a reference whose valid pixels are all 0 (no peak) is
    measured against 1.0, so PSNR stays finite (not -inf, not NaN), also when only the background is lit."""
    ref = np.zeros((16, 16, c), np.float32)
    test = np.full(ref.shape, 0.1)  # MSE = 0.01 -> 10 log10(1 / 0.01) = 20 dB
    assert M.psnr(test, ref) == pytest.approx(20.0, abs=1e-9)
    assert M.default_data_range(ref) == 1.0
    out = M.all_metrics(test, ref)
    assert out["psnr"] == pytest.approx(20.0, abs=1e-9) and math.isfinite(out["ssim"])
    assert out["metric_settings"]["psnr"]["data_range"] == 1.0 == out["metric_settings"]["ssim"]["data_range"]
    mask = np.ones((16, 16), bool)
    mask[:4] = False
    ref[:4] = 5.0  # a bright background does not count: the valid pixels are still all black
    assert M.default_data_range(ref, mask=mask) == 1.0
    assert M.psnr(test, ref, mask=mask) == pytest.approx(20.0, abs=1e-9)


def test_empty_mask_gives_nan():
    ref = _smooth()
    mask = np.zeros(ref.shape[:2], bool)
    out = M.all_metrics(ref, ref, mask=mask)
    assert all(math.isnan(out[k]) for k in ("psnr", "ssim", "flip", "relmse"))


def test_ssim_tiny_images_shrink_window():
    assert M.ssim_win_size(5, 40) == 5
    assert M.ssim_win_size(6, 40) == 5
    assert M.ssim_win_size(64, 64) == 7
    ref = _smooth(h=4, w=9)
    assert M.ssim(ref, ref) == pytest.approx(1.0)
    assert M.all_metrics(ref, ref)["metric_settings"]["ssim"]["win_size"] == 3
    with pytest.raises(LdbenchError):
        M.ssim(ref[:2], ref[:2])
    with pytest.raises(LdbenchError):
        M.ssim(ref, ref, win_size=4)


def test_metric_settings_recorded():
    ref = _smooth()
    s = M.all_metrics(ref, ref)["metric_settings"]
    assert s["ssim"]["win_size"] == 7 and s["ssim"]["data_range"] == pytest.approx(float(ref.max()))
    assert s["flip"]["mode"] == "LDR" and s["flip"]["ppd"] == 67.0
    assert s["relmse"]["eps"] == 1e-2


@pytest.mark.parametrize("test_shape, ref_shape, mask_shape", [
    ((8, 8, 3), (8, 8, 1), None),
    ((8, 9, 3), (8, 8, 3), None),
    ((8,), (8,), None),
    ((2, 8, 8, 3), (2, 8, 8, 3), None),
    ((8, 8, 4), (8, 8, 4), None),
    ((8, 8, 3), (8, 8, 3), (8, 7)),
])
def test_bad_shapes_raise(test_shape, ref_shape, mask_shape):
    t, r = np.zeros(test_shape, np.float32), np.zeros(ref_shape, np.float32)
    mask = None if mask_shape is None else np.ones(mask_shape, bool)
    for fn in (M.psnr, M.ssim, M.relmse, M.error_map, M.all_metrics):
        with pytest.raises(LdbenchError):
            fn(t, r, mask=mask)
    with pytest.raises(LdbenchError):
        M.flip(t, r, mask=mask)


def test_error_map_and_colorize():
    ref = np.zeros((4, 5, 3), np.float32)
    test = ref.copy()
    test[1, 2] = [0.3, 0.6, 0.9]
    mask = np.ones((4, 5), bool)
    mask[0, 0] = False
    test[0, 0] = 5.0
    e = M.error_map(test, ref, mask=mask)
    assert e.shape == (4, 5) and e.dtype == np.float32
    assert e[1, 2] == pytest.approx(0.6) and e[0, 0] == 0.0 and e.sum() == pytest.approx(0.6)
    assert M.error_map(test, ref, mask=mask, kind="sq")[1, 2] == pytest.approx((0.09 + 0.36 + 0.81) / 3)
    with pytest.raises(LdbenchError):
        M.error_map(test, ref, kind="nope")
    rgb = M.colorize(e, vmax=0.6)
    assert rgb.shape == (4, 5, 3) and rgb.dtype == np.uint8
    assert (rgb[0, 1] == rgb[0, 0]).all() and not (rgb[1, 2] == rgb[0, 0]).all()
    assert M.colorize(np.zeros((2, 2)), vmax=0).shape == (2, 2, 3)


def test_to_srgb8():
    img = np.array([[[0.0, 1.0, 2.0], [0.5, -1.0, np.nan]]], np.float32)
    out = M.to_srgb8(img)
    assert out.dtype == np.uint8 and out.shape == img.shape
    assert out[0, 0].tolist() == [0, 255, 255]
    assert out[0, 1].tolist() == [188, 0, 0]  # sRGB(0.5) = 0.7354 -> 188
