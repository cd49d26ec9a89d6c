"""The one save function: every configured format, each a real drawing of the figure."""

from __future__ import annotations

import re

import numpy as np
import pytest

from gbpipe.figures.style import DEFAULT_FORMATS, db, formats, new, save


def _figure():
    fig, ax = new(figsize=(4.0, 3.0))
    ax.plot([0.0, 1.0, 2.0], [0.0, 1.0, 0.0])
    ax.set_xlabel("frequency [Hz]")
    return fig


def _png_size(path):
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    return int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")


def test_default_formats_are_png_and_pdf_of_the_figure_size(tmp_path):
    paths = save(_figure(), tmp_path / "f.png")
    assert [p.suffix for p in paths] == [f".{e}" for e in DEFAULT_FORMATS] == [".png", ".pdf"]
    # 4 x 3 in at savefig.dpi 150 -> 600 x 450 px; the PDF page is 288 x 216 pt
    assert _png_size(paths[0]) == (600, 450)
    box = re.search(rb"/MediaBox \[ *0 0 ([\d.]+) ([\d.]+) *\]", paths[1].read_bytes())
    assert box and (float(box[1]), float(box[2])) == (288.0, 216.0)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f.pdf", "f.png"]


def test_formats_block_writes_exactly_its_formats_png_first(tmp_path):
    with formats(["svg", "png"]) as chosen:
        assert chosen == ("png", "svg")
        paths = save(_figure(), tmp_path / "g")
    assert [p.name for p in paths] == ["g.png", "g.svg"]
    assert _png_size(paths[0]) == (600, 450)
    svg = paths[1].read_text()
    assert re.search(r'<svg[^>]*width="288pt"[^>]*height="216pt"', svg)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["g.png", "g.svg"]
    # the block ends: back to the default
    assert [p.suffix for p in save(_figure(), tmp_path / "h")] == [".png", ".pdf"]


@pytest.mark.parametrize("bad", [["pdf"], ["png", "jpeg"], ["png", "png"], []])
def test_formats_without_png_or_unknown_are_refused(bad):
    with pytest.raises(ValueError, match="figure formats must be distinct names"):
        with formats(bad):
            pass


def test_db_of_amplitudes_and_powers():
    # 20 log10 |x| of an amplitude (complex: its modulus), 10 log10 of a power
    np.testing.assert_allclose(db(np.array([10.0, -0.1, 3.0 + 4.0j])), [20.0, -20.0,
                                                                          20 * np.log10(5.0)])
    np.testing.assert_allclose(db(np.array([100.0, 1e-3]), power=True), [20.0, -30.0])
    # zero stays finite, below any plotted range
    assert np.isfinite(db(0.0)) and db(0.0) < -1000.0

