"""The lock (constraints.txt): the running environment has the locked versions, setup.sh installs
through it, and it agrees with pyproject.toml's lower bounds."""

from __future__ import annotations

import importlib.metadata
import re
import subprocess
import sys
import tomllib
import zipfile
from pathlib import Path

import pytest
from packaging.requirements import Requirement

from sfa_gym.lock import (
    canonical_name,
    differences,
    installed_versions,
    lock_path,
    read_lock,
    update_lock,
)

ROOT = Path(__file__).resolve().parents[1]
LOCK = read_lock(ROOT / "constraints.txt")


def test_the_lock_is_the_checkouts_and_pins_what_the_numbers_depend_on():
    assert lock_path() == ROOT / "constraints.txt"
    for name in ("mujoco", "numpy", "scipy", "scikit-learn", "opencv-python-headless"):
        assert name in LOCK, f"{name} is not locked"
    for name in ("gymnasium", "torch", "stable-baselines3"):
        assert name in LOCK, f"{name} is not locked"


@pytest.mark.parametrize("name", sorted(LOCK))
def test_installed_version_is_the_locked_one(name):
    # scripts/setup.sh (and CI through it) installs with -c constraints.txt: there this holds
    try:
        have = importlib.metadata.version(name)
    except importlib.metadata.PackageNotFoundError:
        pytest.skip(f"{name} is not installed (an extra this environment was set up without)")
    assert have == LOCK[name], (
        f"{name} {have} is installed, the lock says {LOCK[name]}: reinstall with "
        "`bash scripts/setup.sh test`, or regenerate the lock (python -m sfa_gym.lock) and "
        "check the published numbers"
    )


def test_setup_installs_every_package_through_the_lock():
    script = (ROOT / "scripts" / "setup.sh").read_text()
    installs = [
        line
        for line in script.splitlines()
        if re.search(r"pip install", line) and not line.lstrip().startswith("#")
    ]
    package_installs = [line for line in installs if "--upgrade pip" not in line]
    assert len(package_installs) >= 2  # the plain install and the one with extras
    for line in package_installs:
        assert "-c constraints.txt" in line, f"setup.sh installs without the lock: {line.strip()}"


def test_locked_versions_satisfy_pyprojects_ranges():
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    requirements = project["dependencies"] + [
        r for extra in project["optional-dependencies"].values() for r in extra
    ]
    checked = 0
    for text in requirements:
        req = Requirement(text)
        name = canonical_name(req.name)
        if name in LOCK:
            assert req.specifier.contains(LOCK[name], prereleases=True), (
                f"the lock's {name}=={LOCK[name]} is outside pyproject's {text!r}"
            )
            checked += 1
    assert checked >= 10


def test_the_wheel_carries_the_lock_and_finds_it_outside_a_checkout(tmp_path):
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(tmp_path), str(ROOT)],
        check=True,
    )
    (wheel,) = tmp_path.glob("sfa_gym-*.whl")
    zipfile.ZipFile(wheel).extractall(tmp_path / "site")
    assert (tmp_path / "site" / "sfa_gym" / "constraints.txt").read_text() == (
        ROOT / "constraints.txt"
    ).read_text()
    found = subprocess.run(
        [sys.executable, "-c", "from sfa_gym.lock import lock_path; print(lock_path())"],
        cwd=tmp_path,
        env={"PYTHONPATH": str(tmp_path / "site"), "PATH": ""},
        capture_output=True,
        text=True,
        check=True,
    )
    assert found.stdout.strip() == str(tmp_path / "site" / "sfa_gym" / "constraints.txt")


def test_differences_name_each_package_off_the_lock():
    lock = {"numpy": "2.0.0", "mujoco": "3.3.0"}
    assert differences({"numpy": "2.0.0", "mujoco": "3.3.0"}, lock) == {}
    assert differences({"NumPy": "2.0.0", "mujoco": "4.0.0"}, lock) == {
        "mujoco": ("4.0.0", "3.3.0")
    }
    assert differences({"numpy": "2.0.0"}, lock) == {"mujoco": (None, "3.3.0")}


def test_a_malformed_lock_is_refused_with_its_line(tmp_path):
    path = tmp_path / "constraints.txt"
    path.write_text("# header\nnumpy>=2\n")
    with pytest.raises(ValueError, match=r"constraints.txt:2: 'numpy>=2' is not a pin"):
        read_lock(path)
    path.write_text("numpy==2.0\nNumPy==2.1\n")
    with pytest.raises(ValueError, match="numpy is locked twice"):
        read_lock(path)


def test_regenerating_keeps_names_and_comments_and_takes_the_installed_versions(tmp_path):
    path = tmp_path / "constraints.txt"
    path.write_text("# why\nnumpy==0  # arrays\nscipy==1.0.0\n")
    changed = update_lock(path)
    numpy, scipy = installed_versions(["numpy", "scipy"]).values()
    assert changed == {"numpy": ("0", numpy), "scipy": ("1.0.0", scipy)}
    assert path.read_text() == f"# why\nnumpy=={numpy}  # arrays\nscipy=={scipy}\n"
    path.write_text("surely-not-an-installed-package==1.0\n")
    with pytest.raises(ValueError, match="surely-not-an-installed-package is locked"):
        update_lock(path)
