"""gbpipe.model: gain refusal by name, and the truth dataset of the identification pairings."""

from __future__ import annotations

import subprocess
import sys

import control
import numpy as np
import pytest

from gbpipe import model
from gbpipe.config import merge
from gbpipe.errors import ConfigError, UnstableGain
from gbpipe.lti.control_io import to_control


@pytest.mark.parametrize("loop", ["speed_controller", "torque_controller"])
def test_zero_integral_gain_is_not_instability(cfg, loop):
    """ki = 0 leaves an uncoupled integrator (eigenvalue 0): marginal, not unstable."""
    p_only = merge(cfg, {"bench": {loop: {"ki": 0.0}}})
    model.check_stability(p_only)
    ev = np.linalg.eigvals(model.bench_ss(p_only).A)
    assert np.sum(np.abs(ev) < 1e-6) == 2          # the rigid body and the idle integrator
    assert np.all(ev[np.abs(ev) >= 1e-6].real < 0)


def test_unstable_gain_names_the_field(cfg):
    bad = merge(cfg, {"bench": {"torque_controller": {"ki": 50.0}}})
    assert np.linalg.eigvals(model.bench_ss(bad).A).real.max() > 0   # really unstable
    with pytest.raises(UnstableGain) as exc:
        model.check_stability(bad)
    assert exc.value.field == "bench.torque_controller.ki"
    assert isinstance(exc.value, ConfigError) and isinstance(exc.value, ValueError)
    assert "'bench.torque_controller.ki'" in str(exc.value)


def test_truth_dataset_frf_and_modes(cfg):
    pairings = cfg["identify"]["pairings"]
    f = np.geomspace(1.0, 400.0, 50)
    ds = model.truth_dataset(cfg, pairings, f, f_max=400.0, zeta_max=0.2)
    assert list(ds.pairing.values) == [p["name"] for p in pairings]
    for k, p in enumerate(pairings):
        truth = model.truth_model(cfg, p["inputs"], p["outputs"])
        # independent evaluation of the same model by python-control
        ref = control.frequency_response(to_control(truth), 2 * np.pi * f).complex
        ref = ref.reshape(len(p["outputs"]), len(p["inputs"]), f.size)
        g = (ds.frf_true_real + 1j * ds.frf_true_imag).isel(pairing=k).values
        no, ni = len(p["outputs"]), len(p["inputs"])
        np.testing.assert_allclose(g[:, :no, :ni], np.moveaxis(ref, -1, 0), rtol=1e-8,
                                   atol=1e-12 * np.abs(ref).max())
        assert np.isnan(g[:, no:, :]).all() and np.isnan(g[:, :, ni:]).all()
        assert list(ds.output_name.values[k, :no]) == list(p["outputs"])
        assert list(ds.input_name.values[k, :ni]) == list(p["inputs"])
        # the modes by python-control (poles of the upper half-plane, away from 0)
        with np.errstate(invalid="ignore", divide="ignore"):   # the rigid-body pole at 0
            wn, zeta, poles = control.damp(to_control(truth), doprint=False)
        osc = (poles.imag > 1e-9 * np.abs(poles).max()) & (np.abs(poles) > 1e-6 * wn.max())
        fm, zm = wn[osc] / (2 * np.pi), zeta[osc]
        keep = (fm <= 400.0) & (zm <= 0.2)
        found = ds.mode_frequency_true.values[k]
        np.testing.assert_allclose(found[~np.isnan(found)], np.sort(fm[keep]), rtol=1e-8)
    # the bench's 62 Hz drivetrain mode is seen by every pairing
    assert np.all(np.any(np.abs(ds.mode_frequency_true.values - 62.0) < 4.0, axis=1))
    assert ds.frf_true_real.attrs["units"] and ds.mode_frequency_true.attrs["units"] == "Hz"


def test_truth_model_refuses_non_torque_inputs(cfg):
    with pytest.raises(ValueError, match="motor_torque_driver"):
        model.truth_model(cfg, ["speed_ref"], ["speed_gb1_hss"])


def test_model_imports_no_python_control():
    code = ("import sys, gbpipe.model; assert 'control' not in sys.modules; "
            "from gbpipe.model.control_models import bench, gearbox; "
            "import control; print(type(bench).__name__, 'control' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.split() == ["function", "True"]
