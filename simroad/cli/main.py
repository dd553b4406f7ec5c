"""Run the ``simroad`` command line: parse, dispatch to the subcommand, map errors to exit codes.

Exit status (:data:`EXIT_CODES`): 0 on success; 1 when a requirement (``--require``)
is violated (a regression); 2 on bad input (with a message saying what to fix, naming
the flag or config key; no traceback); 3 when a component failed -- a detector raised
or returned no mask (a message naming it), an episode of a sweep failed, or simroad
itself crashed (with the traceback) -- so that CI tells a crash from a regression;
130 when interrupted. Every value is checked as it is parsed
(:mod:`simroad.cli.types`) or by the library's config objects, before any episode,
frame or training runs. ``--help`` exits through ``SystemExit(0)`` as argparse does.
"""

from __future__ import annotations

import sys
import traceback
from collections.abc import Sequence

from simroad.cli.index import COMMANDS, command_parser
from simroad.errors import DetectorFailedError, SimroadError

__all__ = ["EXIT_CODES", "main"]

#: The command line's exit statuses and what each means.
EXIT_CODES = {
    0: "success",
    1: "a --require gate was missed",
    2: "bad input (the message says what to fix)",
    3: "a component failed: a detector raised or returned no mask, a sweep's episode failed, or a crash",
    130: "interrupted (Ctrl-C)",
}


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line on ``argv`` (default ``sys.argv[1:]``); return the exit status."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] not in COMMANDS:  # no command, --help or a wrong one: the summaries answer
        parser, sub = command_parser()
        for name, summary in COMMANDS.items():
            sub.add_parser(name, help=summary)
    else:
        # The full parser reads its defaults from the library (the simulator, scikit-learn):
        # built only when a command runs, so that ``simroad --help`` answers at once.
        from simroad.cli.parser import build_parser

        parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # argparse: --help exits 0 as usual; a bad value returns 2
        if exc.code in (0, None):
            raise
        return exc.code if isinstance(exc.code, int) else 2
    try:
        return int(args.func(args))
    except DetectorFailedError as exc:
        print(f"simroad {args.command}: a detector failed: {exc}", file=sys.stderr)
        return 3
    except SimroadError as exc:
        print(f"simroad {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    except Exception:
        traceback.print_exc()
        print(f"simroad {args.command}: crashed (the traceback above says where)", file=sys.stderr)
        return 3


if __name__ == "__main__":
    raise SystemExit(main())
