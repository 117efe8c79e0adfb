#!/usr/bin/env bash
# Set up ornitail for development on a fresh Debian machine with Python 3.11:
# system libraries the tests need (when missing), a virtualenv in .venv, and an editable install
# with the test tools and the GUI (PySide6 only: pyqtgraph would pick PyQt6 if both were installed).
# Sourced by demo.sh and test.sh; safe to run again (it only installs what is missing).
set -euo pipefail
repo_root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$repo_root"

# Debian packages: python3-venv (venv on Debian's own Python) and the libraries offscreen Qt needs (required);
# those Qt's xcb platform needs on a real X display (`ornitail gui` on a desktop) and xvfb (the window tested on an
# X server): wanted, but a machine that cannot install them still gets the rest, with a warning.
required_packages=(libegl1 libgl1 libxkbcommon0 libfontconfig1 libglib2.0-0 libdbus-1-3)
display_packages=(libxcb-cursor0 libxcb-icccm4 libxcb-image0 libxcb-keysyms1 libxcb-randr0 libxcb-render-util0
  libxcb-shape0 libxcb-xkb1 libxkbcommon-x11-0 libx11-xcb1 xvfb)
if ! python3 -c "import venv, ensurepip" >/dev/null 2>&1; then
  required_packages+=(python3-venv)
fi
apt_updated=0
install_missing() {  # install the Debian packages named that are not installed yet
  local missing=() package
  for package in "$@"; do
    dpkg-query -W -f='${Status}' "$package" 2>/dev/null | grep -q "install ok installed" || missing+=("$package")
  done
  [ ${#missing[@]} -eq 0 ] && return 0
  echo "setup: installing system packages: ${missing[*]}"
  local apt_get=(apt-get)
  [ "$(id -u)" -ne 0 ] && apt_get=(sudo apt-get)
  if [ "$apt_updated" -eq 0 ]; then
    "${apt_get[@]}" update -qq || return 1
    apt_updated=1
  fi
  DEBIAN_FRONTEND=noninteractive "${apt_get[@]}" install -y -qq "${missing[@]}" >/dev/null
}
install_missing "${required_packages[@]}"
install_missing "${display_packages[@]}" || echo "setup: warning: could not install ${display_packages[*]}: \
\`ornitail gui\` on an X display and tests/gui/test_window_under_xvfb.py need them" >&2

python_version_ok='import sys; sys.exit(0 if sys.version_info >= (3, 11) else 1)'
if ! python3 -c "$python_version_ok"; then
  echo "setup: ornitail needs Python 3.11 or newer; python3 is $(python3 --version)" >&2
  exit 1
fi

if [ ! -x .venv/bin/python ]; then
  echo "setup: creating .venv"
  python3 -m venv .venv
fi
# Reinstall only when pyproject.toml changed since the last install.
stamp=.venv/.ornitail-installed
if [ ! -f "$stamp" ] || [ pyproject.toml -nt "$stamp" ]; then
  echo "setup: installing ornitail and its dependencies into .venv"
  log=.venv/pip-install.log
  if ! { .venv/bin/python -m pip install --upgrade pip && .venv/bin/python -m pip install -e ".[test,gui]"; } >"$log" 2>&1; then
    tail -n 30 "$log" >&2
    echo "setup: pip install failed; the whole log is in $log" >&2
    exit 1
  fi
  .venv/bin/python -c "import ornitail.app.cli" # fail here, not later, if the install did not work
  touch "$stamp"
fi
