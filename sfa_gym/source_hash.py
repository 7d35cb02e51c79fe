"""SHA-256 of the package's Python sources: what a number was computed with.

A leaderboard sweep records the hash of the whole package when it starts, and each task
compares it with the sources it finds when it starts and when it ends (:func:`check_sources`): a
checkout edited under a running sweep, or a cluster node with other code, fails the task
instead of scoring it with a mix of versions (a long-lived worker keeps the modules it imported
before the edit and imports the edited ones).
"""

from __future__ import annotations

import hashlib
import platform
from pathlib import Path

__all__ = ["SourcesChangedError", "check_sources", "package_sources_sha256"]

_PACKAGE = Path(__file__).resolve().parent


class SourcesChangedError(RuntimeError):
    """The package's sources differ from those a sweep started with."""


def package_sources_sha256(package: Path | None = None) -> str:
    """SHA-256 of the ``*.py`` files of ``package`` (default: the imported ``sfa_gym``), read
    from disk now (not cached: a sweep compares it over time): each file's path relative to the
    package's parent folder and its content, in path order."""
    package = _PACKAGE if package is None else package
    digest = hashlib.sha256()
    for path in sorted(package.rglob("*.py")):
        digest.update(path.relative_to(package.parent).as_posix().encode() + b"\0")
        digest.update(path.read_bytes() + b"\0")
    return digest.hexdigest()


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
