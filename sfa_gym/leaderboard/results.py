"""Leaderboard results: one JSON file per (track, method, size), read and written (the table
built from them is :mod:`sfa_gym.leaderboard.table`).

A result file ``<results>/<track>/<method label>[.quick].json`` holds::

    {"format": "sfa-gym-leaderboard-result", "schema_version": 2,
     "track": {...the track file's content..., "quick": bool, "size_params": {...}},
     "method": {"name", "path", "sha256", "args"},
     "score": {"mean", "ci95": [lo, hi] | null, "interval": "t-clipped", "n", "std",
               "higher_is_better"},
     "tasks": [{"world_seed", "fit_world_seed", "scores": {...}, "seconds", "phases",
                "peak_rss_mb": {"evaluator", "plugins"}}, ...],
     "provenance": {"sfa_gym_version", "git_commit", "python", "platform", "machine",
                    "cpus", "backend", "created", "seconds", "versions", "cpu_numerics"}}

``versions`` are the installed versions of the locked packages (``constraints.txt``,
:mod:`sfa_gym.lock`) that computed the result, ``cpu_numerics`` what of the CPU decides the last
bits beside them (:func:`~sfa_gym.lock.cpu_numerics`); a navigation task's scores hold its episodes'
``fingerprint`` (:func:`~sfa_gym.protocols.navigation.episode_fingerprint`). The table marks the
results whose versions differ from the lock or whose fingerprints differ from the reference
result's (:mod:`sfa_gym.leaderboard.checks`).

The interval is a Student-t 95 % interval of the mean across the scoring world seeds, clipped
to the score's range (a success rate in [0, 1], an MAE >= 0), with fewer than three seeds none:
``null`` (:func:`~sfa_gym.leaderboard.verify.summarize`). Results of schema version 1 record
``"interval": "t"``, the unclipped interval from two seeds on; they are still read
(:data:`READ_SCHEMA_VERSIONS`), checked by the interval they record and shown with today's.
Scores are computed per world seed, so the result does not depend on which backend ran which
seed.

The committed reference results (:func:`reference_folder`, ``published/leaderboard/``) may also
be *gathered* files: ``{"description", "results": [...]}`` with one summary per track and method
(``track``, ``track_version``, ``quick``, ``method``, ``score``, ``per_world_seed``, ``parts``,
``git_commit``, ``versions``, ``fingerprints`` (``{world seed: fingerprint}``), navigation's
``spl`` (``{"mean", "per_world_seed"}``), ...;
:func:`gathered_entry` writes one). :func:`load_results` reads both kinds into the shape of a
result file, and the table shows each row's source: your results beside the reference ones.

Nothing read is trusted: each result (and each gathered entry) is checked field by field and its
mean, interval and ``n`` recomputed from the seeds' scores
(:func:`~sfa_gym.leaderboard.verify.check_result`), and a result file's place
(``<track>/<label>[.quick].json``) must agree with its track, size and method. A file that fails
is a :class:`~sfa_gym.leaderboard.verify.ResultError` naming it and what is wrong;
:func:`load_results` given a ``skipped`` list notes it there and reads on.
"""

from __future__ import annotations

import datetime
import json
import os
import platform
import subprocess
from pathlib import Path
from typing import Any

import numpy as np

import sfa_gym
from sfa_gym.files import write_json_atomic
from sfa_gym.leaderboard.verify import (
    ROUND_OFF,
    ResultError,
    check_result,
    content_sha256,
    summarize,
)

__all__ = [
    "FORMAT",
    "READ_SCHEMA_VERSIONS",
    "REFERENCE",
    "ROUND_OFF",
    "SCHEMA_VERSION",
    "ResultError",
    "YOURS",
    "check_result",
    "gathered_entry",
    "write_gathered",
    "git_commit",
    "load_results",
    "make_result",
    "mean_parts",
    "navigation_spl",
    "reference_folder",
    "result_path",
    "summarize",
]

