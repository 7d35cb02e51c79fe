"""Which plug-in folder ``sfa-gym localize`` loads: the one the user named, the checkout's
``baselines/``, the plug-ins shipped inside the package, or none; never a ``baselines`` folder
that happens to lie next to the installed package."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

import sfa_gym
from sfa_gym.plugins import (
    PluginError,
    checkout_root,
    close_plugins,
    default_plugin_folder,
    load_plugins,
)

ROOT = Path(__file__).resolve().parents[1]

EVIL = """
from pathlib import Path
Path(__file__).with_name("IMPORTED").write_text("imported")
"""


@pytest.fixture
def site_packages(tmp_path):
    """A site-packages folder with ``sfa_gym`` installed and another distribution's
    ``baselines`` folder beside it, whose file records being imported."""
    site = tmp_path / "site-packages"
    (site / "sfa_gym").mkdir(parents=True)
    (site / "baselines").mkdir()
    (site / "baselines" / "evil.py").write_text(EVIL)
    return site


def test_a_baselines_folder_next_to_the_installed_package_is_never_imported(site_packages, capsys):
    package = site_packages / "sfa_gym"
    assert checkout_root(package) is None
    folder, _ = default_plugin_folder(package)
    assert folder is None
    assert load_plugins(None, package_dir=package) == []
    assert not (site_packages / "baselines" / "IMPORTED").exists()
    err = capsys.readouterr().err
    assert "no baselines" in err and "--baselines" in err  # says so, and what to do


def test_outside_a_checkout_the_plugins_shipped_with_the_package_are_used(site_packages, capsys):
    package = site_packages / "sfa_gym"
    shipped = package / "plugins_data"
    shipped.mkdir()
    shutil.copy(ROOT / "baselines" / "band_means.py", shipped)
    assert default_plugin_folder(package)[0] == shipped
    methods = load_plugins(None, package_dir=package)
    assert [method.name for method, _ in methods] == ["band_means"]
    assert methods[0][1] == ("linear", "quadratic", "map")
    assert not (site_packages / "baselines" / "IMPORTED").exists()
    assert str(shipped) in capsys.readouterr().err


def test_only_a_checkout_of_this_project_counts(tmp_path):
    repo = tmp_path / "repo"
    (repo / "sfa_gym").mkdir(parents=True)
    (repo / "baselines").mkdir()
    (repo / "pyproject.toml").write_text('[project]\nname = "another-project"\n')
    assert checkout_root(repo / "sfa_gym") is None
    assert default_plugin_folder(repo / "sfa_gym")[0] is None
    (repo / "pyproject.toml").write_text('[project]\nname = "sfa-gym"\n')
    assert checkout_root(repo / "sfa_gym") == repo
    assert default_plugin_folder(repo / "sfa_gym")[0] == repo / "baselines"


def test_in_this_checkout_the_default_is_its_baselines_folder(capsys):
    assert Path(sfa_gym.__file__).resolve().parent == ROOT / "sfa_gym"
    assert default_plugin_folder()[0] == ROOT / "baselines"
    methods = load_plugins(None)
    try:
        names = sorted(method.name for method, _ in methods)
    finally:
        close_plugins(methods)
    assert names == ["band_means", "fft_magnitude", "pca", "raw_pixels"]
    assert "left out (minutes of training each)" in capsys.readouterr().err
    # named, their folder's methods all run
    methods = load_plugins(ROOT / "baselines")
    try:
        assert {"deep_sfa", "contrastive"} <= {method.name for method, _ in methods}
    finally:
        close_plugins(methods)


def test_a_plugin_that_needs_a_missing_extra_is_left_out_saying_so(tmp_path, capsys):
    folder = tmp_path / "plugins"
    folder.mkdir()
    shutil.copy(ROOT / "baselines" / "band_means.py", folder)
    # what the deep methods raise where torch is not installed
    (folder / "deep.py").write_text(
        "raise ImportError(\"needs torch: pip install 'sfa-gym[deep]'\")\n"
    )
    methods = load_plugins(folder)
    try:
        assert [method.name for method, _ in methods] == ["band_means"]
    finally:
        close_plugins(methods)
    assert "deep.py left out: it needs sfa-gym[deep]" in capsys.readouterr().err
    # any other failure to import is still an error
    (folder / "deep.py").write_text("raise ImportError('no such thing')\n")
    with pytest.raises(PluginError, match="no such thing"):
        load_plugins(folder)


def test_a_named_folder_must_exist(tmp_path):
    with pytest.raises(ValueError, match="is not a folder"):
        load_plugins(tmp_path / "missing")
    (tmp_path / "mine").mkdir()
    assert load_plugins(tmp_path / "mine") == []


def test_an_installed_wheel_uses_its_shipped_plugins_and_not_a_foreign_baselines(tmp_path):
    wheels = tmp_path / "wheels"
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(wheels), str(ROOT)],
        check=True,
    )
    (wheel,) = wheels.glob("sfa_gym-*.whl")
    site = tmp_path / "site-packages"
    zipfile.ZipFile(wheel).extractall(site)
    (site / "baselines").mkdir()
    (site / "baselines" / "evil.py").write_text(EVIL)
    code = (
        "import sfa_gym; from sfa_gym.plugins import load_plugins\n"
        "print(sfa_gym.__file__)\n"
        "print(sorted(method.name for method, _ in load_plugins(None)))"
    )
    env = {**os.environ, "PYTHONPATH": str(site)}
    done = subprocess.run(
        [sys.executable, "-c", code], cwd=tmp_path, env=env, capture_output=True, text=True
    )
    assert done.returncode == 0, done.stderr
    where, names = done.stdout.splitlines()
    assert where.startswith(str(site))
    # the deep methods are shipped but trained only when a folder that holds them is named
    assert names == "['band_means', 'fft_magnitude', 'pca', 'raw_pixels']"
    assert "shipped with sfa-gym" in done.stderr
    assert "contrastive.py, deep_sfa.py left out (minutes of training each)" in done.stderr
    assert not (site / "baselines" / "IMPORTED").exists()
