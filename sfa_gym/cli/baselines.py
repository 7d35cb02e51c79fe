"""The baselines of the command line's protocols (``localize``, ``localize-run``,
``localize-outdoor``, ``navigate``): the feature-method plug-ins of a folder, each in a worker
process of its own that cannot read the output folder (its renders hold the poses) or the render
cache, stopped when the protocol is done."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from pathlib import Path
from typing import Any

__all__ = ["baseline_workers"]


@contextlib.contextmanager
def baseline_workers(
    out: Path, folder: Path | None, *, use_default: bool
) -> Iterator[list[tuple[Any, tuple[str, ...]]]]:
    """The methods of :func:`~sfa_gym.plugins.load_plugins` (``folder``, ``use_default``),
    with ``out`` (created here, so that it can be hidden) and the render cache hidden from
    their workers; every worker is stopped on leaving, whatever happened.

    Raises:
        ValueError: ``out`` is a file, or ``folder`` is not a folder.
    """
    from sfa_gym.cli.results import check_out_folder
    from sfa_gym.plugins import close_plugins, load_plugins
    from sfa_gym.recording.cache import default_cache_dir

    out = Path(out)
    check_out_folder(out)
    out.mkdir(parents=True, exist_ok=True)
    methods = load_plugins(folder, use_default=use_default, hidden=[out, default_cache_dir()])
    try:
        yield methods
    finally:
        close_plugins(methods)
