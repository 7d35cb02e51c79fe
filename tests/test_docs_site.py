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


# the table as the browser shows it: the header texts and each row's cell texts
_READ_TABLE = """
const table = document.querySelector("table[data-sortable]");
return {
  heads: Array.from(table.tHead.rows[0].cells, c => c.querySelector("button").innerText.trim()),
  rows: Array.from(table.tBodies[0].rows, r => Array.from(r.cells, c => c.innerText.trim())),
};
"""


def test_the_results_page_shows_every_score_and_sorts_by_a_column(site):
    results = load_results(reference_folder(), REFERENCE)
    assert len(results) > 10
    driver = _browser()
    try:
        driver.get((site / "leaderboard" / "results" / "index.html").as_uri())
        table = driver.execute_script(_READ_TABLE)
        heads = table["heads"]
        rows = {(cells[0], cells[1]): cells for cells in table["rows"]}
        assert len(rows) == len({r["method"]["label"] for r in results})
        for r in results:
            column = heads.index(r["track"]["name"] + (" (quick)" if r["track"]["quick"] else ""))
            shown = rows[(r["method"]["label"], "reference")][column]
            mean, interval = r["score"]["mean"], r["score"]["ci95"]
            assert shown.split()[0] == f"{mean:.2f}", (r["track"], r["method"], shown)
            if interval:
                assert f"{interval[0]:.2f} to {interval[1]:.2f}" in shown

        # sort by a track where some method has no score: ascending, again descending
        track = "outdoor_paper (quick)"
        column = heads.index(track)
        means = {
            r["method"]["label"]: r["score"]["mean"]
            for r in results
            if r["track"]["name"] == "outdoor_paper"
        }
        assert 1 < len(means) < len(rows)
        button = driver.find_elements("css selector", "table[data-sortable] thead th button")
        for descending in (False, True):
            button[column].click()
            order = [cells[0] for cells in driver.execute_script(_READ_TABLE)["rows"]]
            scored = sorted(means, key=means.get, reverse=descending)
            # the methods without a score on the track go last either way
            assert order[: len(scored)] == scored
            assert set(order[len(scored) :]) == {method for method, _ in rows} - set(means)
    finally:
        driver.quit()
