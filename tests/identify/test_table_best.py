"""The best pairing per input is chosen by the numbers (achieved bandwidth, then fit)."""

from gbpipe.identify import best_pairings


def _row(pairing, inputs, version, achieved, fit, method="moesp"):
    return {"pairing": pairing, "inputs": inputs, "version": version, "method": method,
            "achieved_hz": achieved, "fit_pct": fit, "test": "t", "profile": "p"}


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
    assert best["Tdrv"]["runner_up"] == "Tdrv_to_wdrv: 36 Hz"
    assert best["Tdrn"]["pairing"] == "Tdrn_to_Mdrn"
    # with clean data allowed the paper's cross pairing wins
    with_clean = {b["inputs"]: b for b in best_pairings(rows, ["clean", "raw", "tsa"])}
    assert with_clean["Tdrv"]["pairing"] == "Tdrv_to_wdrn"
