#!/usr/bin/env bash
# Set up (if needed) and run ornitail's main job on the simulated rig.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/setup.sh"
exec .venv/bin/ornitail demo "$@"
