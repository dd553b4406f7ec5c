"""The ``simroad`` command line (a thin layer over the library): :func:`simroad.cli.main.main`.

The parser with every command is :func:`simroad.cli.parser.build_parser`; this package
imports neither, so that ``simroad --help`` loads no simulator.
"""
