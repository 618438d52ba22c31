"""Pictures and videos of half-field soccer games, drawn with Pillow.

:func:`render_frame` draws one game of a batched :class:`~envs.soccer.state.SoccerState`: the
HFO half field (attacking half, goal on the right, y pointing down as in rcssserver), every
player as a disc with a heading line in its own colour, the ball, the cycle number, and a side
panel with each player's label and, when given, the message it currently has in flight as a
signed bar chart. :func:`save_video` writes a list of frames as a GIF (Pillow only) or an MP4
(imageio with its ffmpeg plugin).

Frames are drawn at twice the requested size and downsampled, which antialiases lines and
discs without any drawing library beyond Pillow.
"""

from __future__ import annotations

import functools
import math
import os
import pathlib
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from envs.soccer.params import DEFAULT_PARAMS, ServerParams
from envs.soccer.state import SoccerState

__all__ = ["PLAYER_COLOURS", "VIDEO_SUFFIXES", "render_frame", "save_video", "world_to_pixel"]

_RGB = tuple[int, int, int]

PLAYER_COLOURS: tuple[_RGB, ...] = (
    (214, 39, 40),  # red
    (31, 119, 220),  # blue
    (255, 190, 11),  # yellow
    (148, 103, 189),  # purple
    (255, 127, 14),  # orange
    (23, 190, 207),  # cyan
    (227, 119, 194),  # pink
    (140, 86, 75),  # brown
)
"""Colour of player ``i`` is ``PLAYER_COLOURS[i % len(PLAYER_COLOURS)]``."""

VIDEO_SUFFIXES = (".gif", ".mp4")
"""File types :func:`save_video` writes."""

_SUPERSAMPLE = 2
_GRASS = ((62, 142, 65), (70, 154, 73))  # alternating mowing stripes
_SURROUND = (46, 112, 50)
_LINE = (242, 242, 242)
_NET = (214, 214, 214)
_PANEL = (32, 34, 38)
_PANEL_TEXT = (225, 225, 225)
_PANEL_DIM = (120, 124, 130)
_BALL = (255, 255, 255)
_OUTLINE = (20, 20, 20)

# Field drawing constants (metres) that the simulator does not need.
_MARGIN = 3.0
_GOAL_DEPTH = 2.44
_GOAL_AREA_LENGTH = 5.5
_GOAL_AREA_WIDTH = 18.32
_CENTRE_CIRCLE_RADIUS = 9.15
_PENALTY_SPOT_DISTANCE = 11.0
_STRIPE = 5.25


@dataclass(frozen=True)
class _Layout:
    """Where the field and the panel go in a frame of the requested size (final pixels)."""

    width: int
    height: int
    scale: float
    """Pixels per metre."""
    x_min: float
    """World x at the frame's left edge."""
    y_min: float
    """World y at the field area's top edge."""
    top: float
    """Pixel row of ``y_min`` (the field is centred vertically)."""
    panel_x: int
    """First pixel column of the panel."""


