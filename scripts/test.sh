#!/usr/bin/env bash
# Set up (if needed) and run the test suite, offscreen.
#
# With no arguments, the whole suite in two pytest sessions at once (tests/conftest.py, --ornitail-phase):
#   - the tests that drive a simulated rig, one at a time in one process at normal priority (the sweep tests count
#     samples exactly), the demo's test first: it waits for `ornitail demo`, recording in the background, so no
#     other rig streams beside the demo's;
#   - beside them, the tests that drive no simulated rig on two pytest-xdist workers in the idle scheduling class
#     (SCHED_IDLE, `chrt --idle`; `nice -n 19` where that is refused): they take only the CPU time the rig tests and
#     the demo leave, so those run as on a quiet host. Their report is printed when both sessions have ended.
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
  pkill -f -- "--basetemp=$demo_folder/no-rig" 2>/dev/null || true
  pkill -f -- "--data-root $demo_folder/data" 2>/dev/null || true
  rm -rf "$demo_folder"
}
trap cleanup EXIT
export ORNITAIL_TEST_DEMO_FOLDER="$demo_folder"

# The idle class where the kernel allows it, else the lowest nice level.
idle_priority=(chrt --idle 0)
if ! chrt --idle 0 true 2>/dev/null; then
  idle_priority=(nice -n 19)
fi
no_rig_log="$demo_folder/no-rig.log"
(
  status=0
  "${idle_priority[@]}" .venv/bin/python -m pytest --ornitail-phase=no-rig -n 2 --dist loadfile -p no:cacheprovider \
    --basetemp="$demo_folder/no-rig" >"$no_rig_log" 2>&1 || status=$?
  echo "$status" >"$demo_folder/no-rig-returncode"
) &
no_rig_job=$!
rig_status=0
.venv/bin/python -m pytest --ornitail-phase=rig || rig_status=$?
wait "$no_rig_job" || true
echo
echo "=== the tests that drive no simulated rig (run beside the ones above) ==="
cat "$no_rig_log"
no_rig_status="$(cat "$demo_folder/no-rig-returncode" 2>/dev/null || echo 1)"
if [ "$no_rig_status" -ne 0 ]; then
  exit "$no_rig_status"
fi
exit "$rig_status"
