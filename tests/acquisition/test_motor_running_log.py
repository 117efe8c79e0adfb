"""Where the motor's starts and stops land on the balance stream (the clock of the balance's drift)."""

from ornitail.acquisition.motor_running_log import MOTOR_TRANSITIONS_KEY, MotorRunningLog


class RowsFromSample:
    """A stream whose recorded rows begin at the board's sample ``first_recorded`` and reach ``last_recorded``."""

    def __init__(self, first_recorded: int, last_recorded: int) -> None:
        self.first_recorded, self.last_recorded = first_recorded, last_recorded

    def first_row_sampled_after(self, samples_since_start: int) -> int | None:
        if samples_since_start > self.last_recorded:
            return None
        return max(samples_since_start, self.first_recorded) - self.first_recorded


def test_a_start_lands_at_the_command_and_a_stop_halfway_between_the_polls_around_it():
    stream = RowsFromSample(first_recorded=500, last_recorded=10_000)
    log = MotorRunningLog()
    log.observe(False, 900, stream)  # standing while the tare settles
    log.commanded(13.5, 1_000, stream)  # told to flap: it turns from here
    log.observe(True, 1_000, stream)
    log.observe(True, 2_000, stream)
    assert log.journal_values(stream) == {MOTOR_TRANSITIONS_KEY: [["started", 500]]}
    log.commanded(0.0, 3_000, stream)  # told to stop: it spins down
    log.observe(True, 3_900, stream)
    log.observe(False, 4_900, stream)  # first poll that reads 0 rpm
    log.observe(False, 5_900, stream)
    # Halfway between the last poll that read it turning and the first that read it standing.
    assert log.journal_values(stream) == {MOTOR_TRANSITIONS_KEY: [["stopped", 3_900]]}
    assert log.journal_values(stream) == {MOTOR_TRANSITIONS_KEY: []}  # journalled once


def test_a_change_waits_for_its_row_and_a_new_run_starts_with_the_motor_as_it_is():
    stream = RowsFromSample(first_recorded=0, last_recorded=1_000)
    log = MotorRunningLog()
    log.commanded(13.5, 1_500, stream)  # that sample has not been recorded yet
    assert log.journal_values(stream) == {MOTOR_TRANSITIONS_KEY: []}
    stream.last_recorded = 2_000
    assert log.journal_values(stream) == {MOTOR_TRANSITIONS_KEY: [["started", 1_500]]}
    log.start_run()  # a new recorder: rows count from its first; the motor is still turning
    assert log.journal_values(stream) == {MOTOR_TRANSITIONS_KEY: [["started", 0]]}
