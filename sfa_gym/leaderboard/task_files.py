"""Task files: the outcome of each (track, method, world seed) task, written atomically as soon
as the task finishes, so that a sweep stopped for any reason (a failing plug-in, Ctrl-C,
SIGTERM, SIGKILL, a dead Ray worker) keeps every finished task and a rerun resumes from them.

``<results>/tasks/<track>/<method label>[.quick]/<world seed>.json`` holds::

    {"format": "sfa-gym-leaderboard-task", "schema_version": 1,
     "identity": {"track": {"name", "track_version", "sha256"}, "quick", "world_seed",
                  "method": {"name", "sha256", "args"}, "controller": null | {...}},
     "output": {"world_seed", "fit_world_seed", "scores", "seconds", "phases",
                "peak_rss_mb"} | null,
     "failure": {"type", "message", "attempts"} | null,
     "provenance": {"sfa_gym_version", "git_commit", "code_sha256", "backend", "node",
                    "created"}}

A rerun reuses a task's output only when the file's ``identity`` is the task's: the same track
version and content at the task's size (``sha256`` of the track file's content with the
parameters and world seeds of that size, its description aside: editing the quick section does
not invalidate the full size's tasks), the same
method file (its SHA-256) with the same arguments (all of them, the defaults filled in), the
same world seed, size and controller. A file of another track version or method file, a
failure, or a damaged file is computed again and overwritten.
"""

from __future__ import annotations

import contextlib
import datetime
import hashlib
import json
import os
import platform
import tempfile
from pathlib import Path
from typing import Any

import sfa_gym
from sfa_gym.files import write_json_atomic
from sfa_gym.leaderboard.results import result_path
from sfa_gym.leaderboard.tracks import Track

__all__ = [
    "TASKS_FOLDER",
    "TASK_FORMAT",
    "check_results_folder",
    "read_finished",
    "task_file",
    "task_identity",
    "task_provenance",
    "write_task_file",
]

TASK_FORMAT = "sfa-gym-leaderboard-task"
TASK_SCHEMA_VERSION = 1
TASKS_FOLDER = "tasks"
"""The folder of the task files inside the results folder."""


def _plugin_identity(described: dict[str, Any]) -> dict[str, Any]:
    """What of a plug-in decides its scores: its code (SHA-256) and all its arguments."""
    return {
        "name": described["name"],
        "sha256": described["sha256"],
        "args": described["all_args"],
    }


def task_identity(
    track: Track,
    quick: bool,
    world_seed: int,
    method: dict[str, Any],
    controller: dict[str, Any] | None,
) -> dict[str, Any]:
    """What decides a task's scores, in JSON types (see the module docstring); ``method`` and
    ``controller`` are the sweep's descriptions of the plug-ins (``name``, ``sha256``,
    ``all_args``)."""
    # the track as it decides this size's scores: its quick section matters only at the quick
    # size, and there only through the parameters and world seeds it gives
    # the limits bound what a plug-in may spend, not what it scores: they are left out
    apart = ("description", "quick", "params", "time_limits", "memory_limit_mb")
    content = {k: v for k, v in track.describe().items() if k not in apart}
    content["world_seeds"], content["params"] = track.sized(quick)
    identity = {
        "track": {
            "name": track.name,
            "track_version": track.track_version,
            "sha256": hashlib.sha256(json.dumps(content, sort_keys=True).encode()).hexdigest(),
        },
        "quick": quick,
        "world_seed": world_seed,
        "method": _plugin_identity(method),
        "controller": None if controller is None else _plugin_identity(controller),
    }
    # as a file holds it (tuples become lists), so that it compares equal to a file's
    return json.loads(json.dumps(identity))


def task_file(results: Path, track: str, label: str, quick: bool, world_seed: int) -> Path:
    """Where the task of ``label`` on ``track`` at ``world_seed`` is written."""
    pair = result_path(results / TASKS_FOLDER, track, label, quick)
    return pair.with_suffix("") / f"{world_seed}.json"


def task_provenance(
    backend: str, git_commit: str | None, code_sha256: str | None = None
) -> dict[str, Any]:
    """Where and when a task was run: the package version, commit and sources' hash
    (:func:`~sfa_gym.source_hash.package_sources_sha256`, which tells an uncommitted edit from
    its commit), the backend, the machine that wrote the file, the time."""
    return {
        "sfa_gym_version": sfa_gym.__version__,
        "git_commit": git_commit,
        "code_sha256": code_sha256,
        "backend": backend,
        "node": platform.node(),
        "created": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
    }


def write_task_file(
    path: Path,
    identity: dict[str, Any],
    output: dict[str, Any] | None,
    failure: dict[str, Any] | None,
    provenance: dict[str, Any],
) -> dict[str, Any]:
    """Write a task's outcome (its ``output``, or its ``failure``) atomically; returns the
    record written."""
    record = {
        "format": TASK_FORMAT,
        "schema_version": TASK_SCHEMA_VERSION,
        "identity": identity,
        "output": output,
        "failure": failure,
        "provenance": provenance,
    }
    path.parent.mkdir(parents=True, exist_ok=True)
    write_json_atomic(path, record)
    return record


def _first_difference(found: Any, expected: dict[str, Any]) -> str:
    if not isinstance(found, dict):
        return "no identity"
    for key, value in expected.items():
        if isinstance(value, dict) and isinstance(found.get(key), dict):
            inner = _first_difference(found[key], value)
            if inner:
                return f"{key}.{inner}"
        elif found.get(key) != value:
            return key
    return "" if found.keys() == expected.keys() else "other fields"


def read_finished(path: Path, identity: dict[str, Any]) -> tuple[dict[str, Any] | None, str]:
    """The record of the finished task at ``path`` if it can be reused for ``identity``, else
    None and why not (``""``: no file yet)."""
    if not path.exists():
        return None, ""
    try:
        record = json.loads(path.read_text())
    except (OSError, ValueError) as error:
        return None, f"unreadable ({error})"
    if not isinstance(record, dict) or record.get("format") != TASK_FORMAT:
        return None, "not a task file"
    if record.get("schema_version") != TASK_SCHEMA_VERSION:
        return None, f"task file schema_version {record.get('schema_version')!r}"
    different = _first_difference(record.get("identity"), identity)
    if different:
        return None, f"stale: its {different} differs"
    if record.get("failure") is not None or not isinstance(record.get("output"), dict):
        return None, "failed before"
    return record, ""


def check_results_folder(folder: str | os.PathLike[str]) -> Path:
    """Create ``folder`` if need be and check that a file can be written in it (before any task
    runs, not after the first one finished).

    Raises:
        OSError: the folder cannot be created or written to; the message names it.
    """
    folder = Path(folder)
    try:
        folder.mkdir(parents=True, exist_ok=True)
        fd, probe = tempfile.mkstemp(dir=folder, prefix=".write-check.", suffix=".tmp")
        os.close(fd)
        with contextlib.suppress(FileNotFoundError):
            os.unlink(probe)
    except OSError as error:
        raise OSError(
            f"the results folder {str(folder)!r} cannot be written to ({error.strerror or error});"
            " choose a folder you can write to"
        ) from None
    return folder
