"""The ``simroad`` command line (a thin layer over the library)."""

from __future__ import annotations

from simroad.cli.main import main
from simroad.cli.parser import build_parser

__all__ = ["build_parser", "main"]
