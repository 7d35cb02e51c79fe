"""MkDocs hook: the leaderboard's results page, generated at build time from the committed
result files (``published/leaderboard/``), so that no page of docs/ holds a copied number;
and the nav entry ``notes/``, which stands for every page of ``docs/notes/``."""

from __future__ import annotations

from pathlib import Path

from mkdocs.structure.files import File

RESULTS_PAGE = "leaderboard/results.md"


def _expand_folders(nav: list, docs_dir: Path) -> list:
    """Nav entries whose page is a folder (``notes/``): the folder's pages, sorted by name."""
    out = []
    for entry in nav:
        if isinstance(entry, dict):
            ((title, value),) = entry.items()
            if isinstance(value, str) and value.endswith("/"):
                pages = sorted(p.relative_to(docs_dir).as_posix() for p in (docs_dir / value).glob("*.md"))
                value = pages
            elif isinstance(value, list):
                value = _expand_folders(value, docs_dir)
            entry = {title: value}
        out.append(entry)
    return out


def on_config(config):
    config["nav"] = _expand_folders(config["nav"], Path(config["docs_dir"]))
    return config


def on_files(files, config):
    from sfa_gym.leaderboard.html import results_page

    files.append(File.generated(config, RESULTS_PAGE, content=results_page()))
    return files
