"""The built-in robots' fitted link models shipped with pfield (``pfield/data/robot_fits``, issue 32): each equals a
fresh fit bit for bit and is what an empty cache reads, and a fit filed under another key is never read."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial import ConvexHull

from pfield.robot import _cover, _fit, _solid
from pfield.robot._shipped_fits import same_fit, shipped_links
from pfield.robot.catalog import BUILTIN_ROBOTS

REGENERATE = "python -m pfield.robot._shipped_fits (after bumping FIT_VERSION if the fitting rule changed)"


@pytest.fixture
def empty_cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """An empty user cache (on disk and in memory)."""
    cache = tmp_path / "user-cache"
    cache.mkdir()
    monkeypatch.setattr(_fit, "fit_cache_directory", lambda: cache)
    monkeypatch.setattr(_fit, "_MEMORY", {})
    return cache


@pytest.fixture
def shipped(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[Path]:
    """A shipped-fits directory of the test's own in place of pfield's."""
    directory = tmp_path / "shipped"
    (directory / "box").mkdir(parents=True)
    monkeypatch.setattr(_fit, "SHIPPED_DIRECTORY", directory)
    _fit.shipped_fits.cache_clear()
    yield directory
    _fit.shipped_fits.cache_clear()


def _box(half: float = 0.02) -> _fit.LinkSurface:
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=np.float64) * half
    return _fit.LinkSurface(corners, np.asarray(ConvexHull(corners).simplices, dtype=np.int64), (2 * half) ** 3)


def _marked(fit: _fit.LinkFit) -> _fit.LinkFit:
    """``fit`` with its radii doubled: a fit no fitting makes, to tell where a fit was read from."""
    prims = fit.primitives
    return _fit.LinkFit(_fit.Primitives(prims.a, prims.b, 2.0 * prims.radii), fit.mean_gap, fit.max_gap,
                        fit.volume_ratio, fit.bound, fit.bound_volume_ratio, fit.bound_mean_gap)


@pytest.mark.parametrize("name", sorted(BUILTIN_ROBOTS))
def test_an_empty_cache_reads_the_shipped_fits_and_they_equal_a_fresh_fit(
        name: str, empty_cache: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    links = shipped_links([name])
    assert links, f"{name} has no link with collision geometry"
    missing = [link.path.name for link in links if not link.path.exists()]
    assert not missing, f"no shipped fit for {missing}: run {REGENERATE}"
    extra = sorted({p.name for p in (_fit.SHIPPED_DIRECTORY / name).glob("*.npz")} - {li.path.name for li in links})
    assert not extra, f"stale shipped fits {extra}: run {REGENERATE}"
    fit_link = _fit.fit_link
    monkeypatch.setattr(_fit, "fit_link", lambda *args: pytest.fail("fitted although a shipped fit exists"))
    read = {link.link: _fit.cached_fit(link.surface) for link in links}  # the lookup a plan makes
    assert not list(empty_cache.iterdir())  # read only: nothing was fitted or written to the user's cache
    differ = [link.link for link in links if not same_fit(read[link.link], fit_link(link.surface, _fit.TARGET_GAP))]
    assert not differ, f"{name}: the shipped fits of {differ} differ from a fresh fit: run {REGENERATE}"


def test_a_fit_filed_under_another_key_is_never_read(empty_cache: Path, shipped: Path) -> None:
    surface = _box()
    key = surface.key(_fit.TARGET_GAP)
    fresh = _fit.fit_link(surface)
    bogus = _marked(fresh)
    # a fit of the same surface at another stand-off bound, and one of a slightly other surface
    _fit.write_fit(shipped / "box" / f"box-{surface.key(0.02)}.npz", bogus, surface.key(0.02))
    other = _box(0.0200001).key(_fit.TARGET_GAP)
    _fit.write_fit(shipped / "box" / f"box-{other}.npz", bogus, other)
    # a file renamed to the right key: it records the key it was fitted for, so it is refused too
    _fit.write_fit(shipped / "box" / f"box-{key}.npz", bogus, other)
    _fit.shipped_fits.cache_clear()
    assert same_fit(_fit.cached_fit(surface), fresh)  # fitted anew, none of the three read
    assert len(list(empty_cache.glob("*.npz"))) == 1


def test_the_user_cache_comes_first_then_the_shipped_fit(empty_cache: Path, shipped: Path,
                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    surface = _box()
    key = surface.key(_fit.TARGET_GAP)
    fresh = _fit.fit_link(surface)
    _fit.write_fit(shipped / "box" / f"box-{key}.npz", _marked(fresh), key, compressed=True)
    _fit.shipped_fits.cache_clear()
    monkeypatch.setattr(_fit, "fit_link", lambda *args: pytest.fail("fitted although a shipped fit exists"))
    assert same_fit(_fit.cached_fit(surface), _marked(fresh))  # the shipped file, under the right key
    _fit.write_fit(empty_cache / f"{key}.npz", fresh, key)
    monkeypatch.setattr(_fit, "_MEMORY", {})
    assert same_fit(_fit.cached_fit(surface), fresh)  # the user's cache before the shipped fit


def test_the_key_covers_the_mesh_the_settings_and_the_fit_version(monkeypatch: pytest.MonkeyPatch) -> None:
    surface = _box()
    key = surface.key(_fit.TARGET_GAP)
    assert surface.key(_fit.TARGET_GAP) == key and len(key) == 32
    moved = surface.vertices.copy()
    moved[3, 1] = np.nextafter(moved[3, 1], 1.0)  # one vertex, by one unit in the last place
    assert _fit.LinkSurface(moved, surface.triangles, surface.volume).key(_fit.TARGET_GAP) != key
    flipped = surface.triangles[:, ::-1].copy()
    assert _fit.LinkSurface(surface.vertices, flipped, surface.volume).key(_fit.TARGET_GAP) != key
    assert surface.key(np.nextafter(_fit.TARGET_GAP, 1.0)) != key
    # names and volume are not what is fitted: they do not change the key
    assert _fit.LinkSurface(surface.vertices, surface.triangles, 1.0, "other", ("x.stl",)).key(_fit.TARGET_GAP) == key
    for module, name in [(_fit, "FIT_VERSION"), (_fit, "_COVER_SAMPLES"), (_fit, "_FIT_SEED"), (_fit, "_PAIR_REACH"),
                         (_cover, "_GRID_CELLS"), (_solid, "_HULL_TOLERANCE")]:
        with monkeypatch.context() as patch:
            patch.setattr(module, name, getattr(module, name) * 2)
            assert surface.key(_fit.TARGET_GAP) != key, f"{module.__name__}.{name} is not in the key"
    assert surface.key(_fit.TARGET_GAP) == key
