"""map_server maps: trinary/scale/raw and negate load as nav2's map_server does; saving; OccupancyGrid."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from pfield.costmap import OccupancyMap, load_map, save_map
from pfield.errors import InvalidInput, ResourceNotFound
from pfield.interfaces.nav_msgs import OccupancyGrid

# image rows top to bottom; one row per shade
PIXELS = np.array([[0, 254, 205, 100, 128, 50, 255]], dtype=np.uint8)


def _write(tmp_path: Path, pixels: np.ndarray, **yaml_fields: object) -> Path:
    mode = "RGBA" if pixels.ndim == 3 else "L"
    name = "map.png" if mode == "RGBA" else "map.pgm"
    Image.fromarray(pixels, mode=mode).save(tmp_path / name)
    fields = {"image": name, "resolution": 0.05, "origin": "[-1.0, -2.0, 0.0]", "negate": 0,
              "occupied_thresh": 0.65, "free_thresh": 0.196} | yaml_fields
    text = "\n".join(f"{key}: {value}" for key, value in fields.items() if value is not None)
    (tmp_path / "map.yaml").write_text(text + "\n")
    return tmp_path / "map.yaml"


def _occ(shade: float, negate: bool) -> float:
    return shade if negate else 1.0 - shade


def _trinary(v: int, negate: bool, free: float = 0.196, occupied: float = 0.65) -> int:
    occ = _occ(v / 255.0, negate)
    return 100 if occ > occupied else (0 if occ < free else -1)


@pytest.mark.parametrize("negate", [0, 1])
def test_trinary_and_negate(tmp_path: Path, negate: int) -> None:
    occ = load_map(_write(tmp_path, PIXELS, negate=negate))
    expected = [_trinary(int(v), bool(negate)) for v in PIXELS[0]]
    assert occ.data[0].tolist() == expected
    assert expected == ([100, 0, -1, -1, -1, 100, 0] if not negate else [0, 100, 100, -1, -1, -1, 100])
    assert occ.resolution == 0.05 and occ.origin == (-1.0, -2.0, 0.0)


def test_image_top_row_is_last_grid_row(tmp_path: Path) -> None:
    pixels = np.array([[0, 254], [254, 254], [254, 254]], dtype=np.uint8)  # top-left pixel occupied
    occ = load_map(_write(tmp_path, pixels))
    assert occ.data.shape == (3, 2)
    assert occ.data[2, 0] == 100 and int(np.count_nonzero(occ.data)) == 1


def test_scale_mode(tmp_path: Path) -> None:
    occ = load_map(_write(tmp_path, PIXELS, mode="scale", free_thresh=0.2, occupied_thresh=0.8))
    expected = []
    for v in PIXELS[0]:
        o = 1.0 - v / 255.0
        expected.append(100 if o > 0.8 else (0 if o < 0.2 else int(np.rint((o - 0.2) / 0.6 * 100))))
    assert occ.data[0].tolist() == expected
    assert expected[4] == 50  # 128 grey: occ 0.498 → rint(49.67)


def test_scale_mode_transparent_is_unknown_and_trinary_averages_alpha(tmp_path: Path) -> None:
    rgba = np.array([[[255, 255, 255, 255], [255, 255, 255, 0], [0, 0, 0, 0]]], dtype=np.uint8)
    occ = load_map(_write(tmp_path, rgba, mode="scale"))
    assert occ.data[0].tolist() == [0, -1, -1]
    # trinary: opacity averaged in, (255·3 + 0)/4 → shade 0.75, occ 0.25 → unknown; black+transparent → occ 1
    occ = load_map(_write(tmp_path, rgba, mode="trinary"))
    assert occ.data[0].tolist() == [0, -1, 100]


@pytest.mark.parametrize("negate", [0, 1])
def test_raw_mode_ignores_negate(tmp_path: Path, negate: int) -> None:
    occ = load_map(_write(tmp_path, PIXELS, mode="raw", negate=negate))
    assert occ.data[0].tolist() == [0, -1, -1, 100, -1, 50, -1]


def test_sixteen_bit_image(tmp_path: Path) -> None:
    grey = np.array([[0, 65535, 205 * 257, 254 * 257]], dtype=np.uint16)
    Image.fromarray(grey).save(tmp_path / "deep.png")  # mode I;16
    (tmp_path / "deep.yaml").write_text("image: deep.png\nresolution: 0.1\norigin: [0, 0, 0]\nnegate: 0\n"
                                        "occupied_thresh: 0.65\nfree_thresh: 0.196\n")
    assert load_map(tmp_path / "deep.yaml").data.tolist() == [[100, 0, -1, 0]]


def test_trinary_round_trip(tmp_path: Path) -> None:
    data = np.array([[0, 100, -1, 50, 20, 65]], dtype=np.int8)
    occ = OccupancyMap(data, 0.1, (1.5, -2.25, 0.0))
    loaded = load_map(save_map(occ, tmp_path / "out"))
    assert loaded.data.tolist() == [[0, 100, -1, -1, 0, 100]]  # ≤ 20 free, ≥ 65 occupied, else unknown
    assert loaded.origin == occ.origin and loaded.resolution == occ.resolution
    assert (tmp_path / "out.pgm").exists()


def test_raw_round_trip_is_exact(tmp_path: Path) -> None:
    data = np.arange(-1, 101, dtype=np.int8).reshape(6, 17)
    loaded = load_map(save_map(OccupancyMap(data, 0.05), tmp_path / "raw", mode="raw"))
    np.testing.assert_array_equal(loaded.data, data)


def test_scale_round_trip_keeps_known_extremes(tmp_path: Path) -> None:
    data = np.array([[0, 100, -1, 50]], dtype=np.int8)
    path = save_map(OccupancyMap(data, 0.05), tmp_path / "scale", mode="scale")
    assert path.with_suffix(".png").exists()
    loaded = load_map(path)
    o = 1.0 - 128 / 255.0  # 50 % is written as grey 128
    assert loaded.data.tolist() == [[0, 100, -1, int(np.rint((o - 0.196) / (0.65 - 0.196) * 100))]]


def test_occupancy_grid_round_trip() -> None:
    data = np.array([[0, 100, -1], [5, 6, 7]], dtype=np.int8)
    occ = OccupancyMap(data, 0.25, (1.0, 2.0, 0.5), "map")
    msg = OccupancyGrid.model_validate(occ.to_message_fields())
    assert msg.data == [0, 100, -1, 5, 6, 7] and msg.info.width == 3 and msg.info.height == 2
    back = OccupancyMap.from_message(msg)
    np.testing.assert_array_equal(back.data, data)
    assert back.origin[:2] == (1.0, 2.0) and math.isclose(back.origin[2], 0.5)
    assert back.resolution == 0.25


def test_occupancy_grid_size_mismatch_rejected() -> None:
    msg = OccupancyGrid.model_validate({"info": {"width": 2, "height": 2, "resolution": 0.1}, "data": [0, 0, 0]})
    with pytest.raises(InvalidInput, match="data"):
        OccupancyMap.from_message(msg)


@pytest.mark.parametrize(
    ("override", "field"),
    [
        ({"resolution": 0}, "resolution"),
        ({"resolution": -0.05}, "resolution"),
        ({"resolution": None}, "resolution"),
        ({"free_thresh": 0.7}, "free_thresh"),
        ({"occupied_thresh": 1.5}, "occupied_thresh"),
        ({"mode": "fancy"}, "mode"),
        ({"negate": 3}, "negate"),
        ({"origin": "[0, 0]"}, "origin"),
        ({"image": None}, "image"),
    ],
)
def test_bad_yaml_fields(tmp_path: Path, override: dict[str, object], field: str) -> None:
    path = _write(tmp_path, PIXELS, **override)
    with pytest.raises(InvalidInput) as info:
        load_map(path)
    assert info.value.field == field


@pytest.mark.parametrize(("key", "typo"), [("resolution", "resolutoin"), ("negate", "negat"), ("image", "imgae"),
                                           ("free_thresh", "free_tresh")])
def test_a_misspelt_key_is_named_beside_the_missing_one(tmp_path: Path, key: str, typo: str) -> None:
    path = _write(tmp_path, PIXELS, **{key: None, typo: 0.05 if key != "image" else "map.pgm"})
    with pytest.raises(InvalidInput) as info:
        load_map(path)
    assert info.value.field == key
    assert f"missing in map YAML {path} (it has '{typo}': did you mean '{key}'?)" in str(info.value)
    unrelated = _write(tmp_path, PIXELS, **{key: None, "comment": "x"})  # nothing like it: no hint
    with pytest.raises(InvalidInput, match=f"missing in map YAML {unrelated}$"):
        load_map(unrelated)


def test_missing_or_malformed_files(tmp_path: Path) -> None:
    with pytest.raises(ResourceNotFound):
        load_map(tmp_path / "nope.yaml")
    (tmp_path / "bad.yaml").write_text("image: [unclosed\n")
    with pytest.raises(InvalidInput, match="malformed YAML"):
        load_map(tmp_path / "bad.yaml")
    path = _write(tmp_path, PIXELS, image="missing.pgm")
    with pytest.raises(ResourceNotFound, match=r"missing\.pgm"):
        load_map(path)
    path = _write(tmp_path, PIXELS, image="garbage.pgm")
    (tmp_path / "garbage.pgm").write_text("not an image")
    with pytest.raises(InvalidInput, match="image"):
        load_map(path)
