"""The removal trade-off figure: its numbers against values computed by hand from
hand-built separation metrics (2 methods, 3 rpm bins, 2 families, one mode band)."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from gbpipe.errors import DataError
from gbpipe.figures import removal_plots
from gbpipe.figures.removal_plots import removal_tradeoff_figure

BANDS = ["mode_30.0Hz", "elsewhere"]
FAMILIES = ["gear_mesh", "shaft"]

# (change_db rows: mode band, elsewhere), (leftover_db rows: families)
CASES = {
    # Worst mode change is |-0.5| (a negative change counts by its size); the 25 dB
    # "elsewhere" change must be ignored; in the middle bin both families are removed
    # perfectly (+inf), so that bin's point is clipped to the top of the axis.
    "tsa": ([[0.2, -0.5, 0.3], [25.0, 25.0, 25.0]],
            [[70.0, np.inf, 80.0], [75.0, np.inf, 62.0]]),
    # One family perfect in the first bin: the other (40 dB) is that bin's attenuation.
    "vkf": ([[-2.5, 1.5, 0.05], [-40.0, -40.0, -40.0]],
            [[40.0, 50.0, 90.0], [np.inf, 45.0, 55.0]]),
}


def _metrics(method: str, change: list, leftover: list,
             with_leftover: bool = True) -> xr.Dataset:
    """A dataset with the layout of ``separation_metrics`` (plus the method attribute)."""
    rpm_lower = np.array([1000.0, 1200.0, 1400.0])
    data = {
        "attenuation_db": (("family", "rpm"), np.asarray(leftover) - 10.0),
        "distortion_db": (("band", "rpm"), np.full((2, 3), -30.0)),
        "change_db": (("band", "rpm"), np.asarray(change)),
        "crossing": (("family", "band", "rpm"), np.zeros((2, 2, 3), dtype=np.int8)),
    }
    if with_leftover:
        data["leftover_db"] = (("family", "rpm"), np.asarray(leftover))
    return xr.Dataset(
        data,
        coords={"rpm": ("rpm", rpm_lower + 100.0), "rpm_lower": ("rpm", rpm_lower),
                "rpm_upper": ("rpm", rpm_lower + 200.0), "family": FAMILIES, "band": BANDS,
                "band_lower": ("band", [26.0, 10.0]), "band_upper": ("band", [34.0, 500.0])},
        attrs={"method": method},
    )


@pytest.fixture(scope="module")
def drawn(tmp_path_factory):
    out = tmp_path_factory.mktemp("removal")
    datasets = {m: _metrics(m, *case) for m, case in CASES.items()}
    figures = []
    save = removal_plots.save
    # keep the figure the function saves, to read back what it drew
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(removal_plots, "save", lambda fig, stem: figures.append(fig)
                   or save(fig, stem))
        numbers = removal_tradeoff_figure(datasets, {"png": out / "tradeoff.png",
                                                     "caption": out / "tradeoff.rst"},
                                          tolerance_db=1.0, target_db=60.0)
    return numbers, out, figures[0]


def test_numbers_are_the_worst_values_over_mode_bands_and_bins(drawn):
    numbers, _, _ = drawn
    assert set(numbers) == {f"{m} {k}" for m in CASES
                            for k in ("worst change dB", "worst attenuation dB")}
    for method, (change, leftover) in CASES.items():
        mode_row = np.asarray(change)[BANDS.index("mode_30.0Hz")]
        assert numbers[f"{method} worst change dB"] == pytest.approx(np.abs(mode_row).max())
        assert numbers[f"{method} worst attenuation dB"] == pytest.approx(np.min(leftover))
    # Not the "elsewhere" band (25 dB) and not the signed maximum (0.3 dB).
    assert numbers["tsa worst change dB"] == pytest.approx(0.5)
    assert numbers["vkf worst attenuation dB"] == pytest.approx(40.0)


def test_points_drawn_are_each_bins_worst_change_and_attenuation(drawn):
    _, _, fig = drawn
    left, right = fig.axes[:2]
    # the clipped (+inf) points sit one common height above every finite attenuation
    finite = [v for _, lo in CASES.values() for v in np.min(lo, axis=0) if np.isfinite(v)]
    top = max(60.0, *finite) + 10.0
    points = [c.get_offsets() for c in left.collections]
    for k, (change, leftover) in enumerate(CASES.values()):
        x = np.abs(np.asarray(change)[0])
        y = np.min(leftover, axis=0)
        clipped = np.isposinf(y)
        drawn_finite, drawn_clipped = points[2 * k], points[2 * k + 1]
        np.testing.assert_allclose(drawn_finite, np.c_[x[~clipped], y[~clipped]])
        np.testing.assert_allclose(drawn_clipped, np.c_[x[clipped], np.full(clipped.sum(),
                                                                              top)])
        # right panel: the worst change along the bin centres [rev/min]
        line = right.lines[k]
        np.testing.assert_allclose(line.get_xdata(), [1100.0, 1300.0, 1500.0])
        np.testing.assert_allclose(line.get_ydata(), x)
    # the targets: tolerance at 1 dB (vertical), attenuation target at 60 dB
    assert any(np.allclose(ln.get_xdata(), 1.0) for ln in left.lines)
    assert any(np.allclose(ln.get_ydata(), 60.0) for ln in left.lines)


def test_caption_names_best_methods_and_those_meeting_both_targets(drawn):
    _, out, _ = drawn
    text = (out / "tradeoff.rst").read_text()
    assert "least broadband damage: tsa (0.50 dB)" in text
    assert "most attenuation: tsa (62.00 dB)" in text
    # no wall-clock number: the same config gives the same caption
    assert "fastest" not in text and " s)" not in text and "MB" not in text
    # tsa: <= 0.5 dB change and >= 62 dB in every bin; vkf fails both.
    assert "in every rpm bin: tsa\n" in text
    assert "worst mode-band change 2.50 dB, worst attenuation 40.00 dB" in text
    assert "1 point(s) with +inf attenuation" in text


def test_metrics_without_leftover_are_refused(tmp_path):
    ds = _metrics("drs", *CASES["tsa"], with_leftover=False)
    with pytest.raises(DataError, match="leftover_db"):
        removal_tradeoff_figure({"drs": ds}, {"png": tmp_path / "f.png",
                                              "caption": tmp_path / "f.rst"})


def _with_crossing(ds: xr.Dataset, bins: list[int], order_value: float = 2.0
                   ) -> xr.Dataset:
    """``ds`` with a shaft order crossing the 30 Hz mode (inside the 26-34 Hz mode band)
    in ``bins``."""
    order = np.full((2, 2, 3), np.nan)
    mode = np.full((2, 2, 3), np.nan)
    order[1, 0, bins], mode[1, 0, bins] = order_value, 30.0
    return ds.assign(crossing_order=(("family", "band", "rpm"), order),
                     crossing_mode=(("family", "band", "rpm"), mode))


def test_worst_crossing_is_the_largest_change_among_the_crossing_bins():
    datasets = {m: _with_crossing(_metrics(m, *case), [2]) for m, case in CASES.items()}
    # bin 2 is the only crossing: |0.3| (tsa) beats 0.05 (vkf), although vkf's -2.5 dB in
    # bin 0 is the worst change overall; 'elsewhere' (25 dB) never counts
    assert removal_plots.worst_crossing(datasets) == (0, 2, True)
    datasets = {m: _with_crossing(_metrics(m, *case), []) for m, case in CASES.items()}
    assert removal_plots.worst_crossing(datasets) == (0, 0, False)


def test_crossing_zoom_reads_the_residual_against_the_random_only_twin(tmp_path):
    # a sweep 1000 -> 1600 rpm; residual "same" is the random-only record itself (0 dB),
    # "double" twice it (+6.02 dB = 20 log10 2 in every bin)
    fs, dur = 1000.0, 30.0
    t = np.arange(int(fs * dur)) / fs
    f0, rate = 1000.0 / 60.0, 600.0 / 60.0 / dur
    theta = 2 * np.pi * (f0 * t + 0.5 * rate * t**2)
    k = np.arange(1, int(theta[-1] / (2 * np.pi)) + 1)
    pulses = (-f0 + np.sqrt(f0**2 + 2 * rate * k)) / rate
    noise = np.random.default_rng(4).standard_normal(t.size)
    record = noise + 3.0 * np.cos(2 * theta)
    # bin 1 (1200-1400 rpm): order 18/13 is at 30 Hz at 1300 rpm, the bin's centre
    base = _with_crossing(_metrics("tsa", *CASES["tsa"]), [1], order_value=18 / 13)
    datasets = {"same": base.assign(residual=("time", noise)),
                "double": base.assign(residual=("time", 2 * noise))}
    numbers = removal_plots.removal_crossing_figure(
        datasets, record, noise, fs, pulses,
        {"png": tmp_path / "crossing.png", "caption": tmp_path / "crossing.rst"},
        fine_bins=6)
    assert numbers["same zoom worst change dB"] == pytest.approx(0.0, abs=1e-9)
    assert numbers["double zoom worst change dB"] == pytest.approx(20 * np.log10(2.0))
    assert (numbers["order"], numbers["mode Hz"]) == (18 / 13, 30.0)
    assert (numbers["rpm lower"], numbers["rpm upper"]) == (1000.0, 1600.0)
    # the caption's crossing speed (mode / order) lies inside the zoom
    assert "order 1.38462 through the 30.0 Hz mode at 1300 rev/min" in (
        tmp_path / "crossing.rst").read_text()


def test_worst_crossing_without_a_finite_crossing_bin_falls_back():
    """Crossing bins whose change is NaN everywhere (no waterfall frame): the worst
    mode-band bin instead, marked as no crossing; nothing finite at all is refused."""
    datasets = {m: _with_crossing(_metrics(m, *case), [1]) for m, case in CASES.items()}
    datasets = {m: ds.assign(change_db=ds.change_db.where(ds.rpm != ds.rpm[1]))
                for m, ds in datasets.items()}
    band, rpm, crossed = removal_plots.worst_crossing(datasets)
    worst = np.fmax.reduce(np.stack([np.abs(ds.change_db.values[:1])
                                     for ds in datasets.values()]), axis=0)
    assert (band, rpm, crossed) == (0, int(np.nanargmax(worst)), False)
    empty = {m: ds.assign(change_db=ds.change_db * np.nan) for m, ds in datasets.items()}
    with pytest.raises(DataError, match="change_db"):
        removal_plots.worst_crossing(empty)
