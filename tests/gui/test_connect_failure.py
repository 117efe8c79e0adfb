"""The window's connect path meets an absent port: one message line naming instrument, port and the safe state."""

from pathlib import Path

from ornitail.acquisition.rig_file import DEFAULT_RIG_FILE
from ornitail.gui.rig_session import RigSession

DATA = Path(DEFAULT_RIG_FILE).parent


def test_connecting_a_rig_whose_port_is_absent_posts_one_error_line(tmp_path):
    absent = tmp_path / "ttyABSENT0"
    text = DEFAULT_RIG_FILE.read_text().replace("simulated = true", "simulated = false")
    text = text.replace('"/dev/ttyUSB0"', f'"{absent}"')
    text = text.replace('calibration = "', f'calibration = "{DATA}/')
    text = text.replace('table = "', f'table = "{DATA}/')
    rig = tmp_path / "rig.toml"
    rig.write_text(text)
    session = RigSession(tmp_path / "data")
    try:
        session.connect(rig).result(timeout=120)
        message = session.messages.get(timeout=10)
    finally:
        session.shutdown()
    assert message.kind == "error" and not session.connected
    (line,) = message.text.splitlines()
    assert line == (
        f"connect: tunnel fan: cannot open port {absent}: No such file or directory; "
        "no actuator was connected, so none was brought to its safe state"
    )
