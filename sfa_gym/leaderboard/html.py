"""The leaderboard as HTML: a table sortable by any column and the chart, from the result files.

The docs' leaderboard results page (:func:`results_page`) is generated at build time by the
MkDocs hook ``docs/hooks/leaderboard.py``, from the same
:func:`~sfa_gym.leaderboard.table.arrange` as the markdown table of ``sfa-gym leaderboard
table``, so the page shows what the table shows. The HTML needs nothing from the network: the
sorting is a few lines of plain JavaScript in the page, the chart an inline SVG.
"""

from __future__ import annotations

import io
import os
from html import escape
from pathlib import Path
from typing import Any

from sfa_gym.intervals import format_interval
from sfa_gym.leaderboard.results import REFERENCE, load_results, reference_folder
from sfa_gym.leaderboard.table import Board, arrange, current_tracks, detail_tables, draw_chart

__all__ = ["board_html", "chart_svg", "results_page", "sorting"]

# Sorts the rows of every table marked data-sortable by the column whose header button is
# pressed: by the cells' data-value, as numbers where both are numbers; empty cells last.
_SORT_SCRIPT = """<script>
document.querySelectorAll("table[data-sortable]").forEach(function (table) {
  table.querySelectorAll("thead th").forEach(function (th) {
    var button = th.querySelector("button");
    if (!button) return;
    button.addEventListener("click", function () {
      var column = th.cellIndex;
      var ascending = th.getAttribute("aria-sort") !== "ascending";
      table.querySelectorAll("thead th").forEach(function (h) {
        h.removeAttribute("aria-sort");
      });
      th.setAttribute("aria-sort", ascending ? "ascending" : "descending");
      var body = table.tBodies[0];
      var rows = Array.prototype.slice.call(body.rows);
      rows.sort(function (a, b) {
        var x = a.cells[column].getAttribute("data-value");
        var y = b.cells[column].getAttribute("data-value");
        if (x === "" || y === "") return (x === "") - (y === "");
        var nx = Number(x), ny = Number(y);
        var order = isNaN(nx) || isNaN(ny) ? x.localeCompare(y) : nx - ny;
        return ascending ? order : -order;
      });
      rows.forEach(function (row) { body.appendChild(row); });
    });
  });
});
</script>"""

_STYLE = """<style>
table[data-sortable] th button { font: inherit; font-weight: bold; background: none;
  border: none; padding: 0; cursor: pointer; color: inherit; text-align: left; }
table[data-sortable] th[aria-sort="ascending"] button::after { content: " \\25B2"; }
table[data-sortable] th[aria-sort="descending"] button::after { content: " \\25BC"; }
table[data-sortable] td small { opacity: 0.7; white-space: nowrap; }
.sfa-chart svg { max-width: 100%; height: auto; }
</style>"""


def _score_cell(result: dict[str, Any] | None) -> str:
    if result is None:
        return '<td data-value="">-</td>'
    score = result["score"]
    seeds = ", ".join(f"{seed}: {value:.3f}" for seed, value in result["per_world_seed"].items())
    interval = f"<br><small>{format_interval(score['ci95'], score['n'])}</small>"
    return (
        f'<td data-value="{score["mean"]!r}" title="world seeds: {escape(seeds)}">'
        f"{score['mean']:.2f}{interval}</td>"
    )


def _table(board: Board) -> str:
    def header(text: str, note: str = "") -> str:
        small = f"<br><small>{escape(note)}</small>" if note else ""
        return f'<th scope="col"><button type="button">{escape(text)}</button>{small}</th>'

    heads = [header("method"), header("source")] + [
        header(t, "higher is better" if board.higher_is_better(t) else "lower is better")
        for t in board.tracks
    ]
    lines = ["<table data-sortable>", "<thead><tr>" + "".join(heads) + "</tr></thead>", "<tbody>"]
    for row in board.rows:
        method, source = (escape(part) for part in row)
        cells = [
            f'<td data-value="{method}">{method}</td>',
            f'<td data-value="{source}">{source}</td>',
        ] + [_score_cell(board.cells[t].get(row)) for t in board.tracks]
        lines.append("<tr>" + "".join(cells) + "</tr>")
    lines += ["</tbody>", "</table>"]
    return "\n".join(lines)


