"""The ``magsail`` console command: signals are held from the first instruction.

SIGINT and SIGTERM that arrive while the command imports its modules (about a second: MuJoCo,
NumPy, pydantic) are held and turn into exit status 130, instead of a traceback from inside an
import or a process killed by the signal; while a verb runs, :func:`magsail_mj.cli.main` turns
them into ``KeyboardInterrupt`` (exit 130); after it has ended they are ignored (its status
stands).
"""

from __future__ import annotations

import os
import signal
import sys

__all__ = ["main"]


def main() -> int:
    """Import the command line with signals held, run it, and exit with its status (130 if a
    signal arrived while held)."""
    pending: list[int] = []

    def hold(signum: int, _frame: object) -> None:
        pending.append(signum)

    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, hold)
    try:  # the heavy imports (MuJoCo's extension, NumPy, pydantic, the runner), with signals held
        # imported here, not at module top, so that signals are held while they load
        from magsail_mj import cli
    except KeyboardInterrupt:
        pending.append(signal.SIGINT)
    if pending:  # nothing has been written yet: leave at once, without the interpreter's clean-up
        print("interrupted", file=sys.stderr, flush=True)
        sys.stdout.flush()
        os._exit(130)
    for sig in (signal.SIGINT, signal.SIGTERM):  # the verb installs its own handlers
        signal.signal(sig, signal.default_int_handler)
    try:
        code = cli.main()
    except KeyboardInterrupt:  # before or after the verb's own handling (argument parsing, exit)
        print("interrupted", file=sys.stderr)
        code = 130
    finally:  # a signal after the verb has ended changes nothing, also while the interpreter exits
        for sig in (signal.SIGINT, signal.SIGTERM):
            signal.signal(sig, signal.SIG_IGN)
        cli.forget_handled_interrupt()  # no further interrupt can arrive: the status 130 stands
    if code == 130:  # the folder is consistent; leave without the interpreter's finalisation, which
        # raced the record store's input/output thread after an interrupt (a fatal GIL error, -6)
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(130)
    return code


if __name__ == "__main__":
    sys.exit(main())
