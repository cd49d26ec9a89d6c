"""The simulated campaign of a described drivetrain end to end in the workflow
(config/examples/shaftline_campaign.yaml on the CI config): campaign -> model -> identify,
the identified models checked against the chain's true FRFs (``model/truth.nc``) by an
FRF evaluated here from the identified state-space matrices."""

from __future__ import annotations

import numpy as np

from gbpipe import io
from tests.workflow.runs import copy_repo, snakemake

EXAMPLE = "config/examples/shaftline_campaign.yaml"


def _frf(A, B, C, D, f, dt):
    """Discrete FRF C (zI − A)⁻¹ B + D at z = exp(j 2π f dt), single input and output."""
    n = A.shape[0]
    z = np.exp(2j * np.pi * f * dt)
    return np.array([(C @ np.linalg.solve(zz * np.eye(n) - A, B) + D)[0, 0] for zz in z])


def test_shaftline_campaign_identified_against_its_truth(tmp_path):
    work = copy_repo(tmp_path)
    targets = ["results/identify/speed_up_square_pbsid.nc", "results/model/truth.nc"]
    snakemake(work, EXAMPLE, "--nolock", *targets)
    ds = io.read(work / targets[0])
    truth = io.read(work / targets[1])
    f = truth.frequency.values
    dt = float(ds.sample_time)
    band = (f >= 5.0) & (f <= 100.0)      # the chain's modes below 70 Hz and above
    checked = 0
    for i in range(ds.sizes["model"]):
        if str(ds.version.values[i]) != "raw":
            continue
        n = int(ds.order.values[i])
        A, B = ds.A.values[i][:n, :n], ds.B.values[i][:n]
        C, D = ds.C.values[i][:, :n], ds.D.values[i]
        g = _frf(A, B, C, D, f, dt)
        p = str(ds.pairing.values[i])
        sel = truth.sel(pairing=p)
        g_true = (sel.frf_true_real + 1j * sel.frf_true_imag).values[:, 0, 0]
        err_db = np.abs(20 * np.log10(np.abs(g / g_true)))
        # measured-like records (ripple-driven, sensor noise): the model follows the truth
        # over the band, and its largest peak is the truth's resonance (same grid point,
        # ±1 step of 1.8 %)
        assert np.median(err_db[band]) < 1.0, p
        assert abs(np.argmax(np.abs(g)) - np.argmax(np.abs(g_true))) <= 1, p
        checked += 1
    assert checked == 3
