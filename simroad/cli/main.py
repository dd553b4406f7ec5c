"""Run the ``simroad`` command line: parse, dispatch to the subcommand, map errors to exit codes.

Exit status: 0 on success, 2 on bad input (with a message saying what to fix,
naming the flag or config key; no traceback), 1 when a requirement (``--require``)
is violated, 130 when interrupted. Every value is checked as it is parsed
(:mod:`simroad.cli.types`) or by the library's config objects, before any episode,
frame or training runs. ``--help`` exits through ``SystemExit(0)`` as argparse does.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence

from simroad.cli.index import COMMANDS, command_parser
from simroad.errors import SimroadError

__all__ = ["main"]


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
    except SimroadError as exc:
        print(f"simroad {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    raise SystemExit(main())
