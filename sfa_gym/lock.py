"""The lock of the packages the scores depend on: ``constraints.txt`` at the repository root.

The lock is a pip constraints file (``name==version`` lines with comments) that
``scripts/setup.sh`` passes to every install, so that a fresh install computes the board's, the
docs' and CI's numbers with the same MuJoCo, numpy, OpenCV, ... as the committed results.
``pyproject.toml`` keeps lower bounds only (sfa-gym is also a library). The leaderboard records
the installed versions of the locked packages in every result file and marks the results whose
versions differ from the lock.

Regenerate the lock after upgrading the packages in the environment (the names and comments of
the file stay, the versions become the running environment's)::

    .venv/bin/python -m sfa_gym.lock            # rewrite constraints.txt
    .venv/bin/python -m sfa_gym.lock --check    # exit 1 when the environment differs
"""

from __future__ import annotations

import argparse
import importlib.metadata
import re
import sys
from pathlib import Path

__all__ = [
    "LOCK_FILE",
    "canonical_name",
    "cpu_numerics",
    "differences",
    "installed_versions",
    "lock_path",
    "read_lock",
    "update_lock",
]

LOCK_FILE = "constraints.txt"
"""The lock's file name: at the repository root, and inside the installed package."""

_PIN = re.compile(r"^([A-Za-z0-9][A-Za-z0-9._-]*)==([^\s;#]+)\s*(#.*)?$")


def canonical_name(name: str) -> str:
    """A distribution name as pip compares them (PEP 503): ``Scikit_Learn`` -> ``scikit-learn``."""
    return re.sub(r"[-_.]+", "-", name).lower()


def lock_path() -> Path:
    """The lock: ``constraints.txt`` of the checkout this sfa_gym runs from, else the copy
    inside the installed package.

    Raises:
        FileNotFoundError: neither exists (an incomplete installation).
    """
    from sfa_gym.data import packaged_path

    return packaged_path("the lock", LOCK_FILE, LOCK_FILE, folder=False)


def read_lock(path: str | Path | None = None) -> dict[str, str]:
    """The locked versions, ``{canonical name: version}``, of the lock at ``path`` (default:
    :func:`lock_path`).

    Raises:
        ValueError: a line that is neither a comment nor ``name==version``, or a name locked
            twice.
    """
    path = Path(path) if path is not None else lock_path()
    out: dict[str, str] = {}
    for number, line in enumerate(path.read_text().splitlines(), 1):
        text = line.strip()
        if not text or text.startswith("#"):
            continue
        match = _PIN.match(text)
        if match is None:
            raise ValueError(
                f"{path}:{number}: {text!r} is not a pin; expected 'name==version' "
                "(an exact version, optionally followed by a # comment)"
            )
        name = canonical_name(match.group(1))
        if name in out:
            raise ValueError(f"{path}:{number}: {name} is locked twice")
        out[name] = match.group(2)
    return out


def installed_versions(names: list[str] | None = None) -> dict[str, str | None]:
    """The installed version of each of ``names`` (default: the locked packages), None for a
    package that is not installed."""
    names = list(read_lock()) if names is None else names
    out: dict[str, str | None] = {}
    for name in names:
        try:
            out[canonical_name(name)] = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            out[canonical_name(name)] = None
    return out


def differences(
    versions: dict[str, str | None], lock: dict[str, str] | None = None
) -> dict[str, tuple[str | None, str]]:
    """``{name: (version, locked version)}`` for each locked package whose version in
    ``versions`` differs from ``lock`` (default: :func:`read_lock`); a package missing from
    ``versions`` or recorded as None counts as differing."""
    lock = read_lock() if lock is None else lock
    found = {canonical_name(k): v for k, v in versions.items()}
    return {
        name: (found.get(name), locked)
        for name, locked in lock.items()
        if found.get(name) != locked
    }


def cpu_numerics() -> dict[str, list[str]]:
    """What of this CPU decides the last bits of the numbers, which no lock can pin: the SIMD
    targets numpy dispatches to (``simd``: with AVX-512, float64 ``exp``, ``log``, ``arctan2``
    and ``power`` take other kernels and round differently) and the BLAS kernels in use
    (``blas``: OpenBLAS picks them per CPU)."""
    from threadpoolctl import threadpool_info

    try:
        from numpy._core._multiarray_umath import __cpu_dispatch__, __cpu_features__
    except ImportError:  # numpy moved its internals: say so rather than guess
        simd = ["unknown"]
    else:
        simd = [name for name in __cpu_dispatch__ if __cpu_features__.get(name)]
    blas = sorted(  # in a fixed order: the libraries load in an order that varies
        f"{info.get('internal_api')} {info.get('version')} {info.get('architecture')}"
        for info in threadpool_info()
        if info.get("user_api") == "blas"
    )
    return {"simd": simd, "blas": blas}


def update_lock(path: str | Path | None = None) -> dict[str, tuple[str, str]]:
    """Rewrite the versions of the lock at ``path`` (default: :func:`lock_path`) with the
    running environment's, keeping its names, order and comments; returns the changed pins,
    ``{name: (old, new)}``.

    Raises:
        ValueError: a locked package is not installed here (install it first: the lock is
            written from an environment that has every extra the tests use).
    """
    path = Path(path) if path is not None else lock_path()
    read_lock(path)  # refuses a malformed file before anything is written
    lines = path.read_text().splitlines()
    changed: dict[str, tuple[str, str]] = {}
    for i, line in enumerate(lines):
        match = _PIN.match(line.strip())
        if match is None:
            continue
        name, old, comment = match.group(1), match.group(2), match.group(3)
        new = installed_versions([name])[canonical_name(name)]
        if new is None:
            raise ValueError(f"{name} is locked in {path} but not installed in {sys.prefix}")
        if new != old:
            changed[canonical_name(name)] = (old, new)
        lines[i] = f"{name}=={new}" + (f"  {comment}" if comment else "")
    path.write_text("\n".join(lines) + "\n")
    return changed


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m sfa_gym.lock",
        description="Rewrite the lock (constraints.txt) with this environment's versions, or "
        "check that this environment matches it.",
    )
    parser.add_argument("--check", action="store_true", help="compare only; exit 1 on a change")
    parser.add_argument("--lock", type=Path, default=None, help="the lock file (default: ours)")
    args = parser.parse_args(argv)
    if args.check:
        changed = differences(installed_versions(list(read_lock(args.lock))), read_lock(args.lock))
        for name, (have, locked) in changed.items():
            print(f"{name}: installed {have}, locked {locked}", file=sys.stderr)
        return 1 if changed else 0
    for name, (old, new) in update_lock(args.lock).items():
        print(f"{name}: {old} -> {new}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
