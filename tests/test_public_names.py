"""Every public name has one home: a module's ``__all__`` lists only what the module
defines, and a package's ``__init__`` may re-export only its own modules' names."""

from __future__ import annotations

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "simroad"


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def foreign_exports(module: str, source: str, *, is_package: bool) -> list[str]:
    """Names in ``__all__`` of ``module`` that it neither defines nor, as a package,
    imports from one of its own modules."""
    tree = ast.parse(source)
    defined: set[str] = set()
    imported: dict[str, str] = {}
    exported: list[str] = []
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)) and node in tree.body:
            defined.add(node.name)
        elif isinstance(node, (ast.Assign, ast.AnnAssign, ast.AugAssign)):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            for target in targets:
                if (
                    isinstance(target, ast.Name)
                    and target.id == "__all__"
                    and isinstance(node.value, (ast.List, ast.Tuple))
                ):
                    exported += [ast.literal_eval(e) for e in node.value.elts]
                defined.update(n.id for n in ast.walk(target) if isinstance(n, ast.Name))  # also a, b = ...
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            for alias in node.names:
                imported[alias.asname or alias.name] = node.module
    foreign = []
    for name in exported:
        origin = imported.get(name)
        if origin is None and name in defined:
            continue
        if origin is not None and is_package and origin.startswith(module + "."):
            continue
        foreign.append(f"{module}.{name} (from {origin or 'nowhere'})")
    return foreign


def test_every_public_name_has_one_home():
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        found += foreign_exports(
            _module_name(path), path.read_text(encoding="utf-8"), is_package=path.name == "__init__.py"
        )
    assert found == []


def test_a_re_export_from_another_module_is_found():
    source = "from simroad.core.radiometry import GAMMA\nfrom simroad.noise.rain import RainModel\n__all__ = ['GAMMA', 'RainModel']\n"
    assert foreign_exports("simroad.noise", source, is_package=True) == [
        "simroad.noise.GAMMA (from simroad.core.radiometry)"
    ]
    assert foreign_exports("simroad.noise.fog", source, is_package=False) == [
        "simroad.noise.fog.GAMMA (from simroad.core.radiometry)",
        "simroad.noise.fog.RainModel (from simroad.noise.rain)",
    ]
