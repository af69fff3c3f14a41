"""Every command and command group of ``spherestep`` answers ``--help`` with an example."""

import pytest
import typer

from spherestep.cli import app, main


def _command_paths(command, path=()):
    """``(path, command)`` for every registered command and group below the Click ``command``, depth first."""
    if path:
        yield path, command
    if hasattr(command, "commands"):  # a group
        for name in sorted(command.commands):
            yield from _command_paths(command.commands[name], path + (name,))


PATHS = [path for path, _ in _command_paths(typer.main.get_command(app))]


def test_the_walk_finds_the_commands():
    names = {" ".join(p) for p in PATHS}
    assert {"demo", "plan", "report", "packings", "design", "design show", "run"} <= names


@pytest.mark.parametrize("path", PATHS, ids=[" ".join(p) for p in PATHS])
def test_help_shows_an_example(path, capsys):
    assert main([*path, "--help"]) == 0
    captured = capsys.readouterr()
    assert "Example" in captured.out, captured.out
    assert captured.err == ""


@pytest.mark.parametrize("path, flags", [
    (("packings",), {"--json"}), (("design", "show"), {"--json"}), (("plan",), {"--json"}),
    (("demo",), {"--json", "--quiet"}), (("report",), {"--json", "--quiet"}),
])
def test_output_for_scripts_and_people(path, flags):
    command = dict(_command_paths(typer.main.get_command(app)))[path]
    assert flags <= {opt for param in command.params for opt in param.opts}
