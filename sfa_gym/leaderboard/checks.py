"""Whether the results of a board can be compared: the package versions each was computed with
against the lock (``constraints.txt``), and each navigation result's episode fingerprints
against the reference result of the same track, track version, method and world seed.

A result records the versions of the locked packages in ``versions`` and each navigation
result its episodes' fingerprint per world seed in ``fingerprints``
(:func:`~sfa_gym.protocols.navigation.episode_fingerprint`). A result written before either was
recorded is not marked: nothing says it differs, and :func:`warnings` counts it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

Row = tuple[str, str]
"""A row of the table: ``(method label, source)``
(:data:`~sfa_gym.leaderboard.table.Row`)."""

__all__ = ["FINGERPRINT_MARK", "VERSIONS_MARK", "Marks", "check_board", "fingerprints"]

VERSIONS_MARK = "†"
"""The mark of a cell whose result was computed with package versions other than the lock's."""
FINGERPRINT_MARK = "‡"
"""The mark of a cell whose episodes differ from the reference result's (fingerprints)."""


def fingerprints(result: dict[str, Any]) -> dict[int, str]:
    """``{world seed: episode fingerprint}`` of ``result`` (none where it records none)."""
    return {int(seed): found for seed, found in (result.get("fingerprints") or {}).items()}


@dataclass
class Marks:
    """What :func:`check_board` found, per cell ``(column, row)`` of the board.

    Attributes:
        versions: ``{cell: {package: (version, locked version)}}`` for results computed with
            versions other than the lock's.
        fingerprints: ``{cell: [world seeds]}`` for results whose episodes on those seeds differ
            from the reference result's.
        cpus: ``{cell: (its CPU numerics, the reference's)}`` for the cells of
            ``fingerprints`` whose CPUs round differently
            (:func:`~sfa_gym.lock.cpu_numerics`): a likely cause.
        unrecorded: cells whose result records no package versions (written before they were
            recorded).
    """

    versions: dict[tuple[str, Row], dict[str, tuple[str | None, str]]] = field(default_factory=dict)
    fingerprints: dict[tuple[str, Row], list[int]] = field(default_factory=dict)
    cpus: dict[tuple[str, Row], tuple[Any, Any]] = field(default_factory=dict)
    unrecorded: list[tuple[str, Row]] = field(default_factory=list)

    def mark(self, column: str, row: Row) -> str:
        """The marks of a cell: ``""``, or a space and :data:`VERSIONS_MARK` and/or
        :data:`FINGERPRINT_MARK`."""
        marks = (VERSIONS_MARK if (column, row) in self.versions else "") + (
            FINGERPRINT_MARK if (column, row) in self.fingerprints else ""
        )
        return f" {marks}" if marks else ""

    def footnotes(self) -> list[str]:
        """Markdown lines explaining the marks used (none when no cell is marked)."""
        lines = []
        if self.versions:
            lines.append(
                f"{VERSIONS_MARK} computed with package versions other than the lock's "
                "(constraints.txt): the numbers may differ for that reason alone."
            )
        if self.fingerprints:
            lines.append(
                f"{FINGERPRINT_MARK} its navigation episodes differ from the reference result's "
                "on some world seeds (episode fingerprints): the same track, version, method and "
                "seed drove differently."
            )
        return ["", *lines] if lines else []

    def warnings(self) -> list[str]:
        """One line per marked result (what differs), and one for the results that record no
        versions."""
        lines = []
        for (column, row), changed in self.versions.items():
            found = ", ".join(
                f"{n} {have or 'missing'} (lock {lock})" for n, (have, lock) in changed.items()
            )
            lines.append(f"{column} / {row[0]} ({row[1]}): versions differ from the lock: {found}")
        for (column, row), seeds in self.fingerprints.items():
            cpus = self.cpus.get((column, row))
            cause = (
                f"; computed on a CPU that rounds differently: {cpus[0]}, the reference on "
                f"{cpus[1]}"
                if cpus
                else ""
            )
            lines.append(
                f"{column} / {row[0]} ({row[1]}): episode fingerprints differ from the "
                f"reference result on world seeds {seeds}{cause}"
            )
        if self.unrecorded:
            lines.append(
                f"{len(self.unrecorded)} result(s) record no package versions (written before "
                "versions were recorded); they are not compared with the lock"
            )
        return lines


def check_board(
    board: Any, lock: dict[str, str] | None = None, reference: str = "reference"
) -> Marks:
    """The :class:`Marks` of ``board`` (a :class:`~sfa_gym.leaderboard.table.Board`): each
    result's versions against ``lock`` (default: the lock of this checkout or installation),
    each result's fingerprints against the row of the same method from the source
    ``reference`` (:data:`~sfa_gym.leaderboard.results.REFERENCE`) in the same column (the
    column is the track and its size) at the same track version."""
    from sfa_gym.lock import differences, read_lock

    lock = read_lock() if lock is None else lock
    marks = Marks()
    for column in board.tracks:
        cells = board.cells[column]
        for row, result in cells.items():
            versions = result.get("versions")
            if versions is None:
                marks.unrecorded.append((column, row))
            else:
                changed = differences(versions, lock)
                if changed:
                    marks.versions[(column, row)] = changed
            theirs = cells.get((row[0], reference))
            if row[1] == reference or theirs is None:
                continue
            if theirs["track_version"] != result["track_version"]:
                continue
            theirs_prints, mine = fingerprints(theirs), fingerprints(result)
            seeds = sorted(
                s for s in mine.keys() & theirs_prints.keys() if mine[s] != theirs_prints[s]
            )
            if seeds:
                marks.fingerprints[(column, row)] = seeds
                cpus = [r.get("cpu_numerics") for r in (result, theirs)]
                if None not in cpus and cpus[0] != cpus[1]:
                    marks.cpus[(column, row)] = (cpus[0], cpus[1])
    return marks
