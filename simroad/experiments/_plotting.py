"""matplotlib for the figures: pyplot on the Agg backend, and a figure saved and closed."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from simroad.core.validation import ensure_writable_dir

__all__ = ["pyplot", "save_figure", "start_figure"]


def pyplot() -> Any:
    """``matplotlib.pyplot`` on the Agg backend (no display needed).

    Imported on the first figure, not with the package: selecting the backend must
    precede the first import of pyplot, and only drawing needs matplotlib.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def start_figure(out: Path) -> Any:
    """:func:`pyplot` for drawing the figure file ``out``, once its folder is made
    sure to exist and be writable (so that no drawing is lost at the end)."""
    plt = pyplot()
    ensure_writable_dir("out", out.parent if str(out.parent) else ".")
    return plt


def save_figure(fig: Any, path: str | Path, *, dpi: int, metadata: dict[str, Any] | None = None) -> None:
    """Lay ``fig`` out tightly, write it to ``path`` at ``dpi`` (with the file's
    ``metadata``, matplotlib's by default) and close it to free its memory."""
    fig.tight_layout()
    fig.savefig(path, dpi=dpi, metadata=metadata)
    pyplot().close(fig)
