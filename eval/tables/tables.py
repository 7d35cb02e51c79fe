"""The tables of README.md and docs/, generated from the committed result files.

A generated table sits between two markers in a page::

    <!-- generated: GENERATOR FILE [FILE ...] [NAME=VALUE ...] -->
    | ... the table, written by :func:`regenerate` ... |
    <!-- end generated -->

``GENERATOR`` names a formatter of :data:`GENERATORS`, each ``FILE`` a result file (JSON)
relative to the repository root, and ``NAME=VALUE`` the formatter's options. :func:`regenerate`
rewrites every table from its files; :func:`check_pages` reports, for each table that differs
from what its files give, the page, the table and the first differing number. Hand-edited
figures therefore cannot drift from the results: ``sfa-gym docs tables --check`` (and
``tests/test_published_tables.py``) fail on them.
"""

from __future__ import annotations

import json
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from eval.tables import cost_formatters, formatters, study_formatters

__all__ = [
    "GENERATORS",
    "Mismatch",
    "check_pages",
    "default_pages",
    "regenerate",
    "render",
    "repository_root",
    "table_specs",
    "update_pages",
]

Generator = Callable[[Sequence[dict[str, Any]], dict[str, str]], str]


def _one(files: Sequence[dict[str, Any]], name: str) -> dict[str, Any]:
    if len(files) != 1:
        raise ValueError(f"{name} takes one result file, got {len(files)}")
    return files[0]


def _localization(files: Sequence[dict[str, Any]], options: dict[str, str]) -> str:
    from sfa_gym.cli.results import format_table

    # the protocols' own plain-text table, kept as a block so its columns stay aligned
    return "```text\n" + format_table(_one(files, "localization")) + "\n```"


def _navigation(files: Sequence[dict[str, Any]], options: dict[str, str]) -> str:
    from sfa_gym.cli.navigate import format_navigation_table

    return format_navigation_table(_one(files, "navigation"))


GENERATORS: dict[str, Generator] = {
    "localization": _localization,
    "navigation": _navigation,
    "board": formatters.board_table,
    "board-parts": formatters.board_parts_table,
    "nav-controllers": formatters.nav_controllers_table,
    "board-seeds": formatters.board_seeds_table,
    "board-seconds": cost_formatters.board_seconds_table,
    "board-memory": cost_formatters.board_memory_table,
    "board-time": formatters.board_time_table,
    "quick-vs-full": formatters.quick_vs_full_table,
    "nav-sets": formatters.nav_sets_table,
    "descent-bound": formatters.descent_bound_table,
    "nav-steps": formatters.nav_steps_table,
    "outdoor-cost": formatters.outdoor_cost_table,
    "image-statistics": formatters.image_statistics_table,
    "item-density": study_formatters.item_density_table,
    "appearance-change": formatters.appearance_change_table,
    "textures-build": formatters.textures_build_table,
    "run-reading": cost_formatters.run_reading_table,
    "paper-pipeline": study_formatters.paper_pipeline_table,
    "release-drift": study_formatters.release_drift_table,
    "appearance-order": study_formatters.appearance_order_table,
    "sfa-engine": formatters.sfa_engine_table,
    "leaderboard-timings": formatters.leaderboard_timings_table,
    "equivariance": formatters.equivariance_table,
}
"""Formatters by the name a marker gives: ``localization`` (a localization protocol's
``results.json``, :func:`sfa_gym.cli.results.format_table`), ``navigation`` (the
navigation protocol's ``results.json``), ``board`` and ``board-parts`` (the leaderboard's
reference board), ``board-seconds`` and ``board-memory`` (what its tasks cost:
:mod:`eval.tables.cost_formatters`), ``nav-controllers`` (success and SPL of navigation
results, controllers beside the gradient controller), ``board-seeds`` (one track's score per
world seed, paired differences), ``board-time`` (a sweep's time per
track), ``nav-sets``
(navigation studies' episode sets),
``quick-vs-full`` (the quick board's ranks against the full one's), ``descent-bound``,
``nav-steps``, ``outdoor-cost`` (also the textures' cost per step), ``image-statistics``,
``appearance-change``, ``textures-build``, ``sfa-engine``, ``leaderboard-timings`` and
``equivariance`` (:mod:`eval.tables.formatters`); ``paper-pipeline``, ``release-drift``,
``appearance-order`` and ``item-density`` (:mod:`eval.tables.study_formatters`)."""

