"""One lookup for the data that travels with sfa-gym: the checkout's folders, else the wheel's."""

from __future__ import annotations

from pathlib import Path

import pytest

from sfa_gym.data import DATA_FOLDERS, checkout_root, data_folder

ROOT = Path(__file__).resolve().parents[1]


def test_a_checkout_uses_its_own_folders():
    assert checkout_root() == ROOT
    assert data_folder("envs") == ROOT / "envs"
    assert data_folder("baselines") == ROOT / "baselines"


def _fake_package(tmp_path: Path, project: str | None) -> Path:
    package = tmp_path / "sfa_gym"
    package.mkdir()
    if project is not None:
        (tmp_path / "pyproject.toml").write_text(f'[project]\nname = "{project}"\n')
    return package


def test_a_wheel_uses_the_copies_inside_the_package(tmp_path):
    package = _fake_package(tmp_path, None)
    (tmp_path / "envs").mkdir()  # another distribution's folder beside the package: ignored
    (package / "envs_data").mkdir()
    assert checkout_root(package) is None
    assert data_folder("envs", package) == package / "envs_data"


def test_another_project_is_not_a_checkout(tmp_path):
    package = _fake_package(tmp_path, "other-project")
    (tmp_path / "tracks").mkdir()
    (package / "tracks_data").mkdir()
    assert checkout_root(package) is None
    assert data_folder("tracks", package) == package / "tracks_data"


def test_missing_data_and_unknown_kinds_are_named(tmp_path):
    package = _fake_package(tmp_path, "sfa-gym")
    with pytest.raises(FileNotFoundError, match="published"):
        data_folder("published", package)
    with pytest.raises(ValueError, match="'worlds'"):
        data_folder("worlds")  # type: ignore[arg-type]
    assert set(DATA_FOLDERS) == {"envs", "baselines", "tracks", "published"}
