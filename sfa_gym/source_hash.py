"""SHA-256 of the package's Python sources: what a number was computed with.

Two uses. The render cache keys a run by the sources that make its pixels
(:func:`sfa_gym.recording.cache.rendering_code_sha256`). A leaderboard sweep records the hash
of the whole package when it starts, and each task compares it with the sources it finds when it
starts and when it ends (:func:`check_sources`): a checkout edited under a running sweep, or a
cluster node with other code, fails the task instead of scoring it with a mix of versions (a
long-lived worker keeps the modules it imported before the edit and imports the edited ones).
"""

from __future__ import annotations

import hashlib
import os
import platform
from collections.abc import Iterable
from pathlib import Path

__all__ = ["SourcesChangedError", "check_sources", "package_sources_sha256", "sources_sha256"]

_PACKAGE = Path(__file__).resolve().parent


class SourcesChangedError(RuntimeError):
    """The package's sources differ from those a sweep started with."""


def sources_sha256(root: str | os.PathLike[str], packages: Iterable[str], head: bytes = b"") -> str:
    """SHA-256 of ``head`` and of the ``*.py`` files of each of ``packages`` (folders under
    ``root``): each file's path relative to ``root`` and its content, in path order.

    Raises:
        FileNotFoundError: a package has no Python source under ``root``.
    """
    root = Path(root)
    digest = hashlib.sha256(head)
    for package in packages:
        sources = sorted((root / package).rglob("*.py"))
        if not sources:
            raise FileNotFoundError(f"no Python sources under {root / package}")
        for path in sources:
            digest.update(path.relative_to(root).as_posix().encode() + b"\0")
            digest.update(path.read_bytes() + b"\0")
    return digest.hexdigest()


def package_sources_sha256() -> str:
    """SHA-256 of every Python source of the imported ``sfa_gym``, read from disk now (not
    cached: a sweep compares it over time)."""
    return sources_sha256(_PACKAGE.parent, [_PACKAGE.name])


def check_sources(expected: str | None, when: str) -> None:
    """Raise :class:`SourcesChangedError` unless the package's sources hash to ``expected``
    (None: no check). ``when`` says at which point of the task the check ran."""
    if expected is None:
        return
    found = package_sources_sha256()
    if found != expected:
        raise SourcesChangedError(
            f"the sfa_gym sources at {_PACKAGE} on {platform.node()} {when} (sha256 "
            f"{found[:12]}) are not those the sweep started with ({expected[:12]}): the "
            "checkout was edited under the running sweep, or this node runs other code; the "
            "task's scores would mix code versions. Run the same command again once the "
            "sources are settled: it computes the failed tasks again"
        )