def chart_svg(board: Board) -> str:
    """The chart of :func:`~sfa_gym.leaderboard.table.draw_chart` as inline SVG (text kept
    as text, no date, so that the same results give the same SVG)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    with matplotlib.rc_context({"svg.fonttype": "none", "svg.hashsalt": "sfa-gym"}):
        fig = draw_chart(board)
        buffer = io.StringIO()
        fig.savefig(buffer, format="svg", metadata={"Date": None})
        plt.close(fig)
    svg = buffer.getvalue()
    # inline: no XML declaration or doctype; no blank line, which would end a markdown HTML block
    svg = svg[svg.index("<svg") :]
    return "\n".join(line for line in svg.splitlines() if line.strip())


def board_html(board: Board) -> str:
    """The table and the chart of ``board``: an HTML fragment without blank lines (so that
    markdown passes it through whole). The table sorts by a column when the page holds
    :func:`sorting` after it."""
    return "\n".join(
        ['<div class="sfa-board">', _table(board), '<div class="sfa-chart">']
        + [chart_svg(board), "</div>", "</div>"]
    )


def sorting() -> str:
    """The style and the script that make the tables of :func:`board_html` sortable; once a
    page (twice, a press would sort twice), after the tables."""
    return _STYLE + "\n" + _SORT_SCRIPT


def _shown_path(path: str | os.PathLike[str]) -> str:
    """``path`` relative to the checkout (``published/leaderboard/quick.json``) where it can
    be, so that the page does not name the machine that built it."""
    from sfa_gym.data import checkout_root

    root = checkout_root()
    resolved = Path(path).resolve()
    if root is not None and resolved.is_relative_to(root):
        return resolved.relative_to(root).as_posix()
    return resolved.name


def results_page(folder: str | os.PathLike[str] | None = None) -> str:
    """The markdown of the docs' leaderboard results page: the results under ``folder``
    (default: the committed reference results, :func:`~sfa_gym.leaderboard.results.
    reference_folder`): for the full-size board and the quick board (the boards of the tracks'
    full and quick sizes, each where there are results), a sortable table and the chart, then
    the parts of the outdoor tracks' scores and each track's version, world seeds and commit.

    Raises:
        ValueError: no results under ``folder``.
    """
    folder = Path(folder) if folder is not None else reference_folder()
    results = load_results(folder, REFERENCE)
    if not results:
        raise ValueError(f"no leaderboard results under {folder}")
    files = sorted({Path(r["_file"]).relative_to(folder).as_posix() for r in results})
    named = ", ".join(f"`{f}`" for f in files) if len(files) <= 4 else f"{len(files)} files"
    lines = [
        # the wide table wants the room of the page's table of contents (Material theme)
        "---",
        "hide:",
        "  - toc",
        "---",
        "",
        "# Leaderboard results",
        "",
        f"The reference results, read from `{_shown_path(folder)}/` ({named}) when this site "
        "was built. Each cell is the mean score over the track's scoring world seeds, with "
        "the Student-t 95 % interval across them below it, clipped to the score's range "
        "(with fewer than three seeds, their number instead: n=2); hover a cell for each "
        "seed's score. Localization: MAE in % of the coordinate range, mean of x and y "
        "(lower is better); navigation: success rate (higher is better). Press a column's "
        "header to sort by it.",
    ]
    tracks = current_tracks()  # results of another track version or seed set go in columns apart
    for quick, title in ((False, "The board"), (True, "The quick board")):
        size = [r for r in results if r["quick"] == quick]
        if not size:
            continue
        board = arrange(size, tracks)
        what = "fewer world seeds, smaller grids" if quick else "the tracks' full size"
        lines += ["", f"## {title}", "", f"{what.capitalize()}.", "", board_html(board), ""]
        lines += [f"### {title}: the parts of the scores and the tracks", *detail_tables(board)]
    return "\n".join(lines + ["", sorting(), ""])
