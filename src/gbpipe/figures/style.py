"""Shared figure style and the one save function (every configured format, atomic)."""

from __future__ import annotations

import os
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from contextvars import ContextVar
from pathlib import Path
from typing import Any

import matplotlib
import numpy as np

matplotlib.use("Agg")  # headless: Snakemake jobs and CI have no display

import matplotlib.pyplot as plt  # noqa: E402

from gbpipe.io import atomic_path  # noqa: E402

__all__ = ["plt", "save", "new", "db", "FORMATS", "DEFAULT_FORMATS", "formats"]

#: File formats a figure may be saved in (config ``figures.formats``). PNG is always one:
#: the report embeds it and every caption refers to it.
FORMATS = ("png", "pdf", "svg")
#: Formats of :func:`save` outside a :func:`formats` block: PNG for the report, PDF (text
#: as TrueType, editable) for papers
DEFAULT_FORMATS = ("png", "pdf")
_formats: ContextVar[tuple[str, ...]] = ContextVar("gbpipe_figure_formats",
                                                   default=DEFAULT_FORMATS)

plt.rcParams.update({
    "figure.dpi": 110, "savefig.dpi": 150, "font.size": 9, "axes.grid": True,
    "grid.alpha": 0.3, "axes.titlesize": 10, "legend.fontsize": 8,
    "pdf.fonttype": 42,
})


def new(nrows: int = 1, ncols: int = 1, **kw):
    """A figure and axes with the gbpipe defaults (constrained layout)."""
    kw.setdefault("figsize", (7.0, 4.2))
    return plt.subplots(nrows, ncols, layout="constrained", **kw)


def db(x: Any, power: bool = False) -> np.ndarray:
    """Level in dB of an amplitude (``20 log10 |x|``) or, with ``power``, of a power
    (``10 log10 x``). Zero maps to a finite floor far below any plotted range (a line is
    never broken by ``-inf``)."""
    return (10.0 if power else 20.0) * np.log10(np.maximum(np.abs(np.asarray(x)), 1e-300))


@contextmanager
def formats(names: Sequence[str]) -> Iterator[tuple[str, ...]]:
    """Save every figure of the block in ``names`` (config ``figures.formats``).

    Parameters
    ----------
    names : sequence of str
        Formats of :data:`FORMATS`, ``png`` among them; saved in the order given, PNG
        first.

    Raises
    ------
    ValueError
        An unknown or repeated format, or no PNG.
    """
    names = tuple(names)
    bad = [n for n in names if n not in FORMATS]
    if bad or "png" not in names or len(set(names)) != len(names):
        raise ValueError(f"figure formats must be distinct names of {list(FORMATS)} with "
                         f"'png' among them (the report embeds it); got {list(names)}")
    token = _formats.set(("png", *(n for n in names if n != "png")))
    try:
        yield _formats.get()
    finally:
        _formats.reset(token)


def save(fig, stem: str | os.PathLike) -> list[Path]:
    """Save ``fig`` as ``<stem>.<format>`` for each format of the enclosing
    :func:`formats` block (default :data:`DEFAULT_FORMATS`): temp file, then rename."""
    stem = Path(stem)
    if stem.suffix.lstrip(".") in FORMATS:
        stem = stem.with_suffix("")
    out = []
    for ext in _formats.get():
        path = stem.with_suffix(f".{ext}")
        with atomic_path(path) as tmp:
            fig.savefig(tmp, format=ext)
        out.append(path)
        # the other formats keep the layout the PNG's draw computed: the constrained layout
        # is solved once per figure, not once per file (about a fifth of a figure's time)
        fig.set_layout_engine("none")
    plt.close(fig)
    return out