FORMAT = "sfa-gym-leaderboard-result"
SCHEMA_VERSION = 2
"""The schema version of new result files: 2 records the clipped interval (``"t-clipped"``)."""
READ_SCHEMA_VERSIONS = (1, 2)
"""The schema versions read: 1 records the unclipped Student-t interval (``"t"``)."""
YOURS = "yours"
"""The source of the results a user ran (the results folder of ``sfa-gym leaderboard``)."""
REFERENCE = "reference"
"""The source of the committed reference results (:func:`reference_folder`)."""


def git_commit(path: str | os.PathLike[str] | None = None) -> str | None:
    """The commit of the checkout at ``path`` (default: the package's folder), ``+dirty`` if
    tracked files changed; None outside a git checkout or without git."""
    where = Path(path) if path is not None else Path(sfa_gym.__file__).resolve().parent
    try:
        head = subprocess.run(
            ["git", "rev-parse", "HEAD"], cwd=where, capture_output=True, text=True, timeout=10
        )
        if head.returncode != 0:
            return None
        dirty = subprocess.run(
            ["git", "status", "--porcelain", "--untracked-files=no"],
            cwd=where,
            capture_output=True,
            text=True,
            timeout=10,
        )
    except (OSError, subprocess.SubprocessError):
        return None
    return head.stdout.strip() + ("+dirty" if dirty.stdout.strip() else "")


def method_label(name: str, args: dict[str, Any], defaults: dict[str, Any]) -> str:
    """``name``, plus the arguments that differ from the defaults (``band_means[n_bands=4]``)."""
    changed = [f"{k}={args[k]}" for k in sorted(args) if args[k] != defaults.get(k)]
    return f"{name}[{','.join(changed)}]" if changed else name


def result_path(results: Path, track: str, label: str, quick: bool) -> Path:
    """Where the result of ``label`` on ``track`` is written."""
    safe = "".join(c if c.isalnum() or c in "-_=,.[]+" else "_" for c in label)
    return results / track / f"{safe}{'.quick' if quick else ''}.json"


def make_result(
    *,
    track: Any,
    quick: bool,
    method: dict[str, Any],
    tasks: list[dict[str, Any]],
    higher_is_better: bool,
    backend: str,
    seconds: float,
) -> dict[str, Any]:
    """The result object of one track and method (see the module docstring)."""
    from sfa_gym.lock import cpu_numerics, installed_versions

    tasks = sorted(tasks, key=lambda t: t["world_seed"])
    return {
        "format": FORMAT,
        "schema_version": SCHEMA_VERSION,
        # the size's own parameters: a quick section edited without a new track version gives
        # results of another size under the same version, which the table keeps apart
        "track": {**track.describe(), "quick": quick, "size_params": track.sized(quick)[1]},
        "method": method,
        "score": summarize([t["scores"]["score"] for t in tasks], higher_is_better),
        "tasks": tasks,
        "provenance": {
            "sfa_gym_version": sfa_gym.__version__,
            "git_commit": git_commit(),
            "python": platform.python_version(),
            "platform": platform.platform(),
            "machine": platform.machine(),
            "node": platform.node(),
            "cpus": os.cpu_count(),
            "backend": backend,
            "created": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
            "seconds": round(seconds, 2),
            "versions": installed_versions(),
            "cpu_numerics": cpu_numerics(),
        },
    }


def write_result(path: Path, result: dict[str, Any]) -> None:
    """Write ``result`` atomically (strict JSON), with its :func:`content_sha256`."""
    path.parent.mkdir(parents=True, exist_ok=True)
    write_json_atomic(path, {**result, "content_sha256": content_sha256(result)})


def reference_folder() -> Path:
    """The committed reference results: ``published/leaderboard`` of the checkout this sfa_gym
    runs from, else the copy inside the installed package.

    Raises:
        FileNotFoundError: neither exists (an incomplete installation).
    """
    from sfa_gym.data import data_folder

    return data_folder("published") / "leaderboard"