_BLOCK = re.compile(
    r"<!-- generated: (?P<spec>[^\n]*?) -->\n(?P<body>.*?)<!-- end generated -->", re.DOTALL
)
_NUMBER = re.compile(r"-?\d+(?:\.\d+)?")


def repository_root() -> Path:
    """The checkout this package was imported from (the folder holding ``published/``)."""
    return Path(__file__).resolve().parents[2]


def default_pages(root: Path) -> list[Path]:
    """README.md and every markdown page under docs/."""
    return [root / "README.md", *sorted((root / "docs").rglob("*.md"))]


def table_specs(text: str) -> list[str]:
    """The spec (``GENERATOR FILE ... NAME=VALUE ...``) of every generated table of ``text``."""
    return [match["spec"] for match in _BLOCK.finditer(text)]


def render(spec: str, root: Path) -> str:
    """The table a marker's ``spec`` (``GENERATOR FILE ... NAME=VALUE ...``) gives."""
    name, *words = spec.split()
    if name not in GENERATORS:
        raise ValueError(f"unknown table generator {name!r}; expected one of {sorted(GENERATORS)}")
    options = dict(w.split("=", 1) for w in words if "=" in w)
    paths = [w for w in words if "=" not in w]
    if not paths:
        raise ValueError(f"table {spec!r} names no result file")
    files = []
    for relative in paths:
        path = root / relative
        if not path.is_file():
            raise ValueError(f"table {spec!r}: result file {relative!r} not found under {root}")
        files.append(json.loads(path.read_text()))
    return GENERATORS[name](files, options)


def regenerate(text: str, root: Path) -> str:
    """``text`` with every generated table rewritten from its result files."""

    def replace(match: re.Match[str]) -> str:
        table = render(match["spec"], root)
        return f"<!-- generated: {match['spec']} -->\n{table}\n<!-- end generated -->"

    return _BLOCK.sub(replace, text)


@dataclass(frozen=True)
class Mismatch:
    """A generated table of ``page`` that differs from what its result files give."""

    page: Path
    spec: str
    difference: str

    def __str__(self) -> str:
        return f"{self.page}: table '{self.spec}': {self.difference}"


def first_difference(expected: str, found: str) -> str:
    """The first number (else the first line) where ``found`` departs from ``expected``."""
    for row, (want, have) in enumerate(
        zip(expected.splitlines(), found.splitlines(), strict=False)
    ):
        if want == have:
            continue
        numbers = zip(_NUMBER.findall(want), _NUMBER.findall(have), strict=False)
        for a, b in numbers:
            if a != b:
                return f"line {row + 1} of the table: {b} where the result file gives {a}"
        return f"line {row + 1} of the table reads {have!r}, the result file gives {want!r}"
    return (
        f"the table has {len(found.splitlines())} lines, the result file gives "
        f"{len(expected.splitlines())}"
    )


def check_pages(pages: Sequence[Path], root: Path) -> list[Mismatch]:
    """Every generated table of ``pages`` that differs from its result files."""
    found = []
    for page in pages:
        for match in _BLOCK.finditer(page.read_text()):
            expected = render(match["spec"], root) + "\n"
            if match["body"] != expected:
                found.append(
                    Mismatch(page, match["spec"], first_difference(expected, match["body"]))
                )
    return found


def update_pages(pages: Sequence[Path], root: Path) -> list[Path]:
    """Regenerate the tables of ``pages`` in place; returns the pages that changed."""
    changed = []
    for page in pages:
        text = page.read_text()
        new = regenerate(text, root)
        if new != text:
            page.write_text(new)
            changed.append(page)
    return changed
