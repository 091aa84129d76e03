"""The fitted link models of the built-in robots that ship with pfield (``pfield/data/robot_fits``), and the
maintainers' command that writes them anew::

    python -m pfield.robot._shipped_fits            # fit every built-in robot's links, write their files
    python -m pfield.robot._shipped_fits --check    # only compare: exit 1 when a shipped fit is stale or missing

:func:`pfield.robot._fit.cached_fit` reads a shipped fit when the user's cache has none for the link's key
(:meth:`pfield.robot._fit.LinkSurface.key`: the surface, the stand-off bound, the fit parameters and
``FIT_VERSION``), so a new install plans with a built-in robot without fitting it (seconds a robot). A changed
mesh, setting or fitting rule makes a new key and the shipped file is no longer read; a change of the fitting
code that changes its results must bump ``FIT_VERSION`` and be followed by this command
(``tests/robot/test_shipped_fits.py`` holds each shipped fit equal to a fresh fit, bit for bit).

Each link is fitted anew here (:func:`pfield.robot._fit.fit_link`), never read from a cache. The files are
``<robot>/<link>-<key>.npz`` (compressed, a few kB each); a robot's files of other keys are removed.
"""

from __future__ import annotations

import argparse
import re
import sys
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pfield.robot._fit import SHIPPED_DIRECTORY, TARGET_GAP, LinkFit, LinkSurface, fit_link, read_fit, write_fit

__all__ = ["ShippedLink", "main", "same_fit", "shipped_links", "stale_links", "write_shipped"]


@dataclass(frozen=True)
class ShippedLink:
    """One link of a built-in robot: its surface, its key and the file its shipped fit has (or should have)."""

    robot: str
    link: str
    surface: LinkSurface
    key: str
    path: Path


def _file_name(link: str, key: str) -> str:
    return f"{re.sub(r'[^A-Za-z0-9_.]+', '_', link)}-{key}.npz"


def shipped_links(names: Iterable[str] | None = None, directory: Path = SHIPPED_DIRECTORY) -> list[ShippedLink]:
    """The links with collision geometry of the built-in robots ``names`` (default: all of them), as loaded here."""
    from pfield.robot import RobotModel
    from pfield.robot.catalog import BUILTIN_ROBOTS
    from pfield.robot.geometry import _link_surfaces

    links = []
    for name in BUILTIN_ROBOTS if names is None else names:
        for link, (_, _, surface) in _link_surfaces(RobotModel.builtin(name)).items():
            key = surface.key(TARGET_GAP)
            links.append(ShippedLink(name, link, surface, key, directory / name / _file_name(link, key)))
    return links


def same_fit(one: LinkFit, other: LinkFit) -> bool:
    """Whether two fits are equal bit for bit (every array's dtype, shape and bytes; every measure)."""
    arrays = [(one.primitives.a, other.primitives.a), (one.primitives.b, other.primitives.b),
              (one.primitives.radii, other.primitives.radii), (one.bound.a, other.bound.a),
              (one.bound.b, other.bound.b), (one.bound.radii, other.bound.radii)]
    measures = [(one.mean_gap, other.mean_gap), (one.max_gap, other.max_gap), (one.volume_ratio, other.volume_ratio),
                (one.bound_volume_ratio, other.bound_volume_ratio), (one.bound_mean_gap, other.bound_mean_gap)]
    return (all(x.dtype == y.dtype and x.shape == y.shape and x.tobytes() == y.tobytes() for x, y in arrays)
            and all(np.float64(x).tobytes() == np.float64(y).tobytes() for x, y in measures))


def stale_links(links: Sequence[ShippedLink], directory: Path = SHIPPED_DIRECTORY) -> list[str]:
    """What is wrong with the shipped fits of ``links``, one line each (empty: each link's file exists, records its
    key and equals a fresh fit bit for bit); also a file in a robot's directory that no link of it has."""
    problems = []
    for link in links:
        if not link.path.exists():
            problems.append(f"{link.robot} {link.link}: no shipped fit {link.path.name}")
        elif not same_fit(read_fit(link.path, link.key), fit_link(link.surface, TARGET_GAP)):
            problems.append(f"{link.robot} {link.link}: {link.path.name} differs from a fresh fit")
    expected = {link.path for link in links}
    for robot in dict.fromkeys(link.robot for link in links):
        problems += [f"{robot}: {path.name} is no link's fit" for path in sorted((directory / robot).glob("*.npz"))
                     if path not in expected]
    return problems


def write_shipped(names: Iterable[str] | None = None, directory: Path = SHIPPED_DIRECTORY) -> list[Path]:
    """Fit the links of the built-in robots ``names`` (default: all) anew and write their files under
    ``directory``; remove the files of those robots that no link has any more. Returns the files written."""
    links = shipped_links(names, directory)
    written = []
    for link in links:
        link.path.parent.mkdir(parents=True, exist_ok=True)
        write_fit(link.path, fit_link(link.surface, TARGET_GAP), link.key, compressed=True)
        written.append(link.path)
    for robot in dict.fromkeys(link.robot for link in links):
        for path in (directory / robot).glob("*.npz"):
            if path not in written:
                path.unlink()
    return written


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m pfield.robot._shipped_fits",
                                     description="Write (or --check) the fitted link models shipped with pfield.")
    parser.add_argument("robots", nargs="*", help="built-in robot names (default: all)")
    parser.add_argument("--check", action="store_true", help="only compare with fresh fits; exit 1 when stale")
    args = parser.parse_args(argv)
    names = args.robots or None
    if args.check:
        problems = stale_links(shipped_links(names))
        for line in problems:
            print(line)
        print("shipped fits are stale" if problems else "shipped fits are current")
        return 1 if problems else 0
    for path in write_shipped(names):
        print(f"{path.relative_to(SHIPPED_DIRECTORY)}: {path.stat().st_size} bytes")
    return 0


if __name__ == "__main__":
    sys.exit(main())
