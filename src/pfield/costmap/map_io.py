"""ROS map_server maps: YAML + PGM/PNG loading and saving as nav2's ``map_io`` does, OccupancyGrid conversion.

YAML keys (nav2 ``loadMapYaml``): ``image`` (relative to the YAML file's folder), ``resolution`` (m/cell),
``origin`` ``[x, y, yaw]`` (pose of the lower-left pixel's corner), ``negate`` (0/1), ``occupied_thresh``,
``free_thresh`` and optional ``mode`` (``trinary`` default, ``scale``, ``raw``).

Pixel rule (nav2 ``loadMapFromFile``): ``shade`` = mean of the R, G, B channels on [0, 1] (in trinary mode
an alpha channel's opacity is averaged in too); ``occ = shade`` if negate else ``1 − shade``.

* trinary: ``occ > occupied_thresh`` → 100, ``occ < free_thresh`` → 0, else −1 (unknown);
* scale: not fully opaque → −1; then as trinary, except in-between values become
  ``rint((occ − free_thresh) / (occupied_thresh − free_thresh) · 100)``;
* raw: ``round(shade · 255)`` when in [0, 100], else −1 (negate is ignored).

Image row 0 is the **top** of the map; grid row 0 is the **bottom**: ``data[height − 1 − y, x] = pixel(x, y)``.
Saving (nav2 ``saveMapToFile``): trinary writes 254 (free, ``value ≤ rint(100·free_thresh)``), 0
(occupied, ``value ≥ rint(100·occupied_thresh)``), 205 (anything else); scale writes grey
``(100 − value)/100`` with unknown cells transparent (PNG only); raw writes the value itself, unknown as 255.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from numpy.typing import NDArray
from PIL import Image, UnidentifiedImageError

from pfield._validation import nearest_name
from pfield.errors import InvalidInput, ResourceNotFound

__all__ = [
    "MAP_MODES",
    "MapMetadata",
    "OccupancyMap",
    "load_map",
    "load_map_yaml",
    "occupancy_from_image",
    "save_map",
]

logger = logging.getLogger(__name__)

MAP_MODES = ("trinary", "scale", "raw")
_GM_MAX = 65535.0  # GraphicsMagick Q16 quantum range, used by ROS map_server


@dataclass(frozen=True)
class MapMetadata:
    """The YAML half of a map_server map. ``image`` is resolved against the YAML file's folder."""

    image: Path
    resolution: float
    origin: tuple[float, float, float]
    negate: bool
    occupied_thresh: float
    free_thresh: float
    mode: str = "trinary"

    def __post_init__(self) -> None:
        if not (math.isfinite(self.resolution) and self.resolution > 0.0):
            raise InvalidInput("resolution", self.resolution, "must be > 0 (metres per cell)")
        if len(self.origin) != 3 or not all(math.isfinite(v) for v in self.origin):
            raise InvalidInput("origin", self.origin, "expected three finite numbers [x, y, yaw]")
        for name in ("occupied_thresh", "free_thresh"):
            value = getattr(self, name)
            if not (math.isfinite(value) and 0.0 <= value <= 1.0):
                raise InvalidInput(name, value, "must be within [0, 1]")
        if self.free_thresh >= self.occupied_thresh:
            raise InvalidInput("free_thresh", self.free_thresh,
                               f"must be smaller than occupied_thresh ({self.occupied_thresh})")
        if self.mode not in MAP_MODES:
            raise InvalidInput("mode", self.mode, f"must be one of {', '.join(MAP_MODES)}")


@dataclass(frozen=True, eq=False)
class OccupancyMap:
    """An occupancy grid: ``data[row, col]`` int8 in [−1, 100] (−1 unknown), row 0 at the bottom.

    Cell ``(col, row)`` covers ``[x0 + col·r, x0 + (col+1)·r) × [y0 + row·r, y0 + (row+1)·r)`` in
    ``frame_id`` with ``(x0, y0, yaw) = origin`` and ``r = resolution`` (m) — nav_msgs/OccupancyGrid.
    """

    data: NDArray[np.int8]
    resolution: float
    origin: tuple[float, float, float] = (0.0, 0.0, 0.0)
    frame_id: str = "map"

    def __post_init__(self) -> None:
        data = np.array(self.data, dtype=np.int8)
        if data.ndim != 2 or data.size == 0:
            raise InvalidInput("data", f"array{data.shape}", "expected a non-empty (height, width) grid")
        data.setflags(write=False)
        object.__setattr__(self, "data", data)
        if not (math.isfinite(self.resolution) and self.resolution > 0.0):
            raise InvalidInput("resolution", self.resolution, "must be > 0 (metres per cell)")
        origin = tuple(float(v) for v in self.origin)
        if len(origin) != 3 or not all(math.isfinite(v) for v in origin):
            raise InvalidInput("origin", self.origin, "expected three finite numbers [x, y, yaw]")
        object.__setattr__(self, "origin", origin)

    @property
    def width(self) -> int:
        return int(self.data.shape[1])

    @property
    def height(self) -> int:
        return int(self.data.shape[0])

    @classmethod
    def from_message(cls, message: Any) -> OccupancyMap:
        """From a nav_msgs/OccupancyGrid (any object with ``header``, ``info`` and ``data`` fields)."""
        info = message.info
        width, height = int(info.width), int(info.height)
        data = np.asarray(list(message.data), dtype=np.int16)
        if data.size != width * height or width <= 0 or height <= 0:
            raise InvalidInput("data", f"{data.size} values", f"expected width·height = {width}·{height} values")
        if np.any((data < -1) | (data > 100)):
            raise InvalidInput("data", "values", "occupancy values must be in [-1, 100]")
        q = info.origin.orientation
        yaw = math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))
        origin = (float(info.origin.position.x), float(info.origin.position.y), yaw)
        return cls(data.reshape(height, width).astype(np.int8), float(info.resolution), origin,
                   str(message.header.frame_id) or "map")

    def to_message_fields(self) -> dict[str, Any]:
        """The nav_msgs/OccupancyGrid fields as plain data (validate it with the interface model)."""
        x, y, yaw = self.origin
        return {
            "header": {"frame_id": self.frame_id},
            "info": {
                "resolution": self.resolution, "width": self.width, "height": self.height,
                "origin": {"position": {"x": x, "y": y, "z": 0.0},
                           "orientation": {"x": 0.0, "y": 0.0, "z": math.sin(0.5 * yaw), "w": math.cos(0.5 * yaw)}},
            },
            "data": self.data.reshape(-1).tolist(),
        }


