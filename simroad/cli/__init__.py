"""The ``simroad`` command line (a thin layer over the library)."""

from __future__ import annotations

from simroad.cli.main import build_parser, main

__all__ = ["build_parser", "main"]
