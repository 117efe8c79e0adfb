"""The independent reality (benchmarks/independent_reality.py) writes what a real campaign would:
the documented flight log and a model file the gap diagnosis reads as any other."""

import numpy as np
import pytest
from independent_reality import RealityCase, fly, linearisation, trim, write_case

from ornitail.flight.flight_logs import read_flight_log
from ornitail.flight.manoeuvres import REQUIRED_LOG_COLUMNS, cut_manoeuvres
from ornitail.gap.flight_candidates import baseline_flight_model, flight_candidates
from ornitail.gap.model_spec import BaselineSpec, read_baseline_spec


def test_flapper_b_trims_and_its_linearisation_is_stable():
    steady = trim()
    a_matrix, b_matrix, _ = linearisation()
    assert 0.0 < steady.theta_rad < np.pi / 2  # fuselage tilted forward, flying forwards
    assert steady.u_m_s < 0 and steady.w_m_s < 0  # frames.md: u0 = -V cos, w0 = -V sin
    assert np.max(np.linalg.eigvals(a_matrix).real) < 0
    assert b_matrix[0, 0] != 0  # the elevator pitches it


def test_its_log_and_model_file_are_read_like_any_campaign(tmp_path):
    log_path, spec_path = write_case(
        RealityCase("input_delay", 0.05, seed=1, manoeuvres=2), tmp_path
    )
    log = read_flight_log(log_path)
    assert set(REQUIRED_LOG_COLUMNS) <= set(log.columns)
    assert len(cut_manoeuvres(log, str(log_path))) == 2
    spec = read_baseline_spec(spec_path)
    baseline = baseline_flight_model(spec)
    a_matrix, b_matrix, _ = linearisation()
    # the file holds the linearisation as derivatives and constants: equal up to round-off
    np.testing.assert_allclose(baseline.a_matrix, a_matrix, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(baseline.b_matrix, b_matrix, rtol=1e-9, atol=1e-12)
    library = flight_candidates(spec, baseline)
    # written in the DelFly model's structure, it is offered the DelFly model's library
    delfly = BaselineSpec("linear_model", model="delfly_longitudinal")
    expected = flight_candidates(delfly, baseline_flight_model(delfly))
    assert [c.name for c in library.candidates] == [c.name for c in expected.candidates]
    assert {"static_stability", "heave_added_mass"} <= {c.name for c in library.candidates}


def test_a_logged_delay_leads_the_deflection_by_its_size():
    plain = fly(RealityCase(seed=4, manoeuvres=1))
    delayed = fly(RealityCase("input_delay", 0.05, seed=4, manoeuvres=1))
    step = float(plain["time_s"].iloc[1] - plain["time_s"].iloc[0])
    shift = int(round(0.05 / step))
    # same seed, same motion; the logged elevator is the deflection 10 samples ahead (sensor noise
    # of 2 mrad on both: 5 sigma of their difference is 0.015 rad)
    ahead = delayed["elevator_rad"].to_numpy()[:-shift] - plain["elevator_rad"].to_numpy()[shift:]
    assert np.max(np.abs(ahead)) < 0.015
    assert plain["q_rad_s"].to_numpy() == pytest.approx(delayed["q_rad_s"].to_numpy())
