"""The repeats of one test: one row per mode of the group, its spread over the records."""

from __future__ import annotations

import statistics

import pytest

from gbpipe.identify import GROUP_COLUMNS, group_table_rows


def _row(record, f, z, kind, spread=0.05):
    return {"record": record, "pairing": "p", "method": "pbsid", "frequency_hz": f,
            "damping": z, "frequency_spread_hz": spread, "damping_spread": 0.001,
            "n_orders": 10, "kind": kind, "evidence": f"{kind} in {record}"}


def test_repeats_become_one_row_per_mode_with_their_spread():
    rows = [_row("r1", 24.05, 0.020, "mode"), _row("r2", 24.15, 0.022, "mode"),
            _row("r3", 23.95, 0.019, "mode"),
            # a line one record's test caught, the others did not: a line
            _row("r1", 53.7, 0.004, "harmonic"), _row("r2", 53.6, 0.005, "mode"),
            _row("r3", 53.8, 0.003, "mode"),
            # a pole in one record of three: not repeatable
            _row("r2", 180.0, 0.03, "mode"),
            # a record in no group: a group of one
            _row("solo", 24.2, 0.021, "mode")]
    out = group_table_rows(rows, {"test": ["r1", "r2", "r3"]}, 0.01)
    assert all(tuple(r) == GROUP_COLUMNS for r in out)
    by = {(r["group"], round(r["frequency_hz"])): r for r in out}
    assert len(out) == 4
    m = by["test", 24]
    assert m["kind"] == "mode" and m["n_records"] == 3 and m["records"] == "r3 r1 r2"
    assert m["frequency_hz"] == pytest.approx(statistics.mean([24.05, 24.15, 23.95]))
    assert m["frequency_spread_hz"] == pytest.approx(statistics.stdev([24.05, 24.15, 23.95]))
    assert m["damping_spread"] == pytest.approx(statistics.stdev([0.020, 0.022, 0.019]))
    assert by["test", 54]["kind"] == "harmonic" and "1 of 3" in by["test", 54]["evidence"]
    assert by["test", 180]["kind"] == "spurious" and "1 of 3" in by["test", 180]["evidence"]
    solo = by["solo", 24]
    assert solo["n_records"] == 1 and solo["kind"] == "mode"
    assert solo["frequency_spread_hz"] == 0.05  # one record: its spread over the orders


def test_two_modes_of_one_record_within_the_tolerance_stay_apart():
    # one cluster per record in a match: a record's second cluster starts a new one
    rows = [_row("r1", 100.0, 0.01, "mode"), _row("r1", 100.5, 0.01, "mode"),
            _row("r2", 100.2, 0.01, "mode")]
    out = group_table_rows(rows, {"g": ["r1", "r2"]}, 0.01)
    assert sorted(r["n_records"] for r in out) == [1, 2]
