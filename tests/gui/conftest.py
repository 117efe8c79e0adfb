"""The window on a simulated rig, offscreen (QT_QPA_PLATFORM=offscreen, set by scripts/test.sh)."""

import os

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
os.environ.setdefault("PYQTGRAPH_QT_LIB", "PySide6")

import math  # noqa: E402

import pytest  # noqa: E402
from backend_agreement import rig_copy  # noqa: E402

from ornitail.acquisition.rig_file import DEFAULT_RIG_FILE  # noqa: E402
from ornitail.gui.main_window import MainWindow  # noqa: E402
from ornitail.gui.rig_session import RigSession  # noqa: E402

TIME_SCALE = 3.0
"""Simulated seconds per wall second: the pty then carries 30 k frames/s beside a redrawing window; at 4x two
busy cores lost samples inside sweep records now and then (which processing then rightly refuses)."""
LIGHT_STREAM_TIME_SCALE = 6.0
"""The same for a rig streaming at 2 kHz: 12 k frames/s on the pty."""


@pytest.fixture
def window(qtbot, tmp_path):
    """A shown main window whose session records under ``tmp_path``; closed (rig safe) after the test."""
    main_window = MainWindow(RigSession(tmp_path))
    qtbot.addWidget(main_window)
    main_window.resize(1400, 900)
    main_window.show()
    yield main_window
    main_window.close()


@pytest.fixture
def connected(window, qtbot):
    """The window with the simulated rig connected through its Connect button and streaming."""
    return _connect(window, qtbot, DEFAULT_RIG_FILE, TIME_SCALE)


@pytest.fixture
def connected_at_2_khz(window, qtbot, tmp_path_factory):
    """As :func:`connected`, on a copy of the simulated rig whose balance streams at 2 kHz instead of 10 kHz, run
    faster (:data:`LIGHT_STREAM_TIME_SCALE`): for tests that record whole sweeps."""
    rig_file = rig_copy(
        DEFAULT_RIG_FILE,
        tmp_path_factory.mktemp("rig-2-khz"),
        {"sample_rate_hz = 10000.0": "sample_rate_hz = 2000.0"},
    )
    return _connect(window, qtbot, rig_file, LIGHT_STREAM_TIME_SCALE)


def _connect(window, qtbot, rig_file, time_scale):
    window.controls.time_scale.setValue(time_scale)
    window.controls.rig_file.edit.setText(str(rig_file))
    window.controls.connect_button.click()
    qtbot.waitUntil(lambda: window.data.rows_received > 1000, timeout=20_000)
    qtbot.waitUntil(lambda: math.isfinite(window.session.readings.time_s), timeout=5_000)
    return window


@pytest.fixture
def drive_to(qtbot):
    """``drive_to(window, pitch_deg, velocity_m_s, frequency_hz)``: type set points, press Set, wait for them."""
    return lambda window, *set_points: _drive_to(window, qtbot, *set_points)


def _drive_to(window, qtbot, pitch_deg, velocity_m_s, frequency_hz, timeout_ms=20_000):
    controls = window.controls
    for box, value, name in (
        (controls.pitch, pitch_deg, "pitch"),
        (controls.velocity, velocity_m_s, "tunnel speed"),
        (controls.frequency, frequency_hz, "flapping frequency"),
    ):
        box.setValue(value)
        controls.set_buttons[name].click()

    def reached():
        readings = window.session.readings
        return (
            abs(math.degrees(readings.pitch_rad) - pitch_deg) < 0.2
            and abs(readings.tunnel_velocity_m_s - velocity_m_s) < 0.02
            and abs(readings.flapping_frequency_hz - frequency_hz) < 0.1
        )

    qtbot.waitUntil(reached, timeout=timeout_ms)
