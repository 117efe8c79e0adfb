"""The conditions a record belongs to, from readings that reach the host after the samples they go with."""

import pytest

from ornitail.acquisition.set_point_recording import RecordConditions


def test_a_creeping_velocity_is_taken_at_the_records_middle_not_at_the_readings_mean():
    # The record holds samples 500..2499; the readings were taken at samples 1000..3000 (they lag the stream).
    conditions = RecordConditions(first_sample=500, samples=2000)
    conditions.sample_counts = [1000, 1500, 2000, 2500, 3000]
    conditions.velocities_m_s = [0.798 + 1e-7 * count for count in conditions.sample_counts]
    conditions.pitches_rad = [0.4363] * 5
    values = conditions.journal_values()
    assert values["tunnel_velocity_mean_m_s"] == pytest.approx(0.798 + 1e-7 * 1499.5, abs=1e-12)
    # The plain mean of the readings sits 0.05 mm/s high.
    assert sum(conditions.velocities_m_s) / 5 - values["tunnel_velocity_mean_m_s"] > 4e-5
    assert values["pitch_mean_rad"] == pytest.approx(0.4363)
    assert values["condition_readings"] == 5


def test_one_reading_is_taken_as_it_is():
    conditions = RecordConditions(first_sample=0, samples=100)
    conditions.sample_counts, conditions.velocities_m_s, conditions.pitches_rad = [50], [0.8], [0.4]
    assert conditions.journal_values()["tunnel_velocity_mean_m_s"] == 0.8
