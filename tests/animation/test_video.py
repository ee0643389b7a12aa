"""GIF through matplotlib's Pillow writer, MP4 through ffmpeg when it is on the PATH."""
from __future__ import annotations

import shutil

import numpy as np
import pytest

from lagdsl import LagError
from lagdsl.animation.video import HEIGHT, WIDTH, frame_rows

from .support import double_pendulum, every_kind, heavy_top


def test_frame_k_shows_the_last_row_at_or_before_t0_plus_k_speed_over_fps():
    t = np.array([0.0, 0.1, 0.2, 0.3, 0.35])
    assert frame_rows(t, speed=1, fps=10).tolist() == [0, 1, 2, 3]
    assert frame_rows(t, speed=1, fps=20).tolist() == [0, 0, 1, 1, 2, 2, 3, 4]
    grid = 0.5 + np.arange(91) / 30         # one row per frame, as lagc animate runs
    assert frame_rows(grid, speed=1, fps=30).tolist() == list(range(91))


def test_a_gif_has_one_frame_per_step_of_speed_over_fps(tmp_path):
    from PIL import Image
    path = tmp_path / "pendulum.gif"
    double_pendulum().animate("chaos", fps=10, speed=2, stop=4).save(path, fps=10)
    with Image.open(path) as gif:
        assert gif.size == (WIDTH, HEIGHT)
        assert gif.n_frames == 21                   # 4 s at 2 model seconds per second, 10 frames a second
        first = np.asarray(gif.convert("RGB"))
        gif.seek(10)
        later = np.asarray(gif.convert("RGB"))
    assert np.any(first != later)


def test_a_3d_model_writes_a_gif(tmp_path):
    from PIL import Image
    path = tmp_path / "top.gif"
    heavy_top().animate("nutation", fps=5, stop=1).save(path, fps=5)
    with Image.open(path) as gif:
        assert gif.n_frames == 6


@pytest.mark.parametrize("dimension", [2, 3])
def test_every_kind_is_painted_in_a_gif(tmp_path, dimension):
    from PIL import Image
    path = tmp_path / "kinds.gif"
    every_kind(dimension).save(path, fps=1)
    with Image.open(path) as gif:
        first = np.asarray(gif.convert("RGB"))
        gif.seek(1)
        second = np.asarray(gif.convert("RGB"))
    assert np.count_nonzero(np.any(first != 255, axis=2)) > 1000 and np.any(first != second)


@pytest.mark.skipif(shutil.which("ffmpeg") is None, reason="ffmpeg is not on the PATH")
def test_an_mp4_is_written_through_ffmpeg(tmp_path):
    path = tmp_path / "pendulum.mp4"
    double_pendulum().animate("chaos", fps=10, stop=1).save(path, fps=10)
    assert path.read_bytes()[4:8] == b"ftyp"          # the ISO media file's first box


def test_without_ffmpeg_an_mp4_is_refused_naming_the_alternatives(tmp_path, monkeypatch):
    animation = double_pendulum().animate("chaos", fps=10, stop=0.2)
    monkeypatch.setenv("PATH", str(tmp_path))         # no ffmpeg here
    with pytest.raises(LagError, match=r"ffmpeg.*\.gif.*\.html"):
        animation.save(tmp_path / "pendulum.mp4")
    assert not (tmp_path / "pendulum.mp4").exists()
