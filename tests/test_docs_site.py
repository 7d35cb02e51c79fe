"""The documentation site: ``mkdocs build --strict`` passes (a docstring the API reference cannot
read fails it), and the leaderboard results page, generated from the committed result files,
shows every method's score in a real browser (Debian's headless Chromium) and sorts by a column.
"""

from __future__ import annotations

import importlib.util
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from sfa_gym.intervals import format_interval
from sfa_gym.leaderboard.results import REFERENCE, load_results, reference_folder

ROOT = Path(__file__).resolve().parents[1]
# Debian's chromium and chromium-driver packages (scripts/setup.sh test installs them)
CHROMIUM = shutil.which("chromium") or "/usr/bin/chromium"
CHROMEDRIVER = shutil.which("chromedriver") or "/usr/bin/chromedriver"


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    """The site, built once for the tests of this module."""
    if importlib.util.find_spec("mkdocs") is None:
        pytest.skip("mkdocs is not installed: pip install -e '.[docs]' (or scripts/setup.sh test)")
    out = tmp_path_factory.mktemp("site")
    done = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "-f", str(ROOT / "mkdocs.yml")]
        + ["-d", str(out)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        env={**os.environ, "NO_MKDOCS_2_WARNING": "1"},
        timeout=600,
    )
    assert done.returncode == 0, done.stderr[-4000:]
    return out


def test_the_site_builds_strictly_with_the_api_reference_and_the_results_page(site):
    for page in ("sfa", "protocols", "localization", "navigation", "recording", "sim"):
        assert (site / "api" / page / "index.html").is_file()
    api = (site / "api" / "leaderboard" / "index.html").read_text()
    # the reference is rendered from the docstrings, not only the page's title
    assert 'id="sfa_gym.leaderboard.results.load_results"' in api
    # the docstrings' Sphinx roles are shown as code, not as written
    assert "<code>load_results</code>" in api and ":func:<code>" not in api
    # every note is in the nav, which names the folder only
    for note in (ROOT / "docs" / "notes").glob("*.md"):
        folder = "" if note.stem == "index" else f"{note.stem}/"
        assert f'href="notes/{folder}"' in (site / "index.html").read_text()
    page = (site / "leaderboard" / "results" / "index.html").read_text()
    assert "published/leaderboard/" in page and "<svg" in page
    assert not (site / "hooks").exists()  # the hook is code of the build, not a page


def _browser():
    if not (Path(CHROMIUM).is_file() and Path(CHROMEDRIVER).is_file()):
        pytest.skip(
            "Debian's chromium and chromium-driver are not installed "
            "(apt-get install chromium chromium-driver, or bash scripts/setup.sh test)"
        )
    if importlib.util.find_spec("selenium") is None:
        pytest.skip("selenium is not installed: pip install -e '.[test]'")
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for argument in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage"):
        options.add_argument(argument)
    # the driver given by path: Selenium then never tries to download one
    return webdriver.Chrome(service=Service(executable_path=CHROMEDRIVER), options=options)


# the tables as the browser shows them: each one's header texts and its rows' cell texts
_READ_TABLES = """
return Array.from(document.querySelectorAll("table[data-sortable]"), table => ({
  heads: Array.from(table.tHead.rows[0].cells, c => c.querySelector("button").innerText.trim()),
  rows: Array.from(table.tBodies[0].rows, r => Array.from(r.cells, c => c.innerText.trim())),
}));
"""


def _column(result: dict) -> str:
    return result["track"] + (" (quick)" if result["quick"] else "")


def _means(results: list[dict], column: str) -> dict[str, float]:
    return {r["method"]: r["score"]["mean"] for r in results if _column(r) == column}


def test_the_results_page_shows_every_score_and_sorts_by_a_column(site):
    results = load_results(reference_folder(), REFERENCE)
    assert len(results) > 10
    driver = _browser()
    try:
        driver.get((site / "leaderboard" / "results" / "index.html").as_uri())
        tables = driver.execute_script(_READ_TABLES)
        # the full-size board and the quick board, each where there are results
        assert len(tables) == len({r["quick"] for r in results})
        for r in results:
            (table,) = [table for table in tables if _column(r) in table["heads"]]
            rows = {(cells[0], cells[1]): cells for cells in table["rows"]}
            shown = rows[(r["method"], "reference")][table["heads"].index(_column(r))]
            mean, interval = r["score"]["mean"], r["score"]["ci95"]
            assert shown.split()[0] == f"{mean:.2f}", (_column(r), r["method"], shown)
            assert format_interval(interval, r["score"]["n"]) in shown

        # sort by the first track whose order by score is not the rows' order (by method):
        # ascending, then again, descending; methods without a score on it go last either way
        table = tables[0]
        methods = [cells[0] for cells in table["rows"]]

        def sorted_on(track: str) -> list[str]:
            means = _means(results, track)
            return sorted(means, key=means.get) + [m for m in methods if m not in means]

        track = next((h for h in table["heads"][2:] if sorted_on(h) != methods), None)
        assert track is not None, "every track's scores are in the order of the method names"
        column, means = table["heads"].index(track), _means(results, track)
        first = driver.find_element("css selector", "table[data-sortable]")
        buttons = first.find_elements("css selector", "thead th button")
        for descending in (False, True):
            buttons[column].click()
            order = [cells[0] for cells in driver.execute_script(_READ_TABLES)[0]["rows"]]
            scored = sorted(means, key=means.get, reverse=descending)
            assert order[: len(scored)] == scored, track
            assert set(order[len(scored) :]) == set(methods) - set(means)
    finally:
        driver.quit()