_MAP_KEYS = ("image", "resolution", "origin", "negate", "occupied_thresh", "free_thresh", "mode")
"""The keys of a map_server YAML that pfield reads (others are ignored, as map_server does)."""


def _missing(doc: dict[str, Any], key: str, path: Path) -> InvalidInput:
    """The error for ``key`` missing from the map YAML, naming a key of it that looks like its misspelling."""
    others = [str(k) for k in doc if str(k) not in _MAP_KEYS]
    near = next((k for k in others if nearest_name(k, [key]) is not None), None)
    hint = f" (it has {near!r}: did you mean {key!r}?)" if near is not None else ""
    return InvalidInput(key, None, f"missing in map YAML {path}{hint}")


def _number(doc: dict[str, Any], key: str, path: Path) -> float:
    if key not in doc:
        raise _missing(doc, key, path)
    value = doc[key]
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise InvalidInput(key, value, f"must be a number (map YAML {path})")
    return float(value)


def load_map_yaml(path: str | Path) -> MapMetadata:
    """Read and validate a map_server YAML file."""
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as exc:
        raise ResourceNotFound(f"map YAML {path} cannot be read: {exc.strerror or exc}") from exc
    try:
        doc = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise InvalidInput("map_yaml", str(path), f"malformed YAML: {exc}") from exc
    if not isinstance(doc, dict):
        raise InvalidInput("map_yaml", str(path), "expected a mapping with image, resolution, origin, ...")
    for key in ("image", "origin", "negate"):
        if key not in doc:
            raise _missing(doc, key, path)
    image = doc.get("image")
    if not isinstance(image, str) or not image:
        raise InvalidInput("image", image, f"missing or empty in map YAML {path}")
    origin = doc.get("origin")
    if not isinstance(origin, list) or len(origin) != 3 or not all(
            isinstance(v, int | float) and not isinstance(v, bool) for v in origin):
        raise InvalidInput("origin", origin, f"expected [x, y, yaw] in map YAML {path}")
    negate = doc.get("negate")
    if negate not in (0, 1, True, False) or negate is None:
        raise InvalidInput("negate", negate, f"must be 0 or 1 (map YAML {path})")
    mode = doc.get("mode", "trinary")
    image_path = Path(image) if Path(image).is_absolute() else path.parent / image
    return MapMetadata(
        image=image_path, resolution=_number(doc, "resolution", path),
        origin=(float(origin[0]), float(origin[1]), float(origin[2])), negate=bool(negate),
        occupied_thresh=_number(doc, "occupied_thresh", path), free_thresh=_number(doc, "free_thresh", path),
        mode=str(mode).lower() if isinstance(mode, str) else mode,
    )


def _read_pixels(path: Path) -> tuple[NDArray[np.float64], NDArray[np.float64] | None]:
    """(colour channels (H, W, 3), alpha (H, W) or None), in GraphicsMagick Q16 quantum units."""
    try:
        with Image.open(path) as img:
            img.load()
            mode, info = img.mode, dict(img.info)
            if mode in ("I;16", "I;16B", "I;16L", "I"):
                grey = np.asarray(img, dtype=np.float64)
                return np.repeat(grey[:, :, None], 3, axis=2), None
            has_alpha = mode in ("LA", "RGBA", "PA", "La", "RGBa") or "transparency" in info
            converted = img.convert("RGBA" if has_alpha else "RGB")
            pixels = np.asarray(converted, dtype=np.float64) * (_GM_MAX / 255.0)
    except FileNotFoundError as exc:
        raise ResourceNotFound(f"map image {path} not found") from exc
    except (OSError, UnidentifiedImageError) as exc:
        raise InvalidInput("image", str(path), f"cannot be read as an image: {exc}") from exc
    return pixels[:, :, :3], (pixels[:, :, 3] if has_alpha else None)


