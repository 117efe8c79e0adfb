"""The ``ornitail`` console command: one subcommand group per area, no logic of its own."""

from __future__ import annotations

import sys

import click

from ornitail.core.errors import UserInputError


class _UserErrorsAsOneLine(click.Group):
    """A click group that turns :class:`UserInputError` into one line on stderr and exit code 2."""

    def invoke(self, ctx: click.Context):  # noqa: D102 - click override
        try:
            return super().invoke(ctx)
        except UserInputError as error:
            click.echo(f"ornitail: error: {error}", err=True)
            sys.exit(2)


@click.group(cls=_UserErrorsAsOneLine)
@click.version_option(package_name="ornitail")
def main() -> None:
    """Wind-tunnel and free-flight tools for the tail of the DelFly II flapping-wing MAV."""


def _register_area_commands() -> None:
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
    main.add_command(runs_command)
    main.add_command(sim_group)
    main.add_command(sweep_command)


_register_area_commands()
