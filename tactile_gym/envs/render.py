"""The env's frame: the simulator's picture with what the probe sensed and estimated on top.

``draw_frame`` takes the picture from ``ProbeScene.render`` (a camera framing the probed
region, ``tactile_gym.sim.camera``) and draws, by projecting world points with the camera's
own matrices: the observed (noisy) force on the fingertip as an arrow, labelled on white; the
accepted measurements (contact point and edge), those taken at an earlier link angle faded
(their edge direction differs from the last one's: the link has turned since, so they float
beside it); the current estimated axis and, only with ``render_truth=True``, the true axis;
and a key (``docs/design.md`` 7.10). Rendering reads the env's observable state; it changes
nothing and feeds nothing.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from tactile_gym.perception import DISTINCT_ANGLE
from tactile_gym.sim.camera import Camera
from tactile_gym.validation import check_bool, check_int

__all__ = ["COLOURS", "FORCE_SCALE", "Overlay", "RenderOptions", "draw_frame", "draw_overlay"]

#: Arrow length per newton of force, m/N (8 N, the default force limit, is 80 mm).
FORCE_SCALE = 0.01
#: Half-length of a measured edge's segment, m.
EDGE_HALF_LENGTH = 0.012
#: RGB colour of each mark.
COLOURS = {
    "force": (255, 150, 0),
    "measurement": (40, 210, 60),
    "earlier": (170, 225, 175),
    "estimate": (220, 0, 220),
    "truth": (40, 110, 255),
}


@dataclass(frozen=True)
class RenderOptions:
    """The env's render keywords (``gym.make(..., render_width=...)``).

    Attributes:
        render_width, render_height: frame size, pixels.
        render_truth: also draw the true axis. Ground truth, for videos only: it is never an
            input to a policy, the sensing or the estimator.
    """

    render_width: int = 640
    render_height: int = 480
    render_truth: bool = False

    def __post_init__(self) -> None:
        check_int("render_width", self.render_width, 16, 4096)
        check_int("render_height", self.render_height, 16, 4096)
        check_bool("render_truth", self.render_truth)


@dataclass(frozen=True, eq=False)
class Overlay:
    """What a frame shows on top of the picture, world frame, m.

    Attributes:
        step: control steps this episode.
        force: (3,) observed force on the fingertip, N.
        force_origin: (3,) where its arrow starts (the sensed contact point, or the centre of
            the fingertip's hemisphere when nothing is touched).
        points, edges: (N, 3) accepted measurements' contact points and edge directions.
        axis: the estimated axis (point, unit direction).
        true_axis: the true axis (point, unit direction), or None to leave it out.
        caption: more for the key's first row (the primitive ids: the primitive running).
    """

    step: int
    force: np.ndarray
    force_origin: np.ndarray
    points: np.ndarray
    edges: np.ndarray
    axis: tuple[np.ndarray, np.ndarray]
    true_axis: tuple[np.ndarray, np.ndarray] | None = None
    caption: str = ""

    @property
    def current(self) -> np.ndarray:
        """(N,) which measurements were taken at the last one's link angle: their edges lie
        within ``DISTINCT_ANGLE`` of its edge (the others were taken before the link turned)."""
        if not len(self.edges):
            return np.zeros(0, bool)
        return self.edges @ self.edges[-1] >= np.cos(DISTINCT_ANGLE)


def draw_frame(scene, pipeline, step: int, options: RenderOptions, true_axis=None, caption=""):
    """A frame of a scene (``ProbeScene``) and what its measurement pipeline
    (``tactile_gym.perception.MeasurementPipeline``) sensed and estimated, after ``step``
    control steps; ``true_axis`` (point, direction) only for ``render_truth``."""
    image, camera = scene.render(options.render_width, options.render_height)
    touch = pipeline.touch
    measurements = pipeline.measurements
    overlay = Overlay(
        step=step,
        force=scene.sensor_to_world_vector(pipeline.wrench[:3]),
        force_origin=touch.point
        if touch.valid
        else scene.sensor_to_world_point(scene.geometry.sphere_center),
        points=np.array([m.point for m in measurements]).reshape(-1, 3),
        edges=np.array([m.edge for m in measurements]).reshape(-1, 3),
        axis=(pipeline.estimate.point, pipeline.estimate.direction),
        true_axis=true_axis,
        caption=caption,
    )
    return draw_overlay(image, camera, overlay)


def _axis_segment(axis: tuple[np.ndarray, np.ndarray], camera: Camera) -> np.ndarray:
    """The stretch of an axis line through the framed region: centred at its point nearest
    the camera's target, as long as the framed box's diagonal."""
    point, direction = (np.asarray(v, dtype=float) for v in axis)
    u = direction / np.linalg.norm(direction)
    centre = point + u * float((camera.target - point) @ u)
    return np.array([centre - camera.radius * u, centre + camera.radius * u])


def _project(camera: Camera, points) -> tuple[np.ndarray, np.ndarray]:
    """``camera.project`` in Pillow's pixel coordinates (pixel centres at integers)."""
    pixels, in_front = camera.project(points)
    return pixels - 0.5, in_front


def _pixel(camera: Camera, point) -> tuple[float, float] | None:
    """The pixel of a world point, or None when it is behind the camera."""
    pixels, in_front = _project(camera, point)
    return (float(pixels[0, 0]), float(pixels[0, 1])) if in_front[0] else None


def _line(draw: ImageDraw.ImageDraw, camera: Camera, ends, colour, width: int) -> None:
    pixels, in_front = _project(camera, ends)
    if in_front.all():
        draw.line([tuple(p) for p in pixels], fill=colour, width=width)


def _arrow(draw: ImageDraw.ImageDraw, camera: Camera, start, end, colour, width: int) -> None:
    pixels, in_front = _project(camera, [start, end])
    if not in_front.all():
        return
    a, b = pixels
    draw.line([tuple(a), tuple(b)], fill=colour, width=width)
    d = b - a
    length = float(np.linalg.norm(d))
    if length < 1.0:
        return
    d /= length
    n = np.array([-d[1], d[0]])
    head = min(4.0 * width + 4.0, 0.5 * length)
    draw.polygon(
        [tuple(b), tuple(b - head * d + 0.5 * head * n), tuple(b - head * d - 0.5 * head * n)],
        fill=colour,
    )


def _legend(draw: ImageDraw.ImageDraw, overlay: Overlay, font, size: int) -> None:
    """The colour key and the counts, on white in the top-left corner."""
    magnitude = float(np.linalg.norm(overlay.force))
    first = f"control step {overlay.step}" + (f", {overlay.caption}" if overlay.caption else "")
    current = int(overlay.current.sum())
    rows = [
        (None, first),
        ("force", f"force on fingertip, |f| = {magnitude:.2f} N ({FORCE_SCALE * 1e3:.0f} mm/N)"),
        ("measurement", f"measurements at the link's last angle: point + edge ({current})"),
    ]
    if current < len(overlay.points):
        older = len(overlay.points) - current
        rows.append(("earlier", f"measured before the link turned ({older})"))
    rows.append(("estimate", "estimated axis"))
    if overlay.true_axis is not None:
        rows.append(("truth", "true axis (ground truth)"))
    pad, swatch, row = size // 2, 2 * size, round(1.3 * size)
    text_x = 2 * pad + swatch
    width = text_x + max(draw.textlength(text, font=font) for _, text in rows) + pad
    draw.rectangle([0, 0, width, 2 * pad + row * len(rows)], fill=(255, 255, 255))
    for i, (key, text) in enumerate(rows):
        y = pad + i * row + row // 2
        if key is not None:
            draw.line([(pad, y), (pad + swatch, y)], fill=COLOURS[key], width=max(2, size // 4))
        draw.text((text_x, y), text, fill=(0, 0, 0), font=font, anchor="lm")


def draw_overlay(image: np.ndarray, camera: Camera, overlay: Overlay) -> np.ndarray:
    """The image with the overlay drawn on it (a new array; the input is left as it was).

    Args:
        image: (height, width, 3) uint8 RGB, taken with ``camera``.
        camera: the camera the image was taken with.
        overlay: what to draw.
    """
    picture = Image.fromarray(image)
    draw = ImageDraw.Draw(picture)
    # Marks and text grow with the frame: 2 px lines and 13 px text at 480 rows.
    size = max(8, round(13 * camera.height / 480))
    font = ImageFont.load_default(size=size)
    width = max(2, size // 6)
    # The earlier link angles' first, so that the last angle's are drawn over them.
    order = np.argsort(overlay.current, kind="stable")
    for point, edge, current in zip(
        overlay.points[order], overlay.edges[order], overlay.current[order]
    ):
        colour = COLOURS["measurement" if current else "earlier"]
        if np.all(np.isfinite(edge)) and np.linalg.norm(edge) > 0.5:
            ends = [point - EDGE_HALF_LENGTH * edge, point + EDGE_HALF_LENGTH * edge]
            _line(draw, camera, ends, colour, width)
        pixel = _pixel(camera, point)
        if pixel is not None:
            x, y, r = *pixel, 1.5 * width
            draw.ellipse([x - r, y - r, x + r, y + r], fill=colour)
    if overlay.true_axis is not None:
        _line(draw, camera, _axis_segment(overlay.true_axis, camera), COLOURS["truth"], width)
    point, direction = overlay.axis
    if np.all(np.isfinite(np.r_[point, direction])) and np.linalg.norm(direction) > 0:
        _line(draw, camera, _axis_segment(overlay.axis, camera), COLOURS["estimate"], width)
    start = np.asarray(overlay.force_origin, dtype=float)
    end = start + FORCE_SCALE * np.asarray(overlay.force, dtype=float)
    _arrow(draw, camera, start, end, COLOURS["force"], width + 1)
    pixel = _pixel(camera, end)
    if pixel is not None:
        # Dark text on a white box beside the arrow's tip: legible on the grey fingertip.
        xy = (pixel[0] + size // 2, pixel[1])
        label = f"{float(np.linalg.norm(overlay.force)):.1f} N"
        box = draw.textbbox(xy, label, font=font, anchor="lm")
        pad = max(1, size // 5)
        draw.rectangle(
            [box[0] - pad, box[1] - pad, box[2] + pad, box[3] + pad],
            fill=(255, 255, 255),
            outline=COLOURS["force"],
        )
        draw.text(xy, label, fill=(0, 0, 0), font=font, anchor="lm")
    _legend(draw, overlay, font, size)
    return np.asarray(picture, dtype=np.uint8).copy()
