"""The ``rangemesh`` command: ``mesh``, ``info``, ``eval``, ``demo``, ``batch`` and ``live``.

User errors print one line on stderr (``rangemesh: error: ...``) and exit
with status 2; no traceback. Outputs are written atomically.

One module a command (``mesh``, ``demo``, ``batch``, ``info``, ``eval``,
``live``), which declares it once: its ``NAME``, its line in ``rangemesh -h``
(``HELP``), the top of its own ``-h`` (``DESCRIPTION``), its flags
(``add_arguments(parser)``) and its work (``handle(args)``, the exit status).
`COMMANDS` lists them once; the flags they share are in
`rangemesh.cli.options`, the rest they share in `rangemesh.cli.common`.
"""

from __future__ import annotations

import argparse
import os
import signal
import sys

from .._version import __version__
from ..timing import timed
from . import batch, demo, info, live, mesh
from . import eval as eval_
from .common import Terminated, UserError, _one_line, _os_message, _signals_raise
from .options import _Parser

__all__ = ["main", "build_parser", "Terminated", "UserError"]

COMMANDS = (mesh, demo, batch, info, eval_, live)  # the order `rangemesh -h` lists them


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``rangemesh`` command."""
    p = _Parser(
        prog="rangemesh",
        description="Discontinuity-preserving adaptive triangle meshes from range images "
                    "(Garcia & Sappa, IEEE SMC-B 2004).",
    )
    p.add_argument("--version", action="version", version=f"rangemesh {__version__}")
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser)
    for command in COMMANDS:  # argparse refills the text: DESCRIPTION's line breaks do not show
        command.add_arguments(sub.add_parser(command.NAME, help=command.HELP,
                                             description=command.DESCRIPTION))
    return p


def main(argv=None) -> int:
    """Entry point of the ``rangemesh`` command; returns the exit status.

    Every expected failure ends here as one line on stderr: bad input, bad
    options, unreadable or unwritable files, a missing optional extra, not
    enough memory for what was asked: exit status 2. ``batch`` returns 1
    when some inputs failed. Ctrl-C, SIGTERM and SIGHUP end the command with
    128 + the signal number (130, 143, 129) after temporary files are removed.
    """
    parser = build_parser()
    argv = sys.argv[1:] if argv is None else list(argv)
    if not argv:  # `rangemesh` alone: the usage, then argparse's missing-command error (status 2)
        parser.print_usage(sys.stderr)
        *others, last = (command.NAME for command in COMMANDS)
        parser.error(f"give a command: {', '.join(others)} or {last} (rangemesh -h says more)")
    args = parser.parse_args(argv)
    handle = next(command.handle for command in COMMANDS if command.NAME == args.command)
    clock = timed()
    try:
        with _signals_raise():
            return handle(args)
    except BrokenPipeError:  # the reader went away (`rangemesh ... --json | head`): stop quietly
        sys.stdout = open(os.devnull, "w")  # noqa: SIM115 - Python flushes stdout at exit
        return 128 + 13  # SIGPIPE's status, as a shell reports a killed writer
    except KeyboardInterrupt as exc:
        signum = getattr(exc, "signum", signal.SIGINT)
        print(f"rangemesh: interrupted ({signal.Signals(signum).name}) after "
              f"{clock.elapsed:.1f} s", file=sys.stderr)
        return 128 + int(signum)
    except (UserError, ImportError) as exc:  # ImportError: an optional extra is missing
        message = _one_line(exc)
    except OSError as exc:
        message = _os_message(exc)
    except MemoryError as exc:
        message = _one_line(exc)
        if not message.startswith("not enough memory"):
            message = f"not enough memory ({message})"
    except (ValueError, TypeError) as exc:
        message = _one_line(exc)
    print(f"rangemesh: error: {message}", file=sys.stderr)
    return 2
