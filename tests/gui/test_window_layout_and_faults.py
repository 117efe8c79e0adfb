"""The window fits the screens tunnel PCs have, keeps its size while long texts arrive, and shows instrument
faults in red (issue 18)."""

from PySide6 import QtWidgets

from ornitail.gui.status_panel import WARN_STYLE

SCREENS = [(1366, 768), (1920, 1080)]


def test_the_window_fits_both_screens_and_does_not_grow_while_recording(connected, qtbot):
    window = connected
    for width, height in SCREENS:
        hint = window.minimumSizeHint()
        assert hint.width() <= width and hint.height() <= height, (hint, width, height)
    window.resize(*SCREENS[0])
    qtbot.waitUntil(lambda: window.size().width() == SCREENS[0][0], timeout=5_000)
    # A recording and a long link-health line must not widen it (they once pushed it past 1700 px).
    window.controls.tail_id.setText("S3")
    window.controls.start_button.click()
    qtbot.waitUntil(lambda: window.session.recording is not None, timeout=10_000)
    frames = window.frames
    qtbot.waitUntil(lambda: window.frames >= frames + 20, timeout=10_000)
    assert (window.size().width(), window.size().height()) == SCREENS[0]
    # Every quantity of the live view on its own axis, with its unit.
    labels = {
        item.getAxis("left").labelText
        for item in window.live_view.plots.ci.items
        if hasattr(item, "getAxis")
    }
    assert labels == {"mN", "mN m", "m/s", "degC", "deg", "Hz"}
    window.controls.stop_button.click()
    qtbot.waitUntil(lambda: window.session.recording is None, timeout=10_000)


def test_an_instrument_that_stops_answering_turns_the_status_strip_red(connected, qtbot):
    window = connected
    instruments = window.status.instruments
    assert instruments.styleSheet() != WARN_STYLE
    window.session.rig.simulators.strut.unplug()
    qtbot.waitUntil(lambda: "INSTRUMENT FAULT" in instruments.text(), timeout=20_000)
    assert instruments.styleSheet() == WARN_STYLE
    assert "strut" in instruments.toolTip()
    QtWidgets.QApplication.closeAllWindows()  # the message boxes of the fault, then the window (rig made safe)
