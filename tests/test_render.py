"""Tests of the Pillow renderer and the video writer."""

from __future__ import annotations

import sys

import numpy as np
import pytest
from PIL import Image

from envs.soccer.params import DEFAULT_PARAMS
from envs.soccer.render import PLAYER_COLOURS, render_frame, save_video, world_to_pixel
from envs.soccer.state import SoccerState


def two_player_state() -> SoccerState:
    s = SoccerState.zeros(2, 2)
    s.pos[0] = [[20.0, 5.0], [35.0, -10.0]]
    s.body[0] = [0.0, -120.0]
    s.ball_pos[0] = [30.0, 15.0]
    s.cycle[0] = 12
    s.pos[1] = [[5.0, 5.0], [6.0, 6.0]]
    return s


def pixel(frame: np.ndarray, xy: tuple[float, float], offset: tuple[int, int] = (0, 0)) -> np.ndarray:
    col, row = np.rint(world_to_pixel(xy, frame.shape[1], frame.shape[0])).astype(int)
    return frame[row + offset[1], col + offset[0]].astype(int)


@pytest.mark.parametrize(("width", "height"), [(640, 420), (320, 240), (1000, 500)])
def test_shape_and_dtype(width: int, height: int) -> None:
    frame = render_frame(two_player_state(), DEFAULT_PARAMS, width=width, height=height)
    assert frame.shape == (height, width, 3)
    assert frame.dtype == np.uint8
    assert frame.std() > 10  # not a blank image


def test_ball_is_white_where_the_ball_is() -> None:
    s = two_player_state()
    frame = render_frame(s, DEFAULT_PARAMS)
    assert (pixel(frame, (30.0, 15.0)) > 200).all()
    # Grass there once the ball has gone.
    s.ball_pos[0] = [45.0, -25.0]
    moved = render_frame(s, DEFAULT_PARAMS)
    grass = pixel(moved, (30.0, 15.0))
    assert grass[1] > grass[0] + 40 and grass[1] > grass[2] + 40
    assert (pixel(moved, (45.0, -25.0)) > 200).all()


def test_players_have_their_colours() -> None:
    frame = render_frame(two_player_state(), DEFAULT_PARAMS)
    # Body 0 points +x, so the disc is free of the heading line just left of the centre.
    for i, xy in enumerate([(20.0, 5.0), (35.0, -10.0)]):
        offset = (-2, 0) if i == 0 else (2, 2)  # player 1 faces up-left
        assert np.abs(pixel(frame, xy, offset) - np.array(PLAYER_COLOURS[i])).max() < 50


def test_player_positions_change_the_frame() -> None:
    s = two_player_state()
    a = render_frame(s, DEFAULT_PARAMS)
    s.pos[0, 1] = [40.0, 20.0]
    b = render_frame(s, DEFAULT_PARAMS)
    assert not np.array_equal(a, b)
    s.body[0, 0] = 90.0
    c = render_frame(s, DEFAULT_PARAMS)
    assert not np.array_equal(b, c)


def test_games_of_a_batch_differ() -> None:
    s = two_player_state()
    assert not np.array_equal(render_frame(s, game=0), render_frame(s, game=1))


def test_messages_are_drawn() -> None:
    s = two_player_state()
    plain = render_frame(s, DEFAULT_PARAMS)
    up = render_frame(s, DEFAULT_PARAMS, messages=np.full((2, 4), 0.9))
    down = render_frame(s, DEFAULT_PARAMS, messages=np.full((2, 4), -0.9))
    assert not np.array_equal(plain, up)
    assert not np.array_equal(up, down)
    # Only the panel changes, not the field.
    panel = world_to_pixel((DEFAULT_PARAMS.half_length + 6.0, 0.0))[0]
    np.testing.assert_array_equal(plain[:, : int(panel)], up[:, : int(panel)])
    # Values outside [-1, 1] and NaN are tolerated.
    render_frame(s, DEFAULT_PARAMS, messages=np.array([[5.0, np.nan], [-3.0, 0.0]]))