_GATHERED_FIELDS = ("track", "track_version", "quick", "method", "score", "per_world_seed")
_GATHERED_PROVENANCE = ("git_commit", "backend", "created", "versions", "cpu_numerics")
"""What a gathered entry keeps of a result's provenance."""


def _from_gathered(entry: Any, where: str, source: str) -> dict[str, Any]:
    """An entry of a gathered file in the shape of a result file, as far as the table reads it.

    A gathered entry keeps each seed's score but only the mean of each part, so the parts go
    into ``parts`` beside the tasks instead of into each task's scores.
    """
    missing = [k for k in _GATHERED_FIELDS if not isinstance(entry, dict) or k not in entry]
    if missing:
        raise ResultError(
            f"{where} lacks {missing}; expected an object with {list(_GATHERED_FIELDS)}"
        )
    for key, kind in (("track", str), ("method", str), ("quick", bool), ("per_world_seed", dict)):
        if not isinstance(entry[key], kind):
            raise ResultError(f"{where}: {key!r} is {entry[key]!r}; expected a {kind.__name__}")
    seeds = entry["per_world_seed"]
    if not all(isinstance(k, str) and k.lstrip("-").isdigit() for k in seeds):
        raise ResultError(f"{where}: 'per_world_seed' has keys {list(seeds)}; expected seeds")
    fingerprints = entry.get("fingerprints") or {}
    found_spl = entry.get("spl")
    if found_spl is not None and not (
        isinstance(found_spl, dict) and isinstance(found_spl.get("per_world_seed"), dict)
    ):
        raise ResultError(f"{where}: 'spl' is {found_spl!r}; expected {{'mean', 'per_world_seed'}}")
    spl = {} if found_spl is None else found_spl["per_world_seed"]
    return {
        "track": {
            "name": entry["track"],
            "quick": entry["quick"],
            "track_version": entry["track_version"],
        }
        | ({"size_params": entry["size_params"]} if "size_params" in entry else {}),
        "method": {"label": entry["method"], "sha256": entry.get("method_sha256")},
        "score": entry["score"],
        "tasks": [
            {
                "world_seed": int(seed),
                "scores": {"score": value}
                | ({"fingerprint": fingerprints[seed]} if seed in fingerprints else {})
                | ({"spl": spl[seed]} if seed in spl else {}),
            }
            for seed, value in seeds.items()
        ],
        "parts": entry.get("parts"),
        "provenance": {k: entry.get(k) for k in _GATHERED_PROVENANCE},
        "_source": source,
        # gathered again (publish), the entry is kept whole: its seconds, phases, isolation and
        # result hash cannot be rebuilt from the result-file shape above
        "_entry": entry,
    }


def gathered_entry(result: dict[str, Any]) -> dict[str, Any]:
    """The entry of a gathered file (see the module docstring) that keeps what the table reads
    of the result file ``result``: the score, each seed's score, the parts' means, the
    provenance, the package versions and the navigation tasks' episode fingerprints."""
    tasks = result["tasks"]
    provenance = result["provenance"]
    fingerprints = {
        str(t["world_seed"]): t["scores"]["fingerprint"]
        for t in tasks
        if "fingerprint" in t["scores"]
    }
    return {
        "track": result["track"]["name"],
        "track_version": result["track"]["track_version"],
        "quick": bool(result["track"]["quick"]),
        **(
            {"size_params": result["track"]["size_params"]}
            if "size_params" in result["track"]
            else {}
        ),
        "method": result["method"]["label"],
        "method_sha256": result["method"].get("sha256"),
        "score": result["score"],
        "per_world_seed": {str(t["world_seed"]): t["scores"]["score"] for t in tasks},
        "parts": mean_parts(result),
        **({"spl": spl} if (spl := navigation_spl(result)) is not None else {}),
        "task_seconds": [t.get("seconds") for t in tasks],
        "task_phases": [t.get("phases") for t in tasks],
        "task_peak_rss_mb": [t.get("peak_rss_mb") for t in tasks],
        "result_sha256": result.get("content_sha256"),
        "isolation": sorted({str(t.get("isolation")) for t in tasks}),
        **{k: provenance.get(k) for k in _GATHERED_PROVENANCE},
        **({"fingerprints": fingerprints} if fingerprints else {}),
    }


