"""The design figure and its caption numbers, from a synthetic prediction whose band is
known by construction."""

from __future__ import annotations

import numpy as np
import pytest

from gbpipe import identify
from gbpipe.figures import design_plots
from gbpipe.figures.design_plots import design_numbers, fig_design


def _design(edge_hz: float):
    """A SISO integrator y = u / (j w) excited by white noise below ``edge_hz`` only, with a
    small white output noise: identifiable from f_min up to the grid point below the edge."""
    f = np.geomspace(5.0, 350.0, 120)
    g = (1.0 / (2j * np.pi * f))[:, None, None]
    phi_r = np.where(f < edge_hz, 1.0, 0.0)
    t = np.concatenate([np.ones((f.size, 1, 1)), g], axis=1)
    return identify.predict(t, ["u", "y"], ["r"],
                            [{"name": "p", "inputs": ["u"], "outputs": ["y"]}], {"p": g},
                            {"r": phi_r}, {"y": np.full(f.size, 1e-9)}, f, 10, 10_000, 1.0)


def test_predicted_band_is_the_last_grid_point_below_the_excitation_edge():
    ds = _design(100.0)
    f = ds.frequency.values
    assert float(ds.predicted_hz[0]) == pytest.approx(f[f < 100.0][-1])


def test_caption_numbers_pair_prediction_and_achievement(tmp_path, monkeypatch):
    designs = {"a square": _design(100.0), "b tapered": _design(200.0)}
    achieved = {("a square", "p"): 80.0}
    stem, caption = tmp_path / "fig_design", tmp_path / "fig_design.rst"
    figures = []
    save = design_plots.save
    monkeypatch.setattr(design_plots, "save",
                        lambda fig, stem: figures.append(fig) or save(fig, stem))
    numbers = fig_design(designs, stem, caption, achieved)
    pa = float(designs["a square"].predicted_hz[0])
    pb = float(designs["b tapered"].predicted_hz[0])
    assert numbers["a square, p"] == f"predicted {pa:.0f} Hz, achieved 80 Hz ({80 / pa:.2f} x)"
    assert numbers["b tapered, p"] == f"predicted {pb:.0f} Hz"
    text = caption.read_text()
    assert f"a square, p: predicted {pa:.0f} Hz" in text and "b tapered" in text
    # what is drawn: one bar per test as long as its predicted band, the achieved band
    # as a tick at 80 Hz on the first test's bar; the right panel is the test with the
    # widest band (b tapered), with the 1 dB tolerance
    bars_ax, err_ax = figures[0].axes[:2]
    widths = sorted(p.get_width() for p in bars_ax.patches)
    assert widths == pytest.approx(sorted([pa, pb]))
    ticks = [ln.get_xdata() for ln in bars_ax.lines if ln.get_marker() == "|"]
    assert [list(np.asarray(t)[np.isfinite(t)]) for t in ticks] == [[80.0], []]
    assert "b tapered" in err_ax.get_title()
    assert any(np.allclose(ln.get_ydata(), 1.0) for ln in err_ax.lines)
    assert (tmp_path / "fig_design.pdf").read_bytes()[:5] == b"%PDF-"


def test_no_achievement_for_a_zero_prediction_gives_no_ratio():
    ds = _design(4.0)          # no excitation at or above f_min: nothing identifiable
    assert float(ds.predicted_hz[0]) == 0.0
    assert design_numbers({"t": ds}, {("t", "p"): 12.0})["t, p"] == (
        "predicted 0 Hz, achieved 12 Hz")
