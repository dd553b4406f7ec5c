"""The README gallery renders and stays small."""

from __future__ import annotations

import pytest
from PIL import Image

from simroad import SimroadError
from simroad.experiments.gallery import GALLERY_NOISES, GALLERY_SEVERITIES, render_gallery, render_wiper_sequence


def test_gallery_is_one_small_png_with_a_row_per_noise(tmp_path):
    path = render_gallery(tmp_path / "sub" / "weather.png", seed=0)
    assert path.exists() and path.stat().st_size < 400_000
    with Image.open(path) as img:
        assert img.format == "PNG"
        assert img.size == (320 * (1 + len(GALLERY_SEVERITIES)), 180 * len(GALLERY_NOISES))


def test_gallery_wants_a_png_path(tmp_path):
    with pytest.raises(SimroadError, match=r"path: expected a \.png"):
        render_gallery(tmp_path / "weather.jpg")


def test_wiper_figure_is_eight_frames_around_a_wipe(tmp_path):
    path = render_wiper_sequence(tmp_path / "windscreen.png", size=(160, 90))
    with Image.open(path) as img:
        assert img.format == "PNG" and img.size == (4 * 160, 2 * 90)
    with pytest.raises(SimroadError, match=r"path: expected a \.png"):
        render_wiper_sequence(tmp_path / "windscreen.gif")
