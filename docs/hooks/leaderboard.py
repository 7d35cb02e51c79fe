"""MkDocs hook (``hooks:`` in mkdocs.yml).

- The leaderboard's results page (``leaderboard/results.md``) is generated at build time from
  the committed result files (``published/leaderboard/``) by
  :func:`sfa_gym.leaderboard.html.results_page`, so that no page of docs/ holds a copied number.
- A nav entry whose page is a folder (``Notes: notes/``) stands for every page of that folder,
  its ``index.md`` first, so that a new note needs no edit of mkdocs.yml.
- The Sphinx roles of the docstrings (``:func:`~sfa_gym.data.data_folder```), which the API
  reference would show as they are written, are shown as code: the name, only its last part
  after ``~`` as Sphinx does.
"""

from __future__ import annotations

import re
from pathlib import Path

from mkdocs.structure.files import File

RESULTS_PAGE = "leaderboard/results.md"
# a role as the docstring renderer leaves it: the role's name, then the target as code
_ROLE = re.compile(r":(?:mod|func|class|meth|data|attr|exc|obj):<code>(~?)([^<]+)</code>")


def _folder_pages(docs_dir: Path, folder: str) -> list[str]:
    pages = sorted(p.relative_to(docs_dir).as_posix() for p in (docs_dir / folder).glob("*.md"))
    return sorted(pages, key=lambda page: not page.endswith("/index.md"))


def _expand_folders(nav: list, docs_dir: Path) -> list:
    out = []
    for entry in nav:
        if isinstance(entry, dict):
            ((title, value),) = entry.items()
            if isinstance(value, str) and value.endswith("/"):
                value = _folder_pages(docs_dir, value)
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


def on_page_content(html, page, config, files):
    return _ROLE.sub(lambda m: f"<code>{m[2].rsplit('.', 1)[-1] if m[1] else m[2]}</code>", html)
