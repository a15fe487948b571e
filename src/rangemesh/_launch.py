"""The ``rangemesh`` console script: the command line, Ctrl-C during start-up included.

Importing the command line takes a moment (NumPy, the kernels); a Ctrl-C then
must end the command as it does later, with status 130 and one line, not a
traceback. So this module imports nothing until it is called.
"""

import sys


def main() -> int:
    """Run the command line; status 130 when interrupted while it loads."""
    try:
        from .cli import main as cli_main
    except KeyboardInterrupt:
        print("rangemesh: interrupted (SIGINT) while starting", file=sys.stderr)
        return 130
    return cli_main()
