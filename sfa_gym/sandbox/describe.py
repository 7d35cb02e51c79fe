"""What a plug-in file declares, read in a worker process: a sweep plans its tasks (labels, task
identities, argument checks) from this report and never imports the file itself.

The worker imports the file, fills its ``Args`` with the arguments given and, for a method, makes
it once (so that the factory's own checks run), then answers with JSON types
(:meth:`~sfa_gym.plugins.Plugin.describe`) and is stopped. The evaluator keeps what it can know
without the plug-in's word (the file, its stem as the name) and checks the shape of the rest.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from sfa_gym.plugin_files import Kind, PluginError, resolve_plugin
from sfa_gym.sandbox.process import PluginCrashed, PluginFailed, Worker

__all__ = ["describe_plugin"]


def describe_plugin(
    source: str | os.PathLike[str],
    kind: Kind,
    args: Mapping[str, Any] | None = None,
    *,
    limit: float,
    hidden: Sequence[str | os.PathLike[str]] = (),
) -> dict[str, Any]:
    """The report of the plug-in ``source`` of ``kind`` with ``args`` (see
    :meth:`~sfa_gym.plugins.Plugin.describe`), made in a worker process within ``limit``
    seconds.

    Args:
        source: a built-in name or a plug-in file.
        kind: ``"method"`` or ``"controller"``.
        args: keyword arguments of the plug-in's ``Args`` (JSON types).
        limit: seconds the worker may take (importing the file included).
        hidden: folders the worker must not read (the render cache, the results).

    Raises:
        FileNotFoundError: no such plug-in.
        ValueError: an argument the plug-in refuses (the message names the file and the
            argument).
        PluginError: the file fails to import, does not follow the contract, its worker died
            or sent a malformed report.
        PluginTimeout: the worker took longer than ``limit``.
    """
    path = resolve_plugin(source, kind)
    worker = Worker(str(path), hidden)
    request = {"describe": True, "path": str(path), "kind": kind, "args": dict(args or {})}
    try:
        report = worker.call(request, limit, "reading its Args")
    except (PluginCrashed, PluginFailed) as error:
        raise PluginError(str(error)) from None
    except (ValueError, TypeError) as error:
        if str(path) in str(error):
            raise
        raise type(error)(f"{path}: {error}") from None  # the user learns which file refused
    finally:
        worker.close()
    return _checked(report, path, kind)


def _checked(report: Any, path: Path, kind: Kind) -> dict[str, Any]:
    """The worker's report with the file and name the evaluator knows itself, or a PluginError
    for a report of the wrong shape."""
    ok = (
        isinstance(report, dict)
        and report.get("kind") == kind
        and all(
            isinstance(report.get(key), dict) and all(isinstance(k, str) for k in report[key])
            for key in ("arguments", "defaults")
        )
    )
    if not ok:
        raise PluginError(f"the worker of the plug-in {path} sent a malformed report: {report!r}")
    return {
        "kind": kind,
        "name": path.stem,
        "path": str(path),
        "arguments": report["arguments"],
        "defaults": report["defaults"],
    }
