"""The package layers: imports only go down, no module imports itself in a circle,
and importing the maths (filters, detector, metrics) starts no simulator.

The layers (README, "Layout"): ``errors`` → ``core`` → ``camera`` → ``noise`` → ``envs``
→ ``control`` → ``experiments`` → ``cli``, with ``filters`` and ``metrics`` on the core
alone and ``detector`` on the core and the filters.
"""

from __future__ import annotations

import ast
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "simroad"

_BASE = {"errors", "core", "simroad"}
#: Package -> the other packages it may import (``simroad`` is the root module: the
#: version, ENV_ID, the error base class and OpenCV without IPP).
ALLOWED: dict[str, set[str]] = {
    "errors": set(),
    "core": {"errors"},
    "simroad": {"errors", "core"},
    "filters": _BASE,
    "metrics": _BASE,
    "detector": _BASE | {"filters"},
    "camera": _BASE,
    "noise": _BASE | {"camera"},
    "envs": _BASE | {"camera", "noise"},
    "control": _BASE | {"camera", "noise", "envs", "filters", "detector", "metrics"},
    "experiments": _BASE | {"camera", "noise", "envs", "control", "filters", "detector", "metrics"},
    "cli": _BASE | {"camera", "noise", "envs", "control", "filters", "detector", "metrics", "experiments"},
    "__main__": {"cli"},
}


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _package_of(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "simroad"


def simroad_imports(source: str) -> list[tuple[int, str]]:
    """``(line, module)`` of every import of a simroad module in ``source``, at module
    level and inside functions (``if TYPE_CHECKING:`` blocks too)."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names = [node.module]
        elif isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        else:
            continue
        found += [(node.lineno, name) for name in names if name == "simroad" or name.startswith("simroad.")]
    return found


def climbing_imports(files: dict[str, str]) -> list[str]:
    """The imports among ``files`` (module name -> source) that climb the layers."""
    bad = []
    for module, source in files.items():
        own = _package_of(module)
        if own not in ALLOWED:
            bad.append(f"{module}: package {own!r} has no layer; add it to ALLOWED")
            continue
        for line, target in simroad_imports(source):
            other = _package_of(target)
            if other != own and other not in ALLOWED[own]:
                bad.append(f"{module}:{line} imports {target} ({own} may import only {sorted(ALLOWED[own])})")
    return bad


def _sources() -> dict[str, str]:
    return {_module_name(p): p.read_text(encoding="utf-8") for p in sorted(PACKAGE.rglob("*.py"))}


def test_no_import_climbs_a_layer():
    assert climbing_imports(_sources()) == []


@pytest.mark.parametrize(
    "source",
    [
        "from simroad.envs import RoadCamEnv\n",
        "def f():\n    from simroad.noise.compose import make_weather\n    return make_weather\n",
        "def f():\n    import simroad.experiments.ablate\n",
    ],
)
def test_layer_check_catches_an_upward_import(source):
    files = _sources()
    files["simroad.filters._probe"] = source
    bad = climbing_imports(files)
    assert len(bad) == 1 and bad[0].startswith("simroad.filters._probe:")


def _cycles(files: dict[str, str]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan) of the import graph."""
    graph = {}
    for module, source in files.items():
        targets = set()
        for _line, target in simroad_imports(source):
            while target not in files and "." in target:  # 'from simroad.camera.codes import X' names a module
                target = target.rsplit(".", 1)[0]
            if target != module and target in files and not module.startswith(target + "."):
                targets.add(target)  # a submodule importing its own package's __init__ runs after it: no cycle
        graph[module] = targets
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    sys.setrecursionlimit(max(sys.getrecursionlimit(), 10_000))
    for v in graph:
        if v not in index:
            visit(v)
    return found


def test_no_import_cycle_between_modules():
    assert _cycles(_sources()) == []


def test_cycle_check_catches_a_cycle():
    files = {"simroad.a": "from simroad.b import x\n", "simroad.b": "def f():\n    from simroad.a import y\n"}
    assert _cycles(files) == [["simroad.a", "simroad.b"]]


def test_every_module_is_at_most_450_lines():
    long = {m: s.count("\n") for m, s in _sources().items() if s.count("\n") > 450}
    assert long == {}


HEAVY = ("gymnasium", "highway_env", "pygame", "matplotlib")


@pytest.mark.parametrize(
    "module", ["simroad.filters", "simroad.detector", "simroad.metrics", "simroad.core.radiometry"]
)
def test_importing_the_maths_starts_no_simulator(module):
    code = f"import sys, {module}; print(','.join(sorted(m for m in {HEAVY!r} if m in sys.modules)))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == ""


def test_cli_help_loads_no_scikit_learn():
    code = textwrap.dedent(
        """
        import contextlib, io, sys
        from simroad.cli.main import main
        with contextlib.redirect_stdout(io.StringIO()), contextlib.suppress(SystemExit):
            main(["--help"])
        print("sklearn" in sys.modules)
        """
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "False"


def test_import_simroad_registers_the_env_before_or_after_gymnasium():
    for order in ("import simroad, gymnasium", "import gymnasium, simroad"):
        code = f"{order}; print(simroad.ENV_ID in gymnasium.registry, 'highway_env' in __import__('sys').modules)"
        out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
        assert out.split() == ["True", "False"], order
