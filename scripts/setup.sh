#!/usr/bin/env bash
# Set up sfa-gym on a fresh Debian/Ubuntu machine: the system libraries for headless
# rendering (EGL, OSMesa fallback), bubblewrap (the plug-ins' sandbox), a virtual environment
# in .venv, and the package with the locked versions of the packages its numbers depend on
# (constraints.txt).
#
#   bash scripts/setup.sh          the library and its command line (sfa-gym)
#   bash scripts/setup.sh test     also the test dependencies (pytest, hypothesis,
#                                  stable-baselines3, MDP, Ray, pygame, the docs site's
#                                  MkDocs and Selenium) and Debian's chromium and chromium-driver, in
#                                  which the tests open the docs' leaderboard page
set -euo pipefail
cd "$(dirname "$0")/.."

extras="${1:-}"
gl_packages="libegl1 libegl-mesa0 libgl1-mesa-dri libgbm1 libosmesa6"
# bubblewrap confines the leaderboard's plug-in workers (read-only filesystem, no network)
system_packages="$gl_packages bubblewrap"
# the browser the docs test drives (a Debian package: browser downloads are not needed)
case ",$extras," in *,test,*) system_packages="$system_packages chromium chromium-driver" ;; esac

missing=""
if command -v dpkg-query >/dev/null; then
    for p in $system_packages; do
        dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing="$missing $p"
    done
fi
if [ -n "$missing" ]; then
    if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
        echo "installing system packages:$missing"
        export DEBIAN_FRONTEND=noninteractive
        apt-get update -qq
        apt-get install -y -qq --no-install-recommends $missing >/dev/null
    elif command -v sudo >/dev/null && sudo -n true 2>/dev/null; then
        sudo apt-get update -qq
        sudo DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends $missing >/dev/null
    else
        echo "warning: missing system packages:$missing" >&2
        echo "         ask an administrator to run: apt-get install$missing" >&2
        echo "         (for the GL libraries: or point MUJOCO_GL at a GL backend that works" >&2
        echo "         on this machine; without chromium the docs browser test is skipped;" >&2
        echo "         without bubblewrap plug-ins run in plain, unconfined worker processes)" >&2
    fi
fi

python="${PYTHON:-python3}"
if ! "$python" -c 'import sys; sys.exit(sys.version_info < (3, 11))'; then
    echo "error: sfa-gym needs Python >= 3.11; $python is $("$python" --version 2>&1)." >&2
    echo "       set PYTHON=/path/to/python3.11 and run again" >&2
    exit 1
fi
[ -x .venv/bin/python ] || "$python" -m venv .venv
.venv/bin/python -m pip install -q --upgrade pip
# every install goes through the lock, so that a fresh clone computes with the versions the
# committed results were computed with (regenerate it: .venv/bin/python -m sfa_gym.lock)
if [ -n "$extras" ]; then
    .venv/bin/python -m pip install -q -c constraints.txt -e ".[$extras]"
else
    .venv/bin/python -m pip install -q -c constraints.txt -e .
fi
echo "sfa-gym is set up in .venv ($(.venv/bin/python -c 'import sfa_gym; print(sfa_gym.__version__)'))"
