"""Report captions written next to each figure, with the figure's key numbers.

Snakemake's report reads a caption file per figure when ``snakemake --report`` runs; the
figure rules write these captions as outputs, so the numbers in them (modes, dB removed,
match bandwidth) are those of the run that made the figure.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path

from gbpipe.io import atomic_path

__all__ = ["write_caption"]


def write_caption(path: str | os.PathLike, title: str, paper: str, shows: str,
                  numbers: Mapping[str, str] | None = None) -> Path:
    """Write a reStructuredText caption.

    Parameters
    ----------
    path : path-like
        Target ``.rst`` file.
    title : str
        Short title (first line, bold).
    paper : str
        Which paper figure it reproduces (or "extension").
    shows : str
        One or two sentences on what is plotted.
    numbers : mapping, optional
        Key numbers, label -> formatted value with unit.
    """
    lines = [f"**{title}** — {paper}.", "", shows, ""]
    for label, value in (numbers or {}).items():
        lines.append(f"* {label}: {value}")
    path = Path(path)
    with atomic_path(path) as tmp:
        tmp.write_text("\n".join(lines).rstrip() + "\n")
    return path
