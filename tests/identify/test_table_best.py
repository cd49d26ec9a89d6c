"""The best pairing per input is chosen by the numbers (status, achieved bandwidth, then
fit), never a failed model, and NaN never wins."""

import math

from gbpipe.identify import best_pairings


def _row(pairing, inputs, version, achieved, fit, method="moesp", status="ok"):
    return {"pairing": pairing, "inputs": inputs, "version": version, "method": method,
            "achieved_hz": achieved, "fit_pct": fit, "test": "t", "profile": "p",
            "status": status}


def test_best_pairing_is_the_widest_band_on_the_chosen_versions():
    rows = [
        _row("Tdrv_to_wdrv", "Tdrv", "raw", 36.0, 90.0),
        _row("Tdrv_to_Mdrv", "Tdrv", "raw", 310.0, 80.0),
        _row("Tdrv_to_Mdrv", "Tdrv", "tsa", 320.0, 80.0, method="n4sid"),
        # clean data beat everything but are not measured-like: not considered
        _row("Tdrv_to_wdrn", "Tdrv", "clean", 350.0, 99.0),
        _row("Tdrn_to_wdrn", "Tdrn", "raw", "54.0", "70.0"),   # CSV strings
        _row("Tdrn_to_Mdrn", "Tdrn", "raw", "54.0", "75.0"),   # tie: higher fit wins
    ]
    best = {b["inputs"]: b for b in best_pairings(rows, ["raw", "tsa"])}
    assert best["Tdrv"]["pairing"] == "Tdrv_to_Mdrv"
    assert best["Tdrv"]["version"] == "tsa" and best["Tdrv"]["method"] == "n4sid"
    assert best["Tdrv"]["runner_up"] == "Tdrv_to_wdrv: 36 Hz (ok)"
    assert best["Tdrn"]["pairing"] == "Tdrn_to_Mdrn"
    # with clean data allowed the paper's cross pairing wins
    with_clean = {b["inputs"]: b for b in best_pairings(rows, ["clean", "raw", "tsa"])}
    assert with_clean["Tdrv"]["pairing"] == "Tdrv_to_wdrn"


def test_a_failed_row_seen_first_neither_wins_nor_blocks_its_pairing():
    # the old bug: a failed row with a NaN fit and a kept bandwidth, seen first, compared
    # False against everything (NaN) and so stayed the pairing's best, and then the best
    # of all, over a 300 Hz model of the same pairing
    rows = [
        _row("Tdrn_to_Mdrn", "Tdrn", "raw", "350.0", "nan", status="failed"),
        _row("Tdrn_to_Mdrn", "Tdrn", "raw", "300.0", "97.0", method="pbsid"),
        _row("Tdrn_to_wdrn", "Tdrn", "raw", "120.0", "90.0"),
    ]
    best = best_pairings(rows, ["raw"])[0]
    assert best["status"] == "ok" and best["method"] == "pbsid"
    assert float(best["achieved_hz"]) == 300.0
    assert best["runner_up"] == "Tdrn_to_wdrn: 120 Hz (ok)"


def test_ok_ranks_before_poor_and_nan_never_first():
    rows = [
        # widest, but poor (e.g. unstable): an ok model of another pairing wins
        _row("Tdrv_to_Mdrv", "Tdrv", "raw", 350.0, 20.0, status="poor"),
        _row("Tdrv_to_wdrv", "Tdrv", "raw", 40.0, 88.0),
        # a NaN band (first) must not beat a finite one of the same pairing
        _row("Tdrn_to_wdrn", "Tdrn", "raw", math.nan, 95.0, status="poor"),
        _row("Tdrn_to_wdrn", "Tdrn", "raw", 12.0, 40.0, method="pbsid", status="poor"),
    ]
    best = {b["inputs"]: b for b in best_pairings(rows, ["raw"])}
    assert best["Tdrv"]["pairing"] == "Tdrv_to_wdrv"
    assert best["Tdrv"]["runner_up"] == "Tdrv_to_Mdrv: 350 Hz (poor)"
    assert best["Tdrn"]["method"] == "pbsid" and best["Tdrn"]["status"] == "poor"


def test_an_input_with_only_failed_rows_has_no_best():
    rows = [_row("Tdrv_to_wdrn", "Tdrv", "raw", 5.0, math.nan, status="failed"),
            _row("Tdrn_to_wdrn", "Tdrn", "raw", 50.0, 80.0)]
    assert [b["inputs"] for b in best_pairings(rows, ["raw"])] == ["Tdrn"]
