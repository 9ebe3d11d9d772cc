"""Figures as PNG files: pyplot on the non-interactive Agg backend, imported when first drawn (so
that a command's ``--help`` stays fast), and one way to save and release a figure."""

from __future__ import annotations

from pathlib import Path


def pyplot():
    """matplotlib.pyplot on the Agg backend (no display needed)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save_png(plt, fig, path, dpi: int = 100, **layout) -> Path:
    """Lay out ``fig`` (``layout``: tight_layout's arguments), write it to ``path`` and close it."""
    fig.tight_layout(**layout)
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    return Path(path)