def occupancy_from_image(colour: NDArray[np.float64], alpha: NDArray[np.float64] | None,
                         meta: MapMetadata) -> NDArray[np.int8]:
    """Occupancy values (grid rows, row 0 at the bottom) of image pixels in quantum units (0..65535)."""
    channels = [colour[:, :, 0], colour[:, :, 1], colour[:, :, 2]]
    if meta.mode == "trinary" and alpha is not None:
        channels.append(alpha)
    shade: NDArray[np.float64] = np.sum(channels, axis=0) / len(channels) / _GM_MAX
    occ = shade if meta.negate else 1.0 - shade
    cells = np.full(shade.shape, -1, dtype=np.int16)
    if meta.mode == "raw":
        percent = np.floor(shade * 255.0 + 0.5)
        keep = (percent >= 0) & (percent <= 100)
        cells[keep] = percent[keep].astype(np.int16)
    else:
        between = np.rint((occ - meta.free_thresh) / (meta.occupied_thresh - meta.free_thresh) * 100.0)
        if meta.mode == "scale":
            cells[:] = between.astype(np.int16)
        cells[occ < meta.free_thresh] = 0
        cells[occ > meta.occupied_thresh] = 100
        if meta.mode == "scale" and alpha is not None:
            cells[alpha != _GM_MAX] = -1
    return np.ascontiguousarray(cells[::-1].astype(np.int8))


def load_map(path: str | Path, frame_id: str = "map") -> OccupancyMap:
    """Load a map_server map (YAML + image) into an :class:`OccupancyMap` exactly as nav2's map_server."""
    meta = load_map_yaml(path)
    if not meta.image.exists():
        raise ResourceNotFound(f"map image {meta.image} (named by {path}) not found")
    colour, alpha = _read_pixels(meta.image)
    data = occupancy_from_image(colour, alpha, meta)
    logger.info("loaded map %s: %d x %d cells at %g m", meta.image, data.shape[1], data.shape[0], meta.resolution)
    return OccupancyMap(data, meta.resolution, meta.origin, frame_id)


def _image_of(occ: OccupancyMap, mode: str, free_int: int, occupied_int: int) -> Image.Image:
    values = occ.data[::-1].astype(np.int16)
    unknown = (values < 0) | (values > 100)
    if mode == "trinary":
        grey = np.full(values.shape, 205, dtype=np.uint8)
        grey[~unknown & (values <= free_int)] = 254
        grey[~unknown & (values >= occupied_int)] = 0
        return Image.fromarray(grey, mode="L")
    if mode == "scale":
        rgba = np.empty((*values.shape, 4), dtype=np.uint8)
        grey = np.floor((100.0 - values) / 100.0 * 255.0 + 0.5).clip(0, 255).astype(np.uint8)
        grey[unknown] = 128
        rgba[:, :, :3] = grey[:, :, None]
        rgba[:, :, 3] = np.where(unknown, 0, 255)
        return Image.fromarray(rgba, mode="RGBA")
    raw = np.where(unknown, 255, values).astype(np.uint8)
    return Image.fromarray(raw, mode="L")


def save_map(occ: OccupancyMap, path: str | Path, *, mode: str = "trinary", image_format: str | None = None,
             free_thresh: float = 0.196, occupied_thresh: float = 0.65) -> Path:
    """Write ``<path>.yaml`` and ``<path>.<pgm|png>`` as nav2's map_saver does; return the YAML path.

    ``path`` is the file stem (a ``.yaml`` suffix is dropped). The default ``free_thresh`` is ROS 1
    map_saver's 0.196, which keeps unknown (205-grey) cells unknown when the map is loaded again.
    Numbers are written at full precision (nav2 writes 3 digits, which can move the origin).
    """
    if mode not in MAP_MODES:
        raise InvalidInput("mode", mode, f"must be one of {', '.join(MAP_MODES)}")
    stem = Path(path)
    if stem.suffix == ".yaml":
        stem = stem.with_suffix("")
    fmt = (image_format or ("png" if mode == "scale" else "pgm")).lower()
    if mode == "scale" and fmt != "png":
        raise InvalidInput("image_format", fmt, "scale mode needs transparency: use png")
    meta = MapMetadata(Path(f"{stem.name}.{fmt}"), occ.resolution, occ.origin, False, occupied_thresh,
                       free_thresh, mode)
    image = _image_of(occ, mode, round(free_thresh * 100.0), round(occupied_thresh * 100.0))
    stem.parent.mkdir(parents=True, exist_ok=True)
    image.save(stem.parent / meta.image, format="PPM" if fmt == "pgm" else fmt.upper())
    doc = {"image": str(meta.image), "mode": mode, "resolution": occ.resolution, "origin": list(occ.origin),
           "negate": 0, "occupied_thresh": occupied_thresh, "free_thresh": free_thresh}
    yaml_path = stem.with_suffix(".yaml")
    yaml_path.write_text(yaml.safe_dump(doc, sort_keys=False, default_flow_style=None))
    return yaml_path
