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
        # click empties both while invoking (``protected_args`` is ``_protected_args`` from click 8.2)
        protected = ctx._protected_args if hasattr(ctx, "_protected_args") else ctx.protected_args
        arguments = [*protected, *ctx.args]
        try:
            return super().invoke(ctx)
        except UserInputError as error:
            command = _invoked_command(ctx, arguments)
            where = _option_of_parameter(command, error.where)
            message = str(error) if where is None else f"{where}: {error.problem}"
            remedy = error.remedy_parameter and _option_of_parameter(
                command, error.remedy_parameter
            )
            if remedy:
                message += f" ({remedy})"
            click.echo(f"ornitail: error: {_one_line(message)}", err=True)
            sys.exit(2)
        except click.ClickException as error:
            _exit_with_click_error(error)


def _invoked_command(ctx: click.Context, arguments: list[str]) -> click.Command:
    """The command the group's ``arguments`` name, down through the groups (``design propose``)."""
    command: click.Command = ctx.command
    args = list(arguments)
    while isinstance(command, click.Group) and args:
        name = args.pop(0)
        subcommand = command.get_command(ctx, name)
        if subcommand is None:
            break
        command = subcommand
    return command


def _option_of_parameter(command: click.Command, where: str) -> str | None:
    """The option (``--starts``) of the invoked command whose parameter a library error names
    (``start_count``), or None: library errors name parameters, files and keys, never command-line flags."""
    for parameter in command.params:
        if isinstance(parameter, click.Option) and parameter.name == where:
            return max(parameter.opts, key=len)
    return None


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
        "ornitail.app.commands.calibration:calibration_group",
        "Balance, hot-wire and tunnel calibrations.",
    ),
    "demo": LazyCommand(
        "ornitail.app.demo:demo_command",
        "Run the study's tunnel protocol on the simulated rig and print cycle-averaged forces.",
    ),
    "design": LazyCommand(
        "ornitail.app.commands.design:design_group", "Tail design: geometry, trend fits, proposals."
    ),
    "export": LazyCommand(
        "ornitail.app.commands.export:export_command",
        "Export run directories or processed tables (CSV) to MATLAB, Parquet or NetCDF with units.",
    ),
    "flight": LazyCommand(
        "ornitail.app.commands.flight:flight_group",
        "Free-flight system identification.",
    ),
    "gap": LazyCommand(
        "ornitail.app.commands.gap:gap_group",
        "Sim-to-real gap: where it lies, which effect, how far.",
    ),
    "gui": LazyCommand(
        "ornitail.app.commands.gui:gui_command",
        "Open the desktop window: live view, cycle view, controls, sweeps, runs and design.",
    ),
    "process": LazyCommand(
        "ornitail.app.commands.process:process_command",
        "Cycle-average recorded runs; write tail contribution, stability derivatives and figures.",
    ),
    "rig": LazyCommand(
        "ornitail.app.commands.rig:rig_group", "Rig files and the instruments they name."
    ),
    "runs": LazyCommand(
        "ornitail.app.commands.runs:runs_command",
        "List recorded runs, oldest first; runs whose process died are shown as crashed.",
    ),
    "sim": LazyCommand(
        "ornitail.app.commands.sim:sim_group", "Physics simulator of the DelFly II with its tail."
    ),
    "sweep": LazyCommand(
        "ornitail.app.commands.sweep:sweep_command",
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
