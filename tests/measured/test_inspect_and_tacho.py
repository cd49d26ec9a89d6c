"""``python -m gbpipe inspect FILE`` and the pulse-count tacho."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
from measured_bench import FS, PPR, bench, write_csv, write_tdms

from gbpipe.__main__ import main
from gbpipe.measured import list_channels, read


def test_list_channels_tdms(tmp_path):
    b = bench()
    write_tdms(tmp_path / "r.tdms", b)
    rows = {r["name"]: r for r in list_channels(tmp_path / "r.tdms")}
    assert set(rows) == {"Measurements/Torque", "Measurements/Tacho"}
    tq = rows["Measurements/Torque"]
    assert tq["length"] == b.t.size and tq["unit"] == "kN*m" and tq["nan"] == 0
    assert tq["min"] == b.torque.min() * 1e-3 and tq["max"] == b.torque.max() * 1e-3
    assert tq["timebase"].startswith(f"{FS:g} Hz")


def test_cli_csv_with_nan(tmp_path, capsys):
    b = bench(n=500)
    x = b.torque.copy()
    x[[3, 7, 9]] = np.nan
    write_csv(tmp_path / "s.csv", {"time": b.t, "torque [N*m]": x, "volts": b.tacho})
    assert main(["inspect", str(tmp_path / "s.csv"), "--time", "time"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].split()[:3] == ["channel", "length", "time"]
    line = next(ln for ln in out if ln.startswith("torque [N*m]"))
    assert " 500 " in line and line.rstrip().endswith(" 3") and "N*m" in line
    assert f"{np.nanmax(x):.6g}" in line and f"{np.nanmin(x):.6g}" in line


def test_cli_process_and_error(tmp_path):
    """Through the interpreter, as the user runs it; a missing file is exit status 1."""
    b = bench(n=200)
    write_csv(tmp_path / "s.csv", {"a": b.torque, "b": b.tacho})
    ok = subprocess.run([sys.executable, "-m", "gbpipe", "inspect", str(tmp_path / "s.csv")],
                        capture_output=True, text=True, check=False)
    assert ok.returncode == 0 and "none (give time: or sample_rate:)" in ok.stdout
    bad = subprocess.run([sys.executable, "-m", "gbpipe", "inspect", str(tmp_path / "x.csv")],
                         capture_output=True, text=True, check=False)
    assert bad.returncode == 1 and "no such file" in bad.stderr


def test_pulse_count_channel(tmp_path):
    """A sampled cumulative counter: one pulse per increment, within half a sample."""
    b = bench()
    count = np.searchsorted(b.pulses, b.t, side="right")  # pulses up to each sample
    write_csv(tmp_path / "c.csv", {"time": b.t, "count": count})
    spec = {"files": {"c": {"path": "c.csv", "time": "time"}}, "sample_rate": FS,
            "signals": {"tacho": {"file": "c", "channel": "count", "quantity": "tacho",
                                  "tacho": "count", "pulses_per_rev": PPR}}}
    ds = read(spec, tmp_path)
    true = b.pulses[b.pulses > 0]
    assert ds["pulse_time"].size == true.size
    np.testing.assert_allclose(ds["pulse_time"].values, true, atol=0.5 / FS)
