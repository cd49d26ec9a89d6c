"""The documented DaISy protocol on measured records (docs/sysid.md, section "DaISy")."""

from pathlib import Path

import numpy as np
import pytest

from gbpipe.sysid.daisy import load_daisy, run_protocol

DAISY = Path(__file__).resolve().parents[2] / "shared" / "data" / "daisy"

# Test-segment fit % per output as documented in docs/sysid.md (rounded down); the protocol
# is deterministic, so a drop of more than 0.5 points is a regression.
DOCUMENTED = {
    ("robot_arm", "pbsid"): (7, [96.5]),
    ("robot_arm", "moesp"): (4, [95.5]),
    ("robot_arm", "n4sid"): (8, [96.4]),
    ("CD_player_arm", "pbsid"): (6, [72.7, 86.2]),
    ("CD_player_arm", "moesp"): (10, [73.2, 81.6]),
    ("CD_player_arm", "n4sid"): (5, [73.9, 83.5]),
}


def daisy_root() -> Path:
    if not (DAISY / "robot_arm.dat").is_file():
        raise FileNotFoundError(
            f"DaISy records not found in {DAISY}: clone the repository next to the shared/ "
            "folder (shared/data/daisy, see its README.md)"
        )
    return DAISY


@pytest.mark.parametrize(("name", "method"), list(DOCUMENTED))
def test_daisy_protocol_fit(name, method):
    u, y, dt = load_daisy(name, daisy_root())
    u0, y0 = u.copy(), y.copy()
    res = run_protocol(u, y, method, dt)
    order, fits = DOCUMENTED[(name, method)]
    assert res.model.is_stable()
    assert np.max(np.abs(np.linalg.eigvals(res.model.A - res.model.K @ res.model.C))) < 1
    assert res.order == order
    assert np.all(res.test_fit >= np.array(fits) - 0.5), res.test_fit
    # Better than a static gain u -> y fitted on the same estimation segment.
    n = len(u)
    a, b = int(0.6 * n), int(0.8 * n)
    uc, yc = u - u[:a].mean(0), y - y[:a].mean(0)
    g, *_ = np.linalg.lstsq(uc[:a], yc[:a], rcond=None)
    static = 100 * (1 - np.linalg.norm(yc[b:] - uc[b:] @ g, axis=0)
                    / np.linalg.norm(yc[b:] - yc[b:].mean(0), axis=0))
    assert res.test_fit.mean() > static.mean() + 2, (res.test_fit, static)
    np.testing.assert_array_equal(u, u0)
    np.testing.assert_array_equal(y, y0)


def test_load_daisy_errors(tmp_path):
    with pytest.raises(ValueError, match="unknown DaISy record 'nope'"):
        load_daisy("nope", daisy_root())
    with pytest.raises(FileNotFoundError, match="robot_arm.dat not found"):
        load_daisy("robot_arm", tmp_path)
