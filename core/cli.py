"""The ``ornitail`` console command: one subcommand group per area, no logic of its own."""

from __future__ import annotations

import importlib
import sys
from collections.abc import Iterator, Mapping, MutableMapping
from dataclasses import dataclass
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


@dataclass(frozen=True)
class LazyCommand:
    """A command imported only when it is used (its module may import numpy, casadi, Qt ...).

    ``target`` and each of ``extras`` are ``"module:attribute"``; the ``extras`` are added to the loaded group.
    ``help`` is the command's first sentence, which its group's ``--help`` lists without importing the module
    (``tests/test_cli_startup.py`` checks that the listing matches the loaded commands').
    """

    target: str
    help: str
    extras: tuple[str, ...] = ()

    def load(self) -> click.Command:
        """Import the command (and add the extras to it)."""
        command = _attribute(self.target)
        for extra in self.extras:
            command.add_command(_attribute(extra))
        return command


def _attribute(target: str) -> Any:
    module_name, _, attribute = target.partition(":")
    return getattr(importlib.import_module(module_name), attribute)


_AREA_COMMANDS = {
    "calibration": LazyCommand(
        "ornitail.calibration.cli:calibration_group", "Balance, hot-wire and tunnel calibrations."
    ),
    "demo": LazyCommand(
        "ornitail.core.demo:demo_command",
        "Run the study's tunnel protocol on the simulated rig and print cycle-averaged forces.",
    ),
    "design": LazyCommand(
        "ornitail.design.cli:design_group", "Tail design: geometry, trend fits, proposals."
    ),
    "export": LazyCommand(
        "ornitail.core.export_cli:export_command",
        "Export run directories or processed tables (CSV) to MATLAB, Parquet or NetCDF with units.",
    ),
    "flight": LazyCommand(
        "ornitail.flight.cli:flight_group",
        "Free-flight system identification.",
        extras=("ornitail.flight.campaign_cli:campaign_command",),
    ),
    "gap": LazyCommand(
        "ornitail.gap.cli:gap_group", "Sim-to-real gap: where it lies, which effect, how far."
    ),
    "gui": LazyCommand(
        "ornitail.gui.cli:gui_command",
        "Open the desktop window: live view, cycle view, controls, sweeps, runs and design.",
    ),
    "process": LazyCommand(
        "ornitail.balance.process_cli:process_command",
        "Cycle-average recorded runs; write tail contribution, stability derivatives and figures.",
    ),
    "rig": LazyCommand(
        "ornitail.acquisition.rig_check_cli:rig_group", "Rig files and the instruments they name."
    ),
    "runs": LazyCommand(
        "ornitail.acquisition.runs_cli:runs_command",
        "List recorded runs, oldest first; runs whose process died are shown as crashed.",
    ),
    "sim": LazyCommand(
        "ornitail.sim.cli:sim_group", "Physics simulator of the DelFly II with its tail."
    ),
    "sweep": LazyCommand(
        "ornitail.acquisition.sweep_cli:sweep_command",
        "Run the sweep PLAN on the rig: check every set point against the rig's limits, then move, settle and "
        "record each point.",
    ),
}
"""The area commands of ``ornitail``, imported on first use so that ``ornitail --help`` starts fast."""


class _LazyCommands(MutableMapping[str, click.Command]):
    """A group's ``commands`` mapping whose :class:`LazyCommand` entries are imported when first looked up.

    Listing names and ``in`` do not import anything; getting a command (click's ``get_command``, ``items()``,
    ``values()``) imports it once and keeps it.
    """

    def __init__(self, lazy: Mapping[str, LazyCommand]) -> None:
        self.lazy = dict(lazy)
        self.loaded: dict[str, click.Command] = {}

    def __getitem__(self, name: str) -> click.Command:
        if name not in self.loaded:
            self.loaded[name] = self.lazy.pop(name).load()
        return self.loaded[name]

    def __setitem__(self, name: str, command: click.Command) -> None:
        self.lazy.pop(name, None)
        self.loaded[name] = command

    def __delitem__(self, name: str) -> None:
        if name in self.lazy:
            del self.lazy[name]
        else:
            del self.loaded[name]

    def __contains__(self, name: object) -> bool:
        return name in self.lazy or name in self.loaded

    def __iter__(self) -> Iterator[str]:
        return iter([*self.loaded, *self.lazy])

    def __len__(self) -> int:
        return len(self.loaded) + len(self.lazy)


class LazyGroup(click.Group):
    """A click group whose ``lazy_commands`` are imported on first use; ``--help`` lists them without importing
    them (click's "lazy loading of subcommands" pattern, with each command's first sentence stored)."""

    def __init__(
        self, *args: Any, lazy_commands: Mapping[str, LazyCommand] | None = None, **kwargs: Any
    ) -> None:
        super().__init__(*args, **kwargs)
        self.lazy_commands = _LazyCommands(lazy_commands or {})
        self.lazy_commands.update(self.commands)
        self.commands = self.lazy_commands

    def format_commands(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        """As click's, with the stored first sentence of each command not loaded yet."""
        commands = self.lazy_commands
        names = [
            name
            for name in self.list_commands(ctx)
            if name in commands.lazy or not commands[name].hidden
        ]
        if not names:
            return
        limit = formatter.width - 6 - max(len(name) for name in names)
        rows = []
        for name in names:
            if name in commands.lazy:  # a stand-in shortens the sentence as click does
                stand_in = click.Command(name, help=commands.lazy[name].help)
                rows.append((name, stand_in.get_short_help_str(limit)))
            else:
                rows.append((name, commands[name].get_short_help_str(limit)))
        with formatter.section("Commands"):
            formatter.write_dl(rows)


class _MainGroup(_UserErrorsAsOneLine, LazyGroup):
    """The ``ornitail`` group: user errors as one line; area commands imported on first use."""


@click.group(cls=_MainGroup, lazy_commands=_AREA_COMMANDS)
@click.version_option(package_name="ornitail")
def main() -> None:
    """Wind-tunnel and free-flight tools for the tail of the DelFly II flapping-wing MAV."""
