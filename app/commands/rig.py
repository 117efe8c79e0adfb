"""``ornitail rig check RIG``: the ports of this machine, and one row per instrument of the rig file.

Exit codes: 0 every instrument ok; 3 an instrument failed (absent port, no reply, wrong device); 5 an instrument's
port is held by another process (and none failed otherwise); 2 a mistake in the rig file.
"""

from __future__ import annotations

import dataclasses
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from ornitail.app.cli_output import emit, json_option

if TYPE_CHECKING:
    from ornitail.acquisition.rig_check import RigCheck

# The rig check and the sweep command import numpy, python-can and pyserial: imported where used, so that
# `ornitail rig --help` stays fast.


def rig_check_record(check: RigCheck) -> dict[str, Any]:
    """The JSON record of a rig check (readings keyed with their units, as :class:`InstrumentCheck` holds them)."""
    return {
        "rig_file": str(check.rig_file),
        "rig_name": check.rig_name,
        "simulated": check.simulated,
        "ok": check.ok,
        "serial_ports": [dataclasses.asdict(port) for port in check.serial_ports],
        "can_interfaces_searched": list(check.can_interfaces_searched),
        "can_channels": [dataclasses.asdict(channel) for channel in check.can_channels],
        "instruments": [dataclasses.asdict(instrument) for instrument in check.instruments],
    }


def rig_check_exit_code(check: RigCheck) -> int:
    """0 every instrument ok, 3 any failed, else 5 when a port is held by another process."""
    from ornitail.acquisition.rig_check import STATUS_FAILED, STATUS_IN_USE
    from ornitail.app.sweep_session import EXIT_BUSY, EXIT_FAILED

    statuses = {instrument.status for instrument in check.instruments}
    if STATUS_FAILED in statuses:
        return EXIT_FAILED
    return EXIT_BUSY if STATUS_IN_USE in statuses else 0


def _value_text(value: float | int | bool) -> str:
    if isinstance(value, bool):
        return "yes" if value else "no"
    return f"{value:.5g}" if isinstance(value, float) else str(value)


def _result_text(instrument: dict[str, Any]) -> str:
    from ornitail.acquisition.rig_check import STATUS_IN_USE

    if instrument["status"] != "ok":
        word = "in use" if instrument["status"] == STATUS_IN_USE else "failed"
        return f"{word}: {instrument['problem']} (set by {instrument['rig_file_key']})"
    reading = " ".join(
        f"{name}={_value_text(value)}" for name, value in instrument["reading"].items()
    )
    return f"ok  {instrument['identity']}; read {reading}"


def _render(record: dict[str, Any]) -> str:
    simulated = ", simulated instruments" if record["simulated"] else ""
    ports = ", ".join(
        f"{port['device']} ({port['description']})" for port in record["serial_ports"]
    )
    channels = ", ".join(
        f"{channel['interface']}:{channel['channel']}" for channel in record["can_channels"]
    )
    searched = ", ".join(record["can_interfaces_searched"]) or "no interface"
    instruments = record["instruments"]
    name_width = max([len("instrument"), *(len(row["instrument"]) for row in instruments)])
    route_width = max([len("route"), *(len(row["route"]) for row in instruments)])
    lines = [
        f"rig {record['rig_name']} ({record['rig_file']}){simulated}",
        f"serial ports found: {ports or 'none'}",
        f"CAN channels found: {channels or 'none'} (searched {searched})",
        f"{'instrument':<{name_width}}  {'route':<{route_width}}  result",
        *(
            f"{row['instrument']:<{name_width}}  {row['route']:<{route_width}}  {_result_text(row)}"
            for row in instruments
        ),
    ]
    ok_count = sum(1 for row in instruments if row["status"] == "ok")
    lines.append(
        f"all {ok_count} instruments ok"
        if record["ok"]
        else f"{ok_count} of {len(instruments)} instruments ok"
    )
    return "\n".join(lines)


@click.group("rig")
def rig_group() -> None:
    """Rig files and the instruments they name."""


@rig_group.command("check")
@click.argument("rig_path", metavar="RIG", type=click.Path(path_type=Path))
@json_option
def rig_check_command(rig_path: Path, as_json: bool) -> None:
    """List the serial ports and CAN channels found, then connect each instrument of the rig file RIG in turn:
    identify it, read one sample, bring it to its safe state, disconnect. Nothing moves. Exit codes: 0 all ok,
    2 rig file error, 3 an instrument failed, 5 a port is in use by another process."""
    from ornitail.acquisition.rig_check import check_rig

    check = check_rig(rig_path)
    emit(rig_check_record(check), as_json, _render)
    sys.exit(rig_check_exit_code(check))