def write_gathered(
    results: str | os.PathLike[str], out: str | os.PathLike[str], description: str
) -> int:
    """Gather every result file under ``results`` into one gathered file ``out`` (see the module
    docstring; written atomically), the form in which reference results are published; returns
    the number of entries. The entries of a gathered file under ``results`` are kept as they are
    (checked like every result), so that a published file can be extended by a later run: copy
    it into the run's folder and publish again. A result file replaces the gathered entry of
    the same track, size and method (a published result run again, e.g. to record what it
    did not record then).

    Raises:
        ValueError: ``results`` holds no result file, two result files (or two gathered
            entries) of the same track, size and method (results of two runs mixed in one
            folder), or a result with a task
            whose plug-ins ran unconfined (``isolation`` "process" or "in-process": no
            bubblewrap, or :data:`~sfa_gym.leaderboard.evaluate.IN_PROCESS`), which the plug-in
            could have altered. A task that does not record its isolation (written before tasks
            did) is published; the entry says ``"None"``.
    """
    found = [r for r in load_results(results) if "_file" in r]
    if not found:
        raise ValueError(f"no leaderboard result files under {results}")
    loose = ("process", "in-process")
    unconfined = [
        r["_file"]
        for r in found
        if any(t.get("isolation") in loose for t in r["tasks"])
        or any(i in loose for i in r.get("_entry", {}).get("isolation", []))
    ]
    if unconfined:
        raise ValueError(
            f"{unconfined[0]} (and {len(unconfined) - 1} more) holds tasks whose plug-ins ran "
            "unconfined (no bubblewrap, or SFA_GYM_PLUGINS_IN_PROCESS=1): a plug-in there can "
            "read and rewrite what the evaluator can, so its results are not published; "
            "install bubblewrap (scripts/setup.sh does) and run again"
        )

    chosen = one_per_key(found, str(results))
    entries = [
        r["_entry"] if "_entry" in r else gathered_entry(r) for _, r in sorted(chosen.items())
    ]
    write_json_atomic(Path(out), {"description": description, "results": entries})
    return len(entries)


def result_key(result: dict[str, Any]) -> tuple[str, bool, str]:
    """What identifies a result on the board: its track, size (quick or not) and method."""
    return result["track"]["name"], bool(result["track"]["quick"]), result["method"]["label"]


def one_per_key(
    results: list[dict[str, Any]], where: str
) -> dict[tuple[str, bool, str], dict[str, Any]]:
    """``results`` (as :func:`load_results` reads them) by :func:`result_key`: a result file
    replaces the gathered entry of its key (a published result run again).

    Raises:
        ValueError: two result files, or two gathered entries, of one key (results of two runs
            mixed in one folder); the message names ``where`` and both files.
    """
    chosen: dict[tuple[str, bool, str], dict[str, Any]] = {}
    # gathered entries first, so that a result file of the same key replaces its entry
    for result in sorted(results, key=lambda r: "_entry" not in r):
        key = result_key(result)
        if key in chosen and ("_entry" in chosen[key]) == ("_entry" in result):
            raise ValueError(
                f"{where} holds more than one result of (track, quick, method) {key}: "
                f"{chosen[key].get('_file')} and {result.get('_file')}"
            )
        chosen[key] = result
    return chosen


