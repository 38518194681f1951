"""The ``liquidtouch`` command line: thin commands over the Python API.

Each submodule registers its commands on :data:`app`; heavy imports happen
inside the commands so that ``--help`` stays fast. Every
:class:`~liquidtouch.errors.LiquidTouchError` becomes one line
``error: <message>`` on stderr and exit status 2; Ctrl-C becomes
``error: interrupted`` and exit status 130. Output-path options are checked
as typed (:mod:`liquidtouch.cli.paths`): ``--out model.json/`` is refused.
``-v`` / ``--verbose`` (before the command) shows the log on stderr: ``-v`` INFO
(device connections, trial steps, recordings), ``-vv`` DEBUG (every command and reply);
without it only warnings.
"""

from __future__ import annotations

import logging
import sys

import typer
import typer.main

try:  # typer >= 0.25 vendors click
    from typer._click import exceptions as click_exc
except ImportError:  # pragma: no cover - older typer uses click itself
    from click import exceptions as click_exc

from liquidtouch import __version__
from liquidtouch.cli import (
    dataset,
    experiments,
    extract,
    fit,
    live,
    models,
    record,
    rig,
    simulate,
)
from liquidtouch.cli.flags import name_flags
from liquidtouch.cli.format import cut_values
from liquidtouch.cli.paths import guard_output_paths
from liquidtouch.errors import LiquidTouchError

INTERRUPTED = 130
"""Exit status after Ctrl-C (128 + SIGINT), as shells report it."""

app = typer.Typer(
    name="liquidtouch",
    help="Estimate fill height, viscosity and identity of a liquid in a closed bottle "
    "from GelSight tactile sloshing signals.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    rich_markup_mode=None,  # help texts carry units in brackets ("[mm]"): not markup
)


def _version(value: bool) -> None:
    if value:
        typer.echo(f"liquidtouch {__version__}")
        raise typer.Exit()


LOG_FORMAT = "%(levelname)s %(name)s: %(message)s"
"""How log records are shown on stderr."""


def configure_logging(verbose: int) -> int:
    """Log to stderr at WARNING (``verbose`` 0), INFO (1) or DEBUG (2 or more); return the level.

    ``logging.basicConfig`` does nothing when the root logger already has handlers (an
    application's, or pytest's), so the ``liquidtouch`` logger gets the level too.
    """
    level = (logging.WARNING, logging.INFO, logging.DEBUG)[min(max(verbose, 0), 2)]
    logging.basicConfig(level=level, stream=sys.stderr, format=LOG_FORMAT)
    if verbose:
        logging.getLogger("liquidtouch").setLevel(level)
    return level


@app.callback()
def _main(
    version: bool = typer.Option(
        False, "--version", callback=_version, is_eager=True, help="Print the version and exit."
    ),
    verbose: int = typer.Option(
        0,
        "--verbose",
        "-v",
        count=True,
        show_default=False,
        help="Log to stderr: -v INFO (connections, steps), -vv DEBUG (every command).",
    ),
) -> None:
    """liquidtouch: liquid properties from dynamic tactile sensing."""
    configure_logging(verbose)


for _module in (fit, simulate, extract, models, experiments, dataset, record, rig, live):
    _module.register(app)


class _Interrupted(Exception):
    """Ctrl-C inside a command, carried past typer (which would turn it into a silent exit)."""


def _command():
    """The click command of :data:`app`, with output paths checked and Ctrl-C carried out."""
    command = guard_output_paths(typer.main.get_command(app))
    invoke = command.invoke

    def invoke_or_interrupt(ctx):
        try:
            return invoke(ctx)
        except KeyboardInterrupt:
            raise _Interrupted from None

    command.invoke = invoke_or_interrupt
    return command


def error_exit(message: str) -> int:
    """Print ``error: message`` on stderr (values over 80 characters cut); return the exit
    status for bad input."""
    print(f"error: {cut_values(message)}", file=sys.stderr)
    return 2


def main(argv: list[str] | None = None) -> int:
    """Run the command line on ``argv``; return the exit status (never raises on bad input)."""
    try:
        result = _command().main(args=argv, prog_name="liquidtouch", standalone_mode=False)
        if result == INTERRUPTED:  # Ctrl-C while typer parsed the command line
            raise _Interrupted
    except LiquidTouchError as exc:
        return error_exit(name_flags(str(exc)))
    except click_exc.NoArgsIsHelpError as exc:
        typer.echo(exc.ctx.get_help() if exc.ctx else str(exc))
        return 0
    except click_exc.UsageError as exc:
        hint = f" (see '{exc.ctx.command_path} --help')" if exc.ctx else ""
        return error_exit(exc.format_message() + hint)
    except click_exc.ClickException as exc:
        return error_exit(exc.format_message())
    except typer.Exit as exc:
        return exc.exit_code
    except (typer.Abort, KeyboardInterrupt, _Interrupted):
        print("error: interrupted", file=sys.stderr)
        return INTERRUPTED
    except FileNotFoundError as exc:
        return error_exit(f"file not found: {exc.filename or exc}")
    except OSError as exc:  # permissions, full disk, a directory where a file was expected
        where = f"{exc.filename}: " if exc.filename else ""
        return error_exit(f"{where}{exc.strerror or exc}")
    except RecursionError:
        return error_exit("the input is nested too deeply to be one of liquidtouch's files")
    except MemoryError:
        return error_exit("out of memory: the input is too large (see the README's limits)")
    return result if isinstance(result, int) else 0


def run() -> None:
    """Console-script entry point."""
    sys.exit(main())
