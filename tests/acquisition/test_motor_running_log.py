"""Where the motor's starts and stops land on the balance stream (the clock of the balance's drift)."""

from ornitail.acquisition.motor_running_log import MOTOR_TRANSITIONS_KEY, MotorRunningLog


class RowsFromSample:
    """A stream whose recorded rows begin at the board's sample ``first_recorded`` and reach ``last_recorded``."""

    def __init__(self, first_recorded: int, last_recorded: int) -> None:
        self.first_recorded, self.last_recorded = first_recorded, last_recorded

    lost: tuple[int, int] | None = None
    """Samples (first, last) the link lost: not recorded, rows continue after them."""

    def row_sampled_at(self, samples_since_start: int) -> tuple[int, int] | None:
        if samples_since_start > self.last_recorded:
            return None
        sample = max(samples_since_start, self.first_recorded)
        lost_before = 0
        if self.lost is not None and sample >= self.lost[0]:
            lost_before = min(sample, self.lost[1] + 1) - self.lost[0]
            if sample <= self.lost[1]:  # fell into the gap: the first row after it
                return self.lost[0] - self.first_recorded, self.lost[1] + 1 - sample
        return sample - self.first_recorded - lost_before, 0


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


def test_a_change_the_link_lost_lands_on_the_row_after_the_gap_with_the_samples_lost_since():
    """Samples 2 000-2 999 never reached the host: a stop at sample 2 500 is journalled on the first row after the
    gap (row 2 000: sample 3 000) with the 500 samples of the counter between, so processing can put it back."""
    stream = RowsFromSample(first_recorded=0, last_recorded=10_000)
    stream.lost = (2_000, 2_999)
    log = MotorRunningLog()
    log.commanded(13.5, 1_000, stream)
    log.observe(True, 2_000, stream)
    log.observe(False, 3_000, stream)  # halfway: sample 2 500, lost
    log.observe(False, 4_000, stream)
    assert log.journal_values(stream) == {
        MOTOR_TRANSITIONS_KEY: [["started", 1_000], ["stopped", 2_000, 500]]
    }
