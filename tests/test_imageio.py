"""The run's image files (ldbench/core/imageio.py): PNG previews hold the sRGB pixels of the image, written atomically."""
import numpy as np
import pytest

from ldbench.core import imageio
from ldbench.core.exr import read_exr
from ldbench.core.metrics import to_srgb8


def _read_png(path):
    from PIL import Image

    with Image.open(path) as im:
        return np.asarray(im)


@pytest.mark.parametrize("channels", [1, 3])
def test_save_image_writes_the_srgb_preview_and_the_exr(tmp_path, channels):
    rng = np.random.default_rng(3)
    img = rng.uniform(-0.1, 2.2, (7, 9, channels)).astype(np.float32)
    imageio.save_image(tmp_path / "a", img, png_scale=2.0)
    png = _read_png(tmp_path / "a.png")
    want = to_srgb8(np.repeat(img / 2.0, 3, -1) if channels == 1 else img / 2.0)
    assert png.shape == (7, 9, 3) and png.dtype == np.uint8
    assert np.array_equal(png, want)
    exr = read_exr(tmp_path / "a.exr")
    got = exr["Y"][..., None] if channels == 1 else np.stack([exr[c] for c in "RGB"], -1)
    assert np.array_equal(got, img)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.exr", "a.png"]  # no temporary left


def test_save_map_writes_the_exr_alone_and_returns_its_99th_percentile(tmp_path):
    """The report colours a grid's maps on one scale from the EXRs: a PNG per map would be seen by no one."""
    e = np.linspace(0.0, 1.0, 100, dtype=np.float32).reshape(10, 10)
    mask = np.ones((10, 10), bool)
    mask[0] = False
    vmax = imageio.save_map(tmp_path / "e", e, mask)
    assert vmax == pytest.approx(np.percentile(e[mask], 99))
    assert np.array_equal(read_exr(tmp_path / "e.exr")["Y"], e)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["e.exr"]


def test_write_png_refuses_floats_and_keeps_the_old_file(tmp_path, monkeypatch):
    from PIL import Image

    p = tmp_path / "x.png"
    imageio.write_png(p, np.full((2, 3), 7, np.uint8))
    with pytest.raises(ValueError):
        imageio.write_png(p, np.zeros((2, 3), np.float32))

    def half(self, fp, *a, **kw):  # an encoder that dies after part of the file
        open(fp, "wb").write(b"\x89PNG")
        raise OSError("disk full")

    monkeypatch.setattr(Image.Image, "save", half)
    with pytest.raises(OSError):
        imageio.write_png(p, np.zeros((2, 3), np.uint8))
    assert np.array_equal(_read_png(p), np.full((2, 3), 7, np.uint8))
    assert [q.name for q in tmp_path.iterdir()] == ["x.png"]
