"""The simulated campaign on a described drivetrain (the shaft line of
config/examples/shaftline_campaign.yaml): records against statics and kinematics computed
here from the description's teeth, and the configuration checks that name the element."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from gbpipe import simulate
from gbpipe.config import load, merge, validate
from gbpipe.errors import ConfigError, ExcitationError
from gbpipe.simulate import profiles

BASE = ("config/config.yaml", "config/examples/shaftline_campaign.yaml")


@pytest.fixture(scope="module")
def cfg():
    return load(*BASE)


def _ratio(cfg) -> float:
    """Load speed per motor speed, from the teeth (independent of the chain builder)."""
    r = 1.0
    for g in cfg["drivetrain"]["gears"]:
        z_parent, z_child = g["teeth"]
        r *= z_parent / z_child
    return r


def _quiet(cfg, **over):
    """The config with no ripple and no sensor noise (and ``over`` merged)."""
    base = cfg.explicit() if hasattr(cfg, "explicit") else copy.deepcopy(dict(cfg))
    motors = [{**m, "ripple": 0.0} for m in base["drivetrain"]["motors"]]
    noise = {"sensor": {"speed": 0.0, "torque": 0.0}}
    return validate(merge(base, {"noise": noise, "drivetrain": {"motors": motors}, **over}),
                    check_stability=False)


def test_steady_state_and_statics_without_noise(cfg):
    # no ripple, no noise: the record starts in exact steady rotation at the references
    quiet = _quiet(cfg)
    ds = simulate.test(quiet, "speed_up", "square")
    w, tq = ds.speed_ref.values[0], ds.torque_ref.values[0]
    ratio = _ratio(quiet)
    n0 = int(quiet["campaign"]["settle"] * quiet["campaign"]["sample_rate"]) - 2
    np.testing.assert_allclose(ds.speed_motor.values[:n0], w, rtol=1e-7)
    np.testing.assert_allclose(ds.speed_load.values[:n0], w * ratio, rtol=1e-7)
    # statics: the load motor holds the output shaft's torque, which the gears divide
    # by the ratio at the input coupling (the torque arm carries the difference)
    np.testing.assert_allclose(ds.torque_output.values[:n0], tq, rtol=1e-7)
    np.testing.assert_allclose(ds.motor_torque_load.values[:n0], tq, rtol=1e-7)
    np.testing.assert_allclose(ds.torque_input.values[:n0], tq * ratio, rtol=1e-7)
    np.testing.assert_allclose(ds.motor_torque_drive.values[:n0], tq * ratio, rtol=1e-7)
    # the speed loop reaches the stepped reference (PI: no steady error) by the hold's end
    step = quiet["campaign"]["step"]["speed_rpm"] * np.pi / 30
    t1 = quiet["campaign"]["settle"] + quiet["campaign"]["hold"]
    end = (ds.time.values > t1 - 1.0) & (ds.time.values < t1 - 0.01)
    # (means over the last second: the lightly damped load end still rings a little)
    assert ds.speed_motor.values[end].mean() == pytest.approx(w + step, rel=1e-4)
    assert ds.speed_load.values[end].mean() == pytest.approx((w + step) * ratio, rel=2e-4)


def test_noisy_record_means_and_noise_levels(cfg):
    ds = simulate.test(cfg, "torque_up", "square")
    ratio = _ratio(cfg)
    fs, camp = cfg["campaign"]["sample_rate"], cfg["campaign"]
    t = ds.time.values
    hold = (t > camp["settle"] + 2.0) & (t < camp["settle"] + camp["hold"])
    tq = camp["nominal"]["torque"] + camp["step"]["torque"]
    w = camp["nominal"]["speed_rpm"] * np.pi / 30
    n = hold.sum()
    for name, expect in (("torque_output", tq), ("motor_torque_load", tq),
                         ("speed_motor", w), ("speed_load", w * ratio)):
        x = ds[name].values[hold]
        # the mean of a ripple-driven record: within 6 standard errors (lag-1 correlated
        # samples widened by the ratio of the record's spread to its first differences)
        sem = x.std() / np.sqrt(n) * max(1.0, x.std() / np.diff(x).std() * 2)
        assert abs(x.mean() - expect) < 6 * sem + 1e-9 * abs(expect), name
    # the measured-like variants: clean plus white noise of noise.sensor at its level
    for name, kind in (("torque_output", "torque"), ("speed_load", "speed")):
        d = ds[f"{name}_measured"].values - ds[name].values
        assert d.std() == pytest.approx(cfg["noise"]["sensor"][kind], rel=0.05)
    assert ds.sizes["time"] == int(round(profiles.test_duration(camp, "torque_up", "square")
                                         * fs))


def test_pairings_checked_against_the_chain():
    over = {"identify": {"pairings": [{"name": "p", "inputs": ["motor_torque_drive"],
                                       "outputs": ["speed_gb1_hss"]}],
                         "best": {"pairing": "p"}}}
    with pytest.raises(ConfigError, match=r"identify\.pairings\[0\]\.outputs\[0\].*speed_load"):
        load(*BASE, over)
    over["identify"]["pairings"][0].update(inputs=["motor_torque_driver"],
                                           outputs=["speed_load"])
    with pytest.raises(ConfigError, match=r"pairings\[0\]\.inputs\[0\].*motor_torque_drive"):
        load(*BASE, over)


def test_ripple_is_the_motors_own(cfg):
    """A chain motor's ripple is its entry's ``ripple``; the paper's noise.motor_ripple
    (driver, driven) is never read for it, and a chain motor's name there is refused with
    where it goes."""
    with pytest.raises(ConfigError, match=r"drivetrain\.motors\[i\]\.ripple") as exc:
        load(*BASE, {"noise": {"motor_ripple": {"load": {"broadband": 1.0}}}})
    assert exc.value.field == "noise.motor_ripple.load"
    motors = copy.deepcopy(cfg["drivetrain"]["motors"])
    del motors[1]["ripple"]
    with pytest.raises(ConfigError) as exc:
        load(*BASE, {"drivetrain": {"motors": motors}})
    assert exc.value.field == "drivetrain.motors[1].ripple"


def test_designed_test_refused_beyond_a_motors_torque_limit(cfg):
    # a 20 N·m rms torque multisine at the output: the drive motor answers with its share
    # (the ratio) on top of 50 N·m held, beyond a limit lowered to 30 N·m
    designed = [{"name": "ms", "base": "speed_up", "setpoint": "torque",
                 "signal": "multisine", "phases": "schroeder", "band": [1.0, 200.0],
                 "rms": 20.0, "period": 2.0}]
    motors = copy.deepcopy(cfg["drivetrain"]["motors"])
    motors[0]["torque_limit"] = 30.0
    c = load(*BASE, {"campaign": {"designed": designed}, "drivetrain": {"motors": motors}})
    with pytest.raises(ExcitationError, match=r"drivetrain\.motors\[0\]\.torque_limit"):
        simulate.test(c, "ms", "square")


def test_tachometer_on_a_named_angle_sensor(cfg):
    sensors = [*cfg["drivetrain"]["sensors"], {"name": "angle_load", "angle": "load"}]
    tach = {"sensor": "angle_load", "pulses_per_rev": 4, "jitter": 0.0}
    c = load(*BASE, {"drivetrain": {"sensors": sensors}, "tachometer": tach})
    ds = simulate.test(c, "speed_up", "square")
    theta = ds.angle_load.values - ds.angle_load.values[0]
    # each pulse where the angle crosses a multiple of a quarter turn (no spacing error,
    # no jitter; the clock floors by < 0.1 µs): times by inverse interpolation of the
    # clean angle, independent of the tachometer's cubic interpolant
    k = np.arange(1, ds.sizes["pulse"] + 1)
    expected = np.interp(k * 2 * np.pi / 4, theta, ds.time.values)
    assert ds.sizes["pulse"] == int(theta[-1] // (2 * np.pi / 4))
    np.testing.assert_allclose(ds.pulse_time.values, expected, atol=2e-6)
    with pytest.raises(ConfigError, match=r"tachometer\.sensor.*angle_load"):
        load(*BASE, {"drivetrain": {"sensors": sensors}, "tachometer": {"sensor": "speed_load"}})


def test_a_line_that_cannot_turn_is_refused_at_load(cfg):
    """A campaign starts in steady rotation: a mount on a rotating disk (no rigid-body
    mode left) and a speed loop on a grounded node are refused with the element named,
    before any simulation (the simulator would find no steady state)."""
    base = cfg.explicit() if hasattr(cfg, "explicit") else copy.deepcopy(dict(cfg))
    grounded = copy.deepcopy(base)
    grounded["drivetrain"]["mounts"].append(
        {"name": "brake", "node": "flywheel", "stiffness": 1e5, "damping_ratio": 0.05})
    with pytest.raises(ConfigError, match=r"drivetrain\.mounts.*0 rigid-body modes"):
        validate(grounded, check_stability=False)
    on_housing = copy.deepcopy(base)
    on_housing["drivetrain"]["sensors"].append({"name": "speed_housing", "speed": "housing"})
    on_housing["drivetrain"]["motors"][0]["controller"]["sensor"] = "speed_housing"
    with pytest.raises(ConfigError,
                       match=r"drivetrain\.motors\[0\]\.controller\.sensor.*housing"):
        validate(on_housing, check_stability=False)
