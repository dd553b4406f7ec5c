"""The ``simroad`` commands and their one-line summaries: all ``simroad --help`` needs.

The full parser (:mod:`simroad.cli.parser`) reads its defaults from the library, which
loads the simulator and scikit-learn; :func:`simroad.cli.main.main` builds it only when
a command is given, so ``simroad --help`` answers at once.
"""

from __future__ import annotations

import argparse

from simroad import __version__

__all__ = ["COMMANDS", "DESCRIPTION", "command_parser"]

DESCRIPTION = "Closed-loop camera road detection testbed in bad weather."

#: Command -> one-line summary, in the order ``simroad --help`` lists them.
COMMANDS = {
    "frames": "export camera frames and ground-truth road masks",
    "episode": "run one closed-loop episode and score it",
    "ablate": "run an ablation sweep (resumable) and write its report",
    "report": "rebuild a sweep's tables and figures from results.jsonl",
    "train-detector": "train a road detector like the shipped one",
    "evaluate-detector": "score the detector per filter setting (FNR, FPR, IoU, F1)",
    "filter-effect": "does each filter earn its place? FNR/FPR with and without it on its weather",
    "figure": "draw a documentation figure",
    "videos": "write the demo's videos: one detector episode per noise",
    "realism": "how real do the frames look? appearance statistics against real road photographs",
    "calibrate": "fit a camera profile to your own road photographs (writes a TOML profile)",
}


def command_parser(
    parser_class: type[argparse.ArgumentParser] = argparse.ArgumentParser,
) -> tuple[argparse.ArgumentParser, argparse._SubParsersAction]:
    """The top-level ``simroad`` parser and its (still empty) subcommand group."""
    parser = argparse.ArgumentParser(prog="simroad", description=DESCRIPTION)
    parser.add_argument("--version", action="version", version=f"simroad {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=parser_class)
    sub.required = True
    return parser, sub