def load_results(
    results: str | os.PathLike[str], source: str = YOURS, skipped: list[str] | None = None
) -> list[dict[str, Any]]:
    """Every result under ``results`` (recursively; or of the one file ``results``): result
    files and the entries of gathered files (see the module docstring), each checked
    (:func:`check_result`, and a result file's place against its content) and marked with
    ``source`` (``"_source"``) and its file (``"_file"``). Files of other sfa-gym formats (task
    files) are passed over. A folder that does not exist holds no results.

    Args:
        skipped: where to note each file or gathered entry that cannot be shown (a message
            naming it and what is wrong) and read on; None: raise at the first.

    Raises:
        ResultError: (``skipped`` None) a file that is not valid JSON, neither a result nor a
            gathered file, of another schema version, or whose content fails the checks.
    """
    root = Path(results)
    out = []
    for path in [root] if root.is_file() else sorted(root.rglob("*.json")):
        try:
            out += _read_file(path, source, skipped)
        except ResultError as error:
            if skipped is None:
                raise
            skipped.append(str(error))
    return out


def _read_file(path: Path, source: str, skipped: list[str] | None) -> list[dict[str, Any]]:
    """The checked results of one file (see :func:`load_results`)."""
    try:
        data = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as error:
        raise ResultError(f"{path} cannot be read as JSON: {error}") from None
    kind = data.get("format") if isinstance(data, dict) else None
    if isinstance(data, dict) and kind is None and isinstance(data.get("results"), list):
        out = []
        for i, entry in enumerate(data["results"]):
            where = f"{path}, entry {i}"
            try:
                out.append(check_result(_from_gathered(entry, where, source), where))
            except ResultError as error:
                if skipped is None:
                    raise
                skipped.append(str(error))
            else:
                out[-1]["_file"] = str(path)
        return out
    if isinstance(kind, str) and kind.startswith("sfa-gym-") and kind != FORMAT:
        return []  # another kind of sfa-gym file (task files): not a result
    if kind != FORMAT:
        raise ResultError(
            f"{path} is neither a result file (format {FORMAT!r}) nor a gathered file (an "
            "object with a 'results' list)"
        )
    if data.get("schema_version") not in READ_SCHEMA_VERSIONS:
        raise ResultError(
            f"{path}: result schema_version {data.get('schema_version')!r}; this sfa_gym "
            f"reads {list(READ_SCHEMA_VERSIONS)}"
        )
    check_result(data, str(path))
    track, quick, label = data["track"]["name"], data["track"]["quick"], data["method"]["label"]
    place = result_path(path.parents[1], track, label, quick)
    if place != path:
        raise ResultError(
            f"{path}: it holds track {track!r} at the {'quick' if quick else 'full'} size, "
            f"method {label!r}, whose file is {place.relative_to(path.parents[1])}; a result's "
            "folder and name must agree with its content"
        )
    data["_file"] = str(path)
    data["_source"] = source
    return [data]


def navigation_spl(result: dict[str, Any]) -> dict[str, Any] | None:
    """A navigation result's SPL (success weighted by path length, reported beside the success
    rate): ``{"mean", "per_world_seed": {seed: spl}}``; None when a task has none (other
    tracks)."""
    tasks = result["tasks"]
    if not tasks or not all("spl" in task["scores"] for task in tasks):
        return None
    per_seed = {str(t["world_seed"]): float(t["scores"]["spl"]) for t in tasks}
    return {"mean": float(np.mean(list(per_seed.values()))), "per_world_seed": per_seed}


def mean_parts(result: dict[str, Any]) -> dict[str, float] | None:
    """The mean of each part of the score over the world seeds (outdoor tracks: each condition,
    the unvisited region); None when the result's scores have no parts."""
    if result.get("parts") is not None:  # a gathered entry keeps only the means
        return result["parts"]
    tasks = result["tasks"]
    if not tasks or not all("parts" in task["scores"] for task in tasks):
        return None
    names = dict.fromkeys(p for task in tasks for p in task["scores"]["parts"])
    out = {}
    for part in names:
        values = [task["scores"]["parts"].get(part) for task in tasks]
        values = [v for v in values if v is not None]
        if values:
            out[part] = float(np.mean(values))
    return out
