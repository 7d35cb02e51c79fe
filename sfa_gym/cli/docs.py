"""``sfa-gym docs-tables [--check]``: regenerate the tables of README.md and docs/ from the
committed result files, or check that they match them. The generators live in the checkout's
``eval/tables/``, outside the installed package: the command works in a checkout only."""

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
    """repository root holding README.md, docs/, published/ and eval/ (default: this checkout)"""
    pages: tuple[Path, ...] = ()
    """pages to process (default: README.md and docs/**/*.md under the root)"""

    def run(self) -> int:
        root = (self.root or Path(__file__).resolve().parents[2]).resolve()
        if not (root / "eval" / "tables" / "tables.py").is_file():
            raise SystemExit(
                f"error: {root} is not an sfa-gym checkout (no eval/tables/tables.py); "
                "docs-tables regenerates a checkout's docs: pass --root CHECKOUT"
            )
        # the generators are the checkout's, not the installed package's: the root named (or
        # the checkout this package runs from) is the one folder imported from
        sys.path.insert(0, str(root))
        from eval.tables.tables import check_pages, default_pages, update_pages

        pages = list(self.pages) or default_pages(root)
        if self.check:
            mismatches = check_pages(pages, root)
            for mismatch in mismatches:
                print(mismatch, file=sys.stderr)
            return 1 if mismatches else 0
        for page in update_pages(pages, root):
            print(f"rewrote {page}")
        return 0
