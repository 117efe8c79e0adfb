"""Exclusive access: one process per instrument port and per chain of runs, released by the OS at process death."""

import os
import signal
import subprocess
import sys
import textwrap
import threading

import pytest

from ornitail.acquisition.exclusive_locks import ExclusiveLock, LockHeld
from ornitail.acquisition.flapping_motor_driver import FlappingMotorDriver
from ornitail.acquisition.instrument_errors import InstrumentInUse
from ornitail.acquisition.rig import Rig
from ornitail.acquisition.run_documents import DocumentDispatcher
from ornitail.acquisition.sweep import SweepChainBusy, run_sweep
from ornitail.acquisition.sweep_plan import plan_from_document

HOLD_PORT = textwrap.dedent(
    """
    import sys
    from ornitail.acquisition.flapping_motor_driver import FlappingMotorDriver
    driver = FlappingMotorDriver(sys.argv[1], max_rpm=20000.0)
    driver.open()
    print("open", flush=True)
    sys.stdin.read()  # hold the port until killed
    """
)


def start_holder(port_path):
    process = subprocess.Popen(
        [sys.executable, "-c", HOLD_PORT, port_path],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
    )
    assert process.stdout.readline().strip() == "open"
    return process


def test_a_second_connection_to_a_port_is_refused_naming_the_holder(simulated_motor):
    first = FlappingMotorDriver(simulated_motor.port_path, max_rpm=20000.0)
    first.open()
    second = FlappingMotorDriver(simulated_motor.port_path, max_rpm=20000.0)
    try:
        with pytest.raises(
            InstrumentInUse, match=rf"flapping motor: port \S+ is in use by process {os.getpid()}"
        ):
            second.open()
    finally:
        first.close()
    assert second.open().startswith("ID model=ORNI-MOTOR")  # free once the first closed it
    second.close()


def test_a_port_held_by_another_process_is_refused_and_freed_when_that_process_is_killed(
    simulated_motor,
):
    holder = start_holder(simulated_motor.port_path)
    try:
        driver = FlappingMotorDriver(simulated_motor.port_path, max_rpm=20000.0)
        with pytest.raises(InstrumentInUse, match=rf"in use by process {holder.pid} \(.*\)"):
            driver.open()
        os.kill(holder.pid, signal.SIGKILL)
        holder.wait()
        assert driver.open().startswith(
            "ID model=ORNI-MOTOR"
        )  # the kernel released the dead holder's locks
        driver.close()
    finally:
        holder.kill()
        holder.wait()


def test_a_lock_file_names_its_holder_and_is_free_after_release(tmp_path):
    path = tmp_path / "x.lock"
    lock = ExclusiveLock(path)
    lock.acquire(detail="sweep x")
    with pytest.raises(LockHeld) as held:
        ExclusiveLock(path).acquire()
    assert held.value.holder.pid == os.getpid() and held.value.holder.detail == "sweep x"
    lock.release()
    with ExclusiveLock(path):
        pass


PLAN = {
    "plan": {"name": "chain-lock"},
    "configuration": {"tail_id": "S3", "x_h_mm": 98},
    "steady_state": {"theta_deg": 25.0, "v_m_s": 0.8, "f_hz": 13.5},
    "protocol": {"steady_state_repeats": 2, "record_s": 0.6, "tailless_points": "none"},
    "settle": {"stable_for_s": 0.3, "timeout_s": 60},
}


def test_a_second_sweep_of_a_chain_being_recorded_is_refused_naming_the_run(tmp_path):
    """Rig A records the chain; from inside its sweep (its run open, so no timing is involved) a second thread
    starts the same plan on rig B with resume=True: refused before rig B is used, naming the run recording."""
    plan = plan_from_document({key: dict(value) for key, value in PLAN.items()}, "chain.toml")
    refusals: list[BaseException] = []

    def second_sweep():
        try:
            run_sweep(
                plan, Rig.from_file(time_scale=5.0), tmp_path, resume=True
            )  # not even connected
        except BaseException as error:  # noqa: BLE001 - handed to the test thread
            refusals.append(error)

    documents, done = DocumentDispatcher(), [0]
    documents.subscribe(
        lambda name, document: done.append(document.progress.done) if name == "set_point" else None
    )

    def on_event(event):  # once the first set point is recorded, as its document says
        if event.stage == "recorded" and done[-1] == 1:
            thread = threading.Thread(target=second_sweep)
            thread.start()
            thread.join(120)

    with Rig.from_file(time_scale=5.0) as rig_a:
        result = run_sweep(plan, rig_a, tmp_path, on_event=on_event, documents=documents)
    assert result.status == "completed" and result.completed_points == 3
    (refusal,) = refusals
    assert isinstance(refusal, SweepChainBusy)
    message = str(refusal)
    assert f"process {os.getpid()}" in message
    assert f"run {result.run_directories[0].name}" in message
    assert len(message.splitlines()) == 1
    # Once the first sweep ended the chain is free: a resume finds nothing left to do.
    with Rig.from_file(time_scale=5.0) as rig_b:
        again = run_sweep(plan, rig_b, tmp_path, resume=True)
    assert "nothing to do" in again.message


def test_a_record_left_by_a_dead_holder_is_never_named(tmp_path):
    """A new holder writes its record just after taking the lock; a refusal in between must not name the dead
    process whose record is still in the file."""
    finished = subprocess.run(
        [sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True
    )
    dead_pid = int(finished.stdout)
    path = tmp_path / "chain.lock"
    lock = ExclusiveLock(path)
    lock.acquire()
    record = (
        f'{{"pid": {dead_pid}, "host": "{os.uname().nodename}", "command": "old", "since_utc": ""}}'
    )
    path.write_text(record)  # as if the new holder had not written its own record yet
    with pytest.raises(LockHeld) as held:
        ExclusiveLock(path).acquire()
    assert held.value.holder is None and "another process" in str(held.value)
    lock.update_detail("now")
    with pytest.raises(LockHeld) as held:
        ExclusiveLock(path).acquire()
    assert held.value.holder.pid == os.getpid()
    lock.release()
