"""The physics of the modal benchmark's random cases (tests/identify/modal_cases.py),
checked from the record alone with scipy, against openTorsion and gbpipe's own import.

* The chain's modes are openTorsion's; gbpipe's import of the assembly
  (``from_assembly`` + ``build_chain``) has the same undamped frequencies (modal damping
  leaves them unchanged), all in 5-400 Hz, damping ratios in 0.5-10 %.
* The H1 FRF of the record (``scipy.signal.csd`` / ``welch``, motor torque to torque
  meter) has the magnitude of the chain's FRF ``C (j w I - A)^-1 B`` where coherent, and peaks at
  openTorsion's modal frequencies within the resolution (every lightly damped mode the
  chain's FRF shows as a peak where the record is coherent).
* The torque meter's lines, resolved in the angle domain of the shaft angle the tacho
  voltage gives (2 pi per rising crossing), stand out at drawn orders and nowhere else.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from gbpipe.model.chain import build_chain
from gbpipe.model.opentorsion_io import from_assembly
from tests.identify import modal_cases as mc

FS, SEGMENT = 2000.0, 2.0
DF = 1.0 / SEGMENT


@pytest.fixture(scope="module")
def case():
    return mc.simulate(11, "tacho", fs=FS, duration=30.0, min_gap_hz=2 * DF)


def spectra(case):
    u, y = case.signals["motor torque"], case.signals["torque meter"]
    n = int(SEGMENT * FS)
    f, puu = signal.welch(u, FS, nperseg=n)
    _, pyy = signal.welch(y, FS, nperseg=n)
    _, puy = signal.csd(u, y, FS, nperseg=n)
    return f, puy / puu, np.abs(puy) ** 2 / (puu * pyy), pyy - np.abs(puy) ** 2 / puu


def test_modes_are_opentorsions_and_gbpipes_import_agrees(case):
    f, z = case.frequency_hz, case.damping
    assert np.all((f >= 5.0) & (f <= 400.0)) and np.all((z >= 0.005) & (z <= 0.1))
    assert np.min(np.diff(f)) >= 2 * DF
    fu = build_chain(from_assembly(case.assembly)).mechanism.undamped_frequencies()
    np.testing.assert_allclose(np.sort(fu), f, rtol=1e-9)


def test_h1_is_the_chains_frf_and_peaks_at_its_modes(case):
    f, h1, coh, _ = spectra(case)
    a, b, c, d = case.plant
    h = np.array([c[0] @ np.linalg.solve(2j * np.pi * fk * np.eye(len(a)) - a, b[:, 0])
                  for fk in f]) + d[0, 0]
    good = (coh >= 0.9) & (f > 0)
    assert good.sum() >= 50  # a coherent band of at least 25 Hz: the test is not empty
    # magnitudes: the record's samples carry the zero-order hold's half-sample delay,
    # a phase the continuous FRF has not
    assert np.median(np.abs(20 * np.log10(np.abs(h1[good] / h[good])))) <= 0.5
    # every lightly damped mode (<= 2 %) the chain's FRF shows as a peak within a bin of
    # it, where the record is coherent
    peaks, _ = signal.find_peaks(20 * np.log10(np.abs(h[1:])), prominence=3.0)
    peaks += 1
    checked = 0
    for fm, zm in zip(case.frequency_hz, case.damping, strict=True):
        near = peaks[np.abs(f[peaks] - fm) <= DF]
        if zm > 0.02 or near.size == 0 or coh[near[0]] < 0.9:
            continue
        checked += 1
        # the largest |H1| within 2 bins: at the mode within the resolution, or a
        # quarter of the half-power bandwidth (the estimate's scatter flattens the top)
        w = np.abs(f - fm) <= 2 * DF
        f_top = f[w][np.argmax(np.abs(h1[w]))]
        assert abs(f_top - fm) <= max(DF, zm * fm / 2), f"H1 peak {f_top} for {fm:.2f} Hz"
    assert checked >= 1


def test_order_lines_at_the_drawn_orders_of_the_tacho_speed(case):
    # the shaft angle from the tacho voltage alone: 2 pi per rising mid-level crossing
    t, v = case.signals["time"], case.signals["tacho"]
    i = np.flatnonzero((v[:-1] < 2.5) & (v[1:] >= 2.5))
    tc = t[i] + (2.5 - v[i]) / (v[i + 1] - v[i]) * (t[i + 1] - t[i])
    f_shaft = (tc.size - 1) / (tc[-1] - tc[0])  # mean shaft frequency [Hz]
    assert case.shaft_hz[0] <= f_shaft <= case.shaft_hz[1]
    span = (t >= tc[0]) & (t <= tc[-1])
    theta = np.interp(t[span], tc, 2 * np.pi * np.arange(tc.size))
    y = case.signals["torque meter"][span]
    y = y - y.mean()

    def amplitude(k):  # of shaft order k in the torque meter (synchronous, angle domain)
        return 2 * abs(np.mean(y * np.exp(-1j * k * theta)))

    # an order stands out when 20 x the broadband level beside it (orders k +- 0.2-0.4);
    # the broadband alone reached 8 x over 20 random cases, a weak line's path to the
    # meter may leave it below
    stands_out = [k for k in range(1, int(mc.LINE_F_MAX // f_shaft) + 1)
                  if amplitude(k) >= 20 * np.median([amplitude(k + d) for d in
                                                     (-0.4, -0.3, -0.2, 0.2, 0.3, 0.4)])]
    assert stands_out, "no order line in the torque meter"
    assert set(stands_out) <= set(case.orders.tolist()), (stands_out, case.orders)
