"""``sfa-gym docs-tables [--check]``: regenerate the tables of README.md and docs/ from the
committed result files, or check that they match them (:mod:`sfa_gym.report.tables`)."""

from __future__ import annotations

import sys
from dataclasses import dataclass
from pathlib import Path

__all__ = ["DocsTables"]


@dataclass(frozen=True)
class DocsTables:
    """Rewrite every generated table (between <!-- generated: ... --> and
    <!-- end generated -->) from its result files; with --check, change nothing and exit 1
    naming the page, the table and the first differing number."""

    check: bool = False
    """only compare; exit status 1 when a table differs from its result files"""
    root: Path | None = None
    """repository root holding README.md, docs/ and published/ (default: this checkout)"""
    pages: tuple[Path, ...] = ()
    """pages to process (default: README.md and docs/**/*.md under the root)"""

    def run(self) -> int:
        from sfa_gym.report.tables import (
            check_pages,
            default_pages,
            repository_root,
            update_pages,
        )

        root = self.root or repository_root()
        pages = list(self.pages) or default_pages(root)
        if self.check:
            mismatches = check_pages(pages, root)
            for mismatch in mismatches:
                print(mismatch, file=sys.stderr)
            return 1 if mismatches else 0
        for page in update_pages(pages, root):
            print(f"rewrote {page}")
        return 0
