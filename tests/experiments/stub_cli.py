"""``python stub_cli.py ARGS``: the ``simroad`` command line with every sweep cell run by
:func:`stub_cell.stub_cell` instead of a simulated episode, for tests of how the command
line runs, interrupts and refuses sweeps (the directory of this file must be on
``PYTHONPATH``: sweep workers import ``stub_cell`` by name)."""

from __future__ import annotations

import functools
import sys

from stub_cell import stub_cell

from simroad.cli import commands
from simroad.cli.main import main

commands.run_ablation = functools.partial(commands.run_ablation, cell_fn=stub_cell)

if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