@functools.lru_cache(maxsize=16)
def _layout(width: int, height: int, params: ServerParams) -> _Layout:
    if width < 160 or height < 100:
        raise ValueError(f"frame too small: {width}x{height} (need at least 160x100)")
    x_min = -_MARGIN
    world_w = params.half_length + _GOAL_DEPTH + _MARGIN - x_min
    world_h = params.pitch_width + 2 * _MARGIN
    min_panel = max(120, width // 5)
    scale = min((width - min_panel) / world_w, height / world_h)
    panel_x = math.ceil(world_w * scale)
    return _Layout(
        width=width,
        height=height,
        scale=scale,
        x_min=x_min,
        y_min=-params.half_width - _MARGIN,
        top=(height - world_h * scale) / 2,
        panel_x=panel_x,
    )


def world_to_pixel(
    points: np.ndarray | Sequence[float],
    width: int = 640,
    height: int = 420,
    params: ServerParams = DEFAULT_PARAMS,
) -> np.ndarray:
    """Pixel coordinates (column, row) of world points (x, y) in a frame of :func:`render_frame`.

    :param points: array (..., 2) of positions in metres.
    :param width: frame width in pixels.
    :param height: frame height in pixels.
    :param params: field geometry.
    :return: float array (..., 2) of (column, row); round it to index the frame.
    """
    lay = _layout(width, height, params)
    pts = np.asarray(points, dtype=float)
    col = (pts[..., 0] - lay.x_min) * lay.scale
    row = lay.top + (pts[..., 1] - lay.y_min) * lay.scale
    return np.stack([col, row], axis=-1)


class _Canvas:
    """Draws in world coordinates on the supersampled image."""

    def __init__(self, image: Image.Image, lay: _Layout) -> None:
        self.image = image
        self.draw = ImageDraw.Draw(image)
        self.lay = lay
        self.k = lay.scale * _SUPERSAMPLE

    def xy(self, x: float, y: float) -> tuple[float, float]:
        lay = self.lay
        return ((x - lay.x_min) * self.k, (lay.top + (y - lay.y_min) * lay.scale) * _SUPERSAMPLE)

    def box(self, x0: float, y0: float, x1: float, y1: float) -> list[float]:
        return [*self.xy(x0, y0), *self.xy(x1, y1)]

    def disc(
        self,
        x: float,
        y: float,
        radius_px: float,
        fill: _RGB | None,
        outline: _RGB | None = None,
        width: float = 1.0,
    ) -> None:
        """A disc of ``radius_px`` final pixels centred on world (x, y)."""
        cx, cy = self.xy(x, y)
        r = radius_px * _SUPERSAMPLE
        self.draw.ellipse(
            [cx - r, cy - r, cx + r, cy + r], fill=fill, outline=outline, width=round(width * _SUPERSAMPLE)
        )


@functools.lru_cache(maxsize=8)
def _font(size_px: int) -> ImageFont.FreeTypeFont | ImageFont.ImageFont:
    return ImageFont.load_default(size=size_px * _SUPERSAMPLE)


@functools.lru_cache(maxsize=8)
def _background(width: int, height: int, params: ServerParams) -> Image.Image:
    """The empty field and panel, supersampled; copied for every frame."""
    lay = _layout(width, height, params)
    image = Image.new("RGB", (width * _SUPERSAMPLE, height * _SUPERSAMPLE), _SURROUND)
    c = _Canvas(image, lay)
    d = c.draw
    hl, hw = params.half_length, params.half_width
    line = max(1, round(0.12 * c.k))

    # Grass stripes over the playing area.
    n_stripes = math.ceil(hl / _STRIPE)
    for i in range(n_stripes):
        x0, x1 = i * _STRIPE, min((i + 1) * _STRIPE, hl)
        d.rectangle(c.box(x0, -hw, x1, hw), fill=_GRASS[i % 2])

    # Touch lines, halfway line (the left edge of the HFO area), goal line.
    d.rectangle(c.box(0, -hw, hl, hw), outline=_LINE, width=line)
    # Centre circle (its attacking half) and spot.
    r = _CENTRE_CIRCLE_RADIUS
    d.arc(c.box(-r, -r, r, r), start=-90, end=90, fill=_LINE, width=line)
    c.disc(0, 0, max(1.5, 0.25 * lay.scale), fill=_LINE)
    # Penalty area, goal area, penalty spot and arc.
    box_x = hl - params.penalty_area_length
    d.rectangle(
        c.box(box_x, -params.penalty_area_width / 2, hl, params.penalty_area_width / 2),
        outline=_LINE,
        width=line,
    )
    d.rectangle(
        c.box(hl - _GOAL_AREA_LENGTH, -_GOAL_AREA_WIDTH / 2, hl, _GOAL_AREA_WIDTH / 2),
        outline=_LINE,
        width=line,
    )
    spot = hl - _PENALTY_SPOT_DISTANCE
    c.disc(spot, 0, max(1.5, 0.25 * lay.scale), fill=_LINE)
    half_angle = math.degrees(math.acos((spot - box_x) / r))
    d.arc(
        c.box(spot - r, -r, spot + r, r), start=180 - half_angle, end=180 + half_angle, fill=_LINE, width=line
    )
    # Goal: net behind the line, posts on it.
    gy = params.goal_width / 2
    d.rectangle(c.box(hl, -gy, hl + _GOAL_DEPTH, gy), fill=_NET, outline=_LINE, width=line)
    for i in range(1, 6):
        y = -gy + i * params.goal_width / 6
        d.line([*c.xy(hl, y), *c.xy(hl + _GOAL_DEPTH, y)], fill=(185, 185, 185), width=max(1, line // 2))
    for y in (-gy, gy):
        c.disc(hl, y, max(2.0, 0.35 * lay.scale), fill=_LINE, outline=_OUTLINE)

    # Side panel.
    d.rectangle([lay.panel_x * _SUPERSAMPLE, 0, width * _SUPERSAMPLE, height * _SUPERSAMPLE], fill=_PANEL)
    return image


def _check_messages(messages: np.ndarray | None, n_players: int) -> np.ndarray | None:
    if messages is None:
        return None
    msg = np.asarray(messages, dtype=float)
    if msg.ndim == 1 and n_players == 1:
        msg = msg[None]
    if msg.ndim != 2 or msg.shape[0] != n_players:
        raise ValueError(f"messages must have shape (n_players={n_players}, channel), got {msg.shape}")
    return np.clip(np.nan_to_num(msg), -1.0, 1.0)


def render_frame(
    state: SoccerState,
    params: ServerParams = DEFAULT_PARAMS,
    game: int = 0,
    messages: np.ndarray | None = None,
    width: int = 640,
    height: int = 420,
    labels: Sequence[str] | None = None,
    kickable_players: np.ndarray | Sequence[bool] | None = None,
) -> np.ndarray:
    """Draw one game of a batched state as an RGB image.

    The field shows HFO's attacking half (x from 0 to 52.5, goal on the right; y points down
    as in rcssserver). Player ``i`` is a disc of colour ``PLAYER_COLOURS[i]`` with a dark
    heading line along its body angle and a thin ring of its kickable area, drawn thick and
    yellow when it can kick. The side panel shows the cycle number and, for each player, its
    label and the message it has in flight as a bar chart (bars up for positive values, down for
    negative, full height at ±1).

    :param state: the batched games.
    :param params: field geometry (and the kickable area).
    :param game: which game of the batch to draw.
    :param messages: optional (P, n) array in [-1, 1], the message each player currently has
        in flight (values outside are clipped, NaN drawn as 0).
    :param width: frame width in pixels.
    :param height: frame height in pixels.
    :param labels: optional text per player (e.g. ``"sighted"``, ``"blind"``), shown by the
        player and in the panel.
    :param kickable_players: optional (P,) booleans, which players to mark as able to kick;
        by default computed from the state (ball within ``params.client_kickable_area``, the
        distance at which an HFO agent can kick).
    :return: uint8 array of shape (height, width, 3).
    """
    n_games, n_players = state.n_games, state.n_players
    if not -n_games <= game < n_games:
        raise IndexError(f"game {game} out of range for a batch of {n_games}")
    if labels is not None and len(labels) != n_players:
        raise ValueError(f"labels has {len(labels)} entries for {n_players} players")
    msg = _check_messages(messages, n_players)
    pos = np.asarray(state.pos[game], dtype=float)
    body = np.radians(np.asarray(state.body[game], dtype=float))
    ball = np.asarray(state.ball_pos[game], dtype=float)
    if kickable_players is None:
        kick = np.hypot(*(pos - ball).T) <= params.client_kickable_area
    else:
        kick = np.asarray(kickable_players, dtype=bool).reshape(n_players)

    lay = _layout(width, height, params)
    image = _background(width, height, params).copy()
    c = _Canvas(image, lay)
    d = c.draw
    font = _font(max(9, round(height / 36)))
    small = _font(max(8, round(height / 46)))
    names = [str(i) if labels is None else str(labels[i]) for i in range(n_players)]

    # Players: kickable ring, body disc, heading line, label.
    radius = max(5.5, params.player_size * lay.scale)
    ring = params.client_kickable_area * lay.scale
    for i in range(n_players):
        colour = PLAYER_COLOURS[i % len(PLAYER_COLOURS)]
        x, y = pos[i]
        if kick[i]:
            c.disc(x, y, max(ring, radius + 2.5), fill=None, outline=(255, 230, 0), width=2.0)
        else:
            c.disc(x, y, max(ring, radius + 1.5), fill=None, outline=_lighter(colour), width=1.0)
        c.disc(x, y, radius, fill=colour, outline=_OUTLINE, width=1.0)
        head = 2.3 * radius / lay.scale
        d.line(
            [*c.xy(x, y), *c.xy(x + head * math.cos(body[i]), y + head * math.sin(body[i]))],
            fill=_OUTLINE,
            width=round(2 * _SUPERSAMPLE),
        )
        tx, ty = c.xy(x, y)
        d.text(
            (tx, ty - (radius + 3) * _SUPERSAMPLE),
            names[i],
            font=small,
            fill=(255, 255, 255),
            anchor="md",
            stroke_width=_SUPERSAMPLE,
            stroke_fill=_OUTLINE,
        )

    # Ball, on top.
    c.disc(ball[0], ball[1], max(3.5, params.ball_size * lay.scale), fill=_BALL, outline=_OUTLINE, width=1.0)

    _draw_panel(d, lay, font, small, int(state.cycle[game]), names, kick, msg)
    image = image.reduce(_SUPERSAMPLE)
    return np.array(image, dtype=np.uint8)


def _lighter(colour: _RGB, amount: float = 0.45) -> _RGB:
    r, g, b = (round(v + (255 - v) * amount) for v in colour)
    return (r, g, b)


def _draw_panel(
    d: ImageDraw.ImageDraw,
    lay: _Layout,
    font: ImageFont.FreeTypeFont | ImageFont.ImageFont,
    small: ImageFont.FreeTypeFont | ImageFont.ImageFont,
    cycle: int,
    names: list[str],
    kick: np.ndarray,
    msg: np.ndarray | None,
) -> None:
    """Cycle number, then one block per player: colour, label, kickable mark, message bars."""
    s = _SUPERSAMPLE
    x0 = (lay.panel_x + 10) * s
    x1 = (lay.width - 10) * s
    line_h = font.size * 1.35 if isinstance(font, ImageFont.FreeTypeFont) else 14 * s
    y = 10 * s
    d.text((x0, y), f"cycle {cycle}", font=font, fill=_PANEL_TEXT)
    y += line_h
    d.text((x0, y), "messages in flight" if msg is not None else "no messages", font=small, fill=_PANEL_DIM)
    y += line_h
    n_players = len(names)
    block = (lay.height * s - y - 6 * s) / max(n_players, 1)
    for i, name in enumerate(names):
        colour = PLAYER_COLOURS[i % len(PLAYER_COLOURS)]
        top = y + i * block
        r = 5 * s
        d.ellipse([x0, top + line_h / 2 - r, x0 + 2 * r, top + line_h / 2 + r], fill=colour, outline=_OUTLINE)
        d.text((x0 + 3 * r, top), name, font=font, fill=_PANEL_TEXT)
        if kick[i]:
            d.text((x1, top), "kickable", font=small, fill=(255, 230, 0), anchor="ra")
        if msg is None:
            continue
        chart_top = top + line_h + 2 * s
        values_h = small.size * 1.3 if isinstance(small, ImageFont.FreeTypeFont) else 12 * s
        chart_h = min(block - line_h - values_h - 8 * s, 90 * s)
        if chart_h < 8 * s:
            continue
        _draw_bars(d, msg[i], colour, x0, chart_top, x1, chart_top + chart_h, small)


def _draw_bars(
    d: ImageDraw.ImageDraw,
    values: np.ndarray,
    colour: _RGB,
    x0: float,
    y0: float,
    x1: float,
    y1: float,
    font: ImageFont.FreeTypeFont | ImageFont.ImageFont,
) -> None:
    """A signed bar chart of ``values`` in [-1, 1] inside the box (x0, y0)-(x1, y1)."""
    s = _SUPERSAMPLE
    d.rectangle([x0, y0, x1, y1], outline=(70, 74, 80), width=s)
    mid = (y0 + y1) / 2
    half = (y1 - y0) / 2 - 2 * s
    n = len(values)
    slot = (x1 - x0) / max(n, 1)
    gap = min(4 * s, slot * 0.2)
    for k, v in enumerate(values):
        bx0 = x0 + k * slot + gap
        bx1 = x0 + (k + 1) * slot - gap
        top, bottom = sorted((mid, mid - float(v) * half))
        if bottom - top >= 1:
            d.rectangle([bx0, top, bx1, bottom], fill=colour)
        if slot >= 34 * s:  # values under the chart when they fit
            d.text(((bx0 + bx1) / 2, y1 + 2 * s), f"{v:+.2f}", font=font, fill=_PANEL_DIM, anchor="ma")
    d.line([x0, mid, x1, mid], fill=(160, 164, 170), width=s)


def save_video(frames: Iterable[np.ndarray], path: str | pathlib.Path, fps: float = 10) -> pathlib.Path:
    """Write frames (uint8 arrays (H, W, 3), all the same size) as a video.

    ``.gif`` needs only Pillow; ``.mp4`` needs imageio and its ffmpeg plugin
    (``pip install imageio imageio-ffmpeg``). Parent folders are created.

    :param frames: the frames, e.g. from :func:`render_frame`.
    :param path: output file; its suffix picks the format (one of :data:`VIDEO_SUFFIXES`).
    :param fps: frames per second.
    :return: the path written.
    :raises ValueError: for an unknown suffix, no frames, or frames of different shapes.
    :raises ImportError: for ``.mp4`` without imageio or imageio-ffmpeg.
    """
    path = pathlib.Path(path)
    suffix = path.suffix.lower()
    if suffix not in VIDEO_SUFFIXES:
        raise ValueError(
            f"cannot write {suffix or 'a file without suffix'!r}: use one of {', '.join(VIDEO_SUFFIXES)}"
        )
    if fps <= 0:
        raise ValueError(f"fps must be positive, got {fps}")
    frames = [np.asarray(f) for f in frames]
    if not frames:
        raise ValueError("no frames to write")
    shape = frames[0].shape
    for f in frames:
        if f.shape != shape or f.dtype != np.uint8 or f.ndim != 3 or f.shape[2] != 3:
            raise ValueError(f"frames must be uint8 arrays of one shape (H, W, 3); got {f.dtype} {f.shape}")
    if suffix == ".mp4":
        try:
            import imageio.v2 as iio
            import imageio_ffmpeg  # noqa: F401  (imageio's ffmpeg backend)
        except ImportError as err:
            raise ImportError(
                "writing .mp4 needs imageio and imageio-ffmpeg (pip install imageio imageio-ffmpeg); "
                "or save as .gif, which needs only Pillow"
            ) from err
    path.parent.mkdir(parents=True, exist_ok=True)
    # Written to a temporary file in the same folder, then renamed: never a truncated video.
    tmp = path.with_name(f".{path.stem}.{os.getpid()}.tmp{path.suffix}")
    try:
        if suffix == ".mp4":
            # macro_block_size=2: libx264 needs even sizes; larger blocks would rescale the frames.
            iio.mimwrite(tmp, frames, format="FFMPEG", fps=fps, codec="libx264", macro_block_size=2)
        else:
            images = [Image.fromarray(f) for f in frames]
            images[0].save(
                tmp,
                format="GIF",
                save_all=True,
                append_images=images[1:],
                duration=max(1, round(1000 / fps)),
                loop=0,
                optimize=False,
            )
        os.replace(tmp, path)
    except OSError as error:
        if error.errno is None:
            raise
        raise OSError(error.errno, error.strerror, str(path)) from error  # the file the user asked for
    finally:
        tmp.unlink(missing_ok=True)
    return path
