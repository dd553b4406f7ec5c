"""Run the ``simroad`` command line as ``python -m simroad``."""

from __future__ import annotations

from simroad.cli.main import main

__all__: list[str] = []

if __name__ == "__main__":
    raise SystemExit(main())
