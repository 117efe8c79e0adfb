"""The ``ornitail`` console command: one subcommand group per area, no logic of its own."""

from __future__ import annotations

import sys
from typing import Any, NoReturn

import click

from ornitail.core.errors import UserInputError


def _one_line(text: str) -> str:
    """``text`` with its line breaks turned into spaces."""
    return " ".join(line.strip() for line in str(text).splitlines() if line.strip())


def _exit_with_click_error(error: click.ClickException) -> NoReturn:
    """Print a click usage or parameter error as one line and exit with its code (2 for usage)."""
    message = _one_line(error.format_message())
    context = getattr(error, "ctx", None)
    if isinstance(error, click.UsageError) and context is not None:
        message += f" (see: {context.command_path} --help)"
    click.echo(f"ornitail: error: {message}", err=True)
    sys.exit(error.exit_code)


class _UserErrorsAsOneLine(click.Group):
    """A click group that turns :class:`UserInputError` into one line on stderr and exit code 2.

    Click's own usage and parameter errors (unknown option, missing or ill-typed value) become one
    line too, with click's exit code (2).
    """

    def make_context(self, *args: Any, **kwargs: Any) -> click.Context:  # noqa: D102
        try:
            return super().make_context(*args, **kwargs)
        except click.ClickException as error:
            _exit_with_click_error(error)

    def invoke(self, ctx: click.Context):  # noqa: D102 - click override
        try:
            return super().invoke(ctx)
        except UserInputError as error:
            click.echo(f"ornitail: error: {_one_line(str(error))}", err=True)
            sys.exit(2)
        except click.ClickException as error:
            _exit_with_click_error(error)


@click.group(cls=_UserErrorsAsOneLine)
@click.version_option(package_name="ornitail")
def main() -> None:
    """Wind-tunnel and free-flight tools for the tail of the DelFly II flapping-wing MAV."""


def _register_area_commands() -> None:
    from ornitail.acquisition.rig_check_cli import rig_group
    from ornitail.acquisition.runs_cli import runs_command
    from ornitail.acquisition.sweep_cli import sweep_command
    from ornitail.balance.process_cli import process_command
    from ornitail.calibration.cli import calibration_group
    from ornitail.core.demo import demo_command
    from ornitail.design.cli import design_group
    from ornitail.flight.campaign_cli import campaign_command
    from ornitail.flight.cli import flight_group
    from ornitail.gap.cli import gap_group
    from ornitail.gui.cli import gui_command
    from ornitail.sim.cli import sim_group

    main.add_command(calibration_group)
    main.add_command(demo_command)
    main.add_command(design_group)
    flight_group.add_command(campaign_command)
    main.add_command(flight_group)
    main.add_command(gap_group)
    main.add_command(gui_command)
    main.add_command(process_command)
    main.add_command(rig_group)
    main.add_command(runs_command)
    main.add_command(sim_group)
    main.add_command(sweep_command)


_register_area_commands()