def test_labels_cycle_and_kickable_marks_are_drawn() -> None:
    s = two_player_state()
    plain = render_frame(s, DEFAULT_PARAMS)
    assert not np.array_equal(plain, render_frame(s, DEFAULT_PARAMS, labels=["sighted", "blind"]))
    assert not np.array_equal(plain, render_frame(s, DEFAULT_PARAMS, kickable_players=[True, False]))
    s.cycle[0] = 99
    assert not np.array_equal(plain, render_frame(s, DEFAULT_PARAMS))


def test_kickable_is_computed_from_the_state() -> None:
    s = two_player_state()
    s.ball_pos[0] = [20.9, 5.0]  # within 1.085 of player 0
    assert np.array_equal(
        render_frame(s, DEFAULT_PARAMS), render_frame(s, DEFAULT_PARAMS, kickable_players=[True, False])
    )


def test_bad_arguments_raise() -> None:
    s = two_player_state()
    with pytest.raises(ValueError, match="messages"):
        render_frame(s, messages=np.zeros((3, 4)))
    with pytest.raises(ValueError, match="labels"):
        render_frame(s, labels=["only one"])
    with pytest.raises(IndexError):
        render_frame(s, game=2)
    with pytest.raises(ValueError, match="too small"):
        render_frame(s, width=50, height=40)


def test_world_to_pixel_keeps_the_field_left_of_the_panel() -> None:
    corners = world_to_pixel([[0.0, -34.0], [52.5, 34.0]])
    (c0, r0), (c1, r1) = corners
    assert 0 < c0 < c1 < 640 * 0.7
    assert 0 <= r0 < r1 < 420
    assert (r1 - r0) / (c1 - c0) == pytest.approx(68 / 52.5)


def frames(n: int = 3) -> list[np.ndarray]:
    s = two_player_state()
    out = []
    for k in range(n):
        s.ball_pos[0] = [30.0 + 2 * k, 15.0]
        s.cycle[0] = k
        out.append(render_frame(s, DEFAULT_PARAMS, width=320, height=210))
    return out


def test_save_gif(tmp_path) -> None:
    written = save_video(frames(3), tmp_path / "sub" / "episode.gif", fps=5)
    assert written == tmp_path / "sub" / "episode.gif"
    with Image.open(written) as gif:
        assert gif.n_frames == 3
        assert gif.size == (320, 210)
        assert gif.info["duration"] == 200


def test_save_mp4(tmp_path) -> None:
    pytest.importorskip("imageio_ffmpeg")
    written = save_video(frames(4), tmp_path / "episode.mp4", fps=10)
    assert written.stat().st_size > 0
    import imageio.v2 as iio

    with iio.get_reader(written) as reader:
        assert sum(1 for _ in reader) == 4


def test_mp4_without_ffmpeg_names_the_package(tmp_path, monkeypatch) -> None:
    monkeypatch.setitem(sys.modules, "imageio_ffmpeg", None)  # makes the import fail
    with pytest.raises(ImportError, match=r"imageio-ffmpeg.*\.gif"):
        save_video(frames(1), tmp_path / "x.mp4")


def test_bad_suffix_and_frames_raise(tmp_path) -> None:
    with pytest.raises(ValueError, match=r"\.gif, \.mp4"):
        save_video(frames(1), tmp_path / "x.avi")
    with pytest.raises(ValueError, match="no frames"):
        save_video([], tmp_path / "x.gif")
    with pytest.raises(ValueError, match="uint8"):
        save_video([np.zeros((10, 10, 3), dtype=np.float32)], tmp_path / "x.gif")
    with pytest.raises(ValueError, match="one shape"):
        save_video([np.zeros((10, 10, 3), np.uint8), np.zeros((12, 10, 3), np.uint8)], tmp_path / "x.gif")
