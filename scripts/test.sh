#!/usr/bin/env bash
# Set up (if needed) and run the test suite, offscreen.
#
# With no arguments, the whole suite in two phases (tests/conftest.py, --ornitail-phase):
#   1. the tests that drive no simulated rig, on two pytest-xdist workers (one per core), while `ornitail demo`
#      records in the background (it mostly waits on its simulated rig);
#   2. once the demo has ended, the tests that drive a simulated rig, on two workers as well: they mostly wait on
#      their rigs' simulated time (each worker about 0.6 of a core), so two rigs stream at once and nothing else
#      does (the sweep tests count samples exactly and are kept off a CPU-bound neighbour); the demo's test only
#      reads what the demo printed.
# With arguments, pytest with those arguments (one process).
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/setup.sh"
export QT_QPA_PLATFORM=offscreen
# One BLAS thread per process: the suite already runs two processes on two cores, and OpenBLAS's extra threads
# only contended with them (tests/gap on two workers: 165 s with them, 86 s without; one flight diagnosis alone is
# no faster with two threads).
export OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 MKL_NUM_THREADS=1
export PYQTGRAPH_QT_LIB=PySide6
if [ $# -gt 0 ]; then
  exec .venv/bin/python -m pytest "$@"
fi

demo_folder="$(mktemp -d -t ornitail-demo-XXXXXX)"
(
  # `set -e` holds in this subshell too: without the `||` a failing demo ended it before its return code was
  # written, and the demo's test waited out its whole deadline for a demo long gone.
  status=0
  .venv/bin/ornitail demo --data-root "$demo_folder/data" --json >"$demo_folder/stdout" 2>"$demo_folder/stderr" ||
    status=$?
  echo "$status" >"$demo_folder/returncode"
) &
demo_job=$!
cleanup() {
  kill "$demo_job" 2>/dev/null || true
  pkill -f -- "--data-root $demo_folder/data" 2>/dev/null || true
  rm -rf "$demo_folder"
}
trap cleanup EXIT
export ORNITAIL_TEST_DEMO_FOLDER="$demo_folder"

no_rig_status=0
.venv/bin/python -m pytest --ornitail-phase=no-rig -n 2 --dist loadfile || no_rig_status=$?
# A deadline, not a synchronisation: the demo's test reports a demo that has not ended by then, with its log.
for _ in $(seq 1200); do
  [ -s "$demo_folder/returncode" ] && break
  sleep 0.5
done
rig_status=0
.venv/bin/python -m pytest --ornitail-phase=rig -n 2 --dist loadfile || rig_status=$?
if [ "$no_rig_status" -ne 0 ]; then
  exit "$no_rig_status"
fi
exit "$rig_status"
