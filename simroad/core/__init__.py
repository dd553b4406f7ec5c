"""The leaf every simroad package stands on: radiometry, constants, names, lane
geometry, validation. It imports nothing else of simroad but :mod:`simroad.errors`.

Import its modules by name (``simroad.core.radiometry``); this package loads none
of them, so that importing one stays cheap.
"""
