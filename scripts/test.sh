#!/usr/bin/env bash
# Set up (if needed) and run the whole test suite, offscreen.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/setup.sh"
export QT_QPA_PLATFORM=offscreen
export PYQTGRAPH_QT_LIB=PySide6
exec .venv/bin/python -m pytest "$@"
