"""The table of bad configurations: each an overlay on config.yaml + ci.yaml, the key path
its error must name, and its category.

Missing keys are made by replacing a list (overlays merge mappings key by key, so a key
of a mapping cannot be removed by an overlay, as with ``snakemake --configfile``).
"""

from __future__ import annotations

NAN, INF = float("nan"), float("inf")

_STAGES = [{"type": "planetary", "ring": 96, "planet": 35, "sun": 24, "planets": 4},
           {"type": "planetary", "ring": 114, "planet": 45, "sun": 21, "planets": 3},
           {"type": "parallel", "wheel": 96, "pinion": 29}]


def _stage(i: int, **change) -> dict:
    stages = [dict(s) for s in _STAGES]
    stages[i].update(change)
    for k in [k for k, v in change.items() if v is None]:
        del stages[i][k]
    return {"gearbox": {"stages": stages}}


def _variants(*extra: dict) -> dict:
    """tsa.variants: ``extra`` then valid ones up to the three the figures need."""
    pad = [{"name": f"pad{k}", "cycles": ["hss"]} for k in range(max(0, 3 - len(extra)))]
    return {"variants": [*extra, *pad]}


_PAIR = {"name": "p", "inputs": ["motor_torque_driver"], "outputs": ["speed_gb1_hss"]}

_MS = {"name": "ms", "base": "speed_up", "setpoint": "torque", "signal": "multisine",
       "phases": "schroeder", "band": [1.0, 450.0], "rms": 2000.0, "period": 5.0}
_PRBS = {"name": "pr", "base": "speed_up", "setpoint": "speed", "signal": "prbs",
         "band": [0.0, 450.0], "rms": 10.0}


def _designed(*entries: dict) -> dict:
    """campaign.designed holding ``entries`` (a list: replaces the configured one)."""
    return {"campaign": {"designed": list(entries)}}


def _ripple(**change) -> dict:
    """noise.motor_ripple.driver changed by ``change`` (None deletes a key)."""
    driver = {"broadband": 150.0, "pole_pairs": 2,
              "pulsating": [{"harmonic": 6, "amplitude": 100.0}], **change}
    return {"noise": {"motor_ripple": {"driver": {k: v for k, v in driver.items()
                                                  if v is not None}}}}

#: (id, category, overlay, key path named by the error)
CASES: list[tuple[str, str, dict, str]] = [
    # unknown keys: typos, at every level (the schema is closed everywhere)
    ("typo_tsa", "unknown key", {"tsa": {"n_cycle": 3}}, "tsa.n_cycle"),
    ("typo_top", "unknown key", {"seeed": 1}, "seeed"),
    ("typo_sweep_noise", "unknown key",
     {"sweep": {"noise": {"motor_ripple": {"drivn": 1.0}}}}, "sweep.noise.motor_ripple.drivn"),
    ("typo_sweep_noise_group", "unknown key", {"sweep": {"noise": {"sensors": {}}}},
     "sweep.noise.sensors"),
    ("typo_identify", "unknown key", {"identify": {"pasts": 10}}, "identify.pasts"),
    ("typo_spectra", "unknown key", {"spectra": {"overlapp": 0.5}}, "spectra.overlapp"),
    ("typo_coupling", "unknown key", {"bench": {"coupling": {"stifness": 1e6}}},
     "bench.coupling.stifness"),
    ("typo_housing", "unknown key", {"gearbox": {"housing": {"mass": 1.0}}},
     "gearbox.housing.mass"),
    ("typo_campaign", "unknown key", {"campaign": {"sample_rat": 5000.0}},
     "campaign.sample_rat"),
    ("typo_variant", "unknown key",
     {"tsa": _variants({"name": "hss", "cycles": ["hss"], "averageing": "block"})},
     "tsa.variants[0].averageing"),
    ("typo_stage", "unknown key", _stage(0, planet_count=4), "gearbox.stages[0].planet_count"),
    ("typo_figures", "unknown key", {"figures": {"profile": "square"}}, "figures.profile"),
    # numbers: finite and in their physical range
    ("nan_stiffness", "range", {"gearbox": {"stiffness": [NAN, 1.5e7, 1.5e7]}},
     "gearbox.stiffness[0]"),
    ("inf_stiffness", "range", {"gearbox": {"stiffness": [1.5e8, INF, 1.5e7]}},
     "gearbox.stiffness[1]"),
    ("huge_stiffness", "range", {"gearbox": {"stiffness": [1.5e8, 1.5e7, 1e300]}},
     "gearbox.stiffness[2]"),
    ("negative_inertia", "range", {"gearbox": {"inertia": [-1.0, 595.0, 183.0, 5.0]}},
     "gearbox.inertia[0]"),
    ("inertia_text", "type", {"gearbox": {"inertia": ["6730 kg m2", 595.0, 183.0, 5.0]}},
     "gearbox.inertia[0]"),
    ("zero_motor_inertia", "range", {"bench": {"motor_inertia": {"driver": 0}}},
     "bench.motor_inertia.driver"),
    ("stiffness_text", "type", {"bench": {"lss_shaft": {"stiffness": "3e8 Nm/rad"}}},
     "bench.lss_shaft.stiffness"),
    ("damping_above_1", "range", {"gearbox": {"damping_ratio": {"shaft": 1.5}}},
     "gearbox.damping_ratio.shaft"),
    ("negative_mount_damping", "range", {"gearbox": {"housing": {"damping_ratio": -0.1}}},
     "gearbox.housing.damping_ratio"),
    ("nan_sample_rate", "range", {"campaign": {"sample_rate": NAN}}, "campaign.sample_rate"),
    ("zero_sweep_duration", "range", {"sweep": {"duration": 0}}, "sweep.duration"),
    ("zero_hold", "range", {"campaign": {"hold": 0}}, "campaign.hold"),
    ("huge_mesh_error", "range",
     {"excitation": {"mesh": [{"stage": 1, "amplitude": 1.0, "harmonics": [1.0]}]}},
     "excitation.mesh[0].amplitude"),
    ("zero_pulses", "range", {"tachometer": {"pulses_per_rev": 0}},
     "tachometer.pulses_per_rev"),
    ("lowpass_1", "range", {"identify": {"lowpass": 1.0}}, "identify.lowpass"),
    ("overlap_1", "range", {"spectra": {"overlap": 1.0}}, "spectra.overlap"),
    ("nan_zeta", "range", {"identify": {"zeta_max": NAN}}, "identify.zeta_max"),
    ("negative_sensor_noise", "range", {"noise": {"sensor": {"speed": -1.0}}},
     "noise.sensor.speed"),
    ("inf_ki", "range", {"bench": {"speed_controller": {"ki": INF}}},
     "bench.speed_controller.ki"),
    # names and types
    ("mount_rubber", "type", {"gearbox": {"housing": {"mount": "rubber"}}},
     "gearbox.housing.mount"),
    ("stage_type_unknown", "type", _stage(2, type="helical"), "gearbox.stages[2].type"),
    ("fractional_teeth", "type", _stage(1, sun=21.5), "gearbox.stages[1].sun"),
    ("method_unknown", "type", {"identify": {"methods": ["arx"]}}, "identify.methods[0]"),
    ("order_zero", "type", {"identify": {"order": 0}}, "identify.order"),
    ("order_text", "type", {"identify": {"order": "fixed"}}, "identify.order"),
    ("test_unknown", "type", {"campaign": {"tests": ["speed_sideways"]}},
     "campaign.tests[0]"),
    ("averaging_unknown", "type", {"tsa": {"averaging": "median"}}, "tsa.averaging"),
    ("negative_seed", "range", {"seed": -1}, "seed"),
    ("figure_profile_unknown", "type", {"figures": {"test_profile": "smooth"}},
     "figures.test_profile"),
    ("versions_empty", "type", {"identify": {"versions": []}}, "identify.versions"),
    # missing keys
    ("stage_missing_pinion", "missing", _stage(2, pinion=None), "gearbox.stages[2].pinion"),
    ("pairing_missing_outputs", "missing",
     {"identify": {"pairings": [{"name": "p", "inputs": ["motor_torque_driver"]}]}},
     "identify.pairings[0].outputs"),
    ("variant_missing_cycles", "missing", {"tsa": _variants({"name": "hss"})},
     "tsa.variants[0].cycles"),
    ("mesh_missing_harmonics", "missing",
     {"excitation": {"mesh": [{"stage": 1, "amplitude": 1e-5}]}},
     "excitation.mesh[0].harmonics"),
    # gearbox physics and structure
    ("planets_not_equally_spaced", "gearbox", _stage(1, planets=4), "gearbox.stages[1].ring"),
    ("not_concentric", "gearbox", _stage(0, planet=30), "gearbox.stages[0].planet"),
    ("planets_collide", "gearbox", _stage(0, planets=8), "gearbox.stages[0].planets"),
    ("ring_below_sun", "gearbox", _stage(0, ring=20), "gearbox.stages[0].ring"),
    ("parallel_with_ring", "gearbox", _stage(2, ring=90), "gearbox.stages[2].ring"),
    ("inertia_count", "gearbox", {"gearbox": {"inertia": [6730.0, 595.0, 5.0]}},
     "gearbox.inertia"),
    ("stiffness_count", "gearbox", {"gearbox": {"stiffness": [1.5e8, 1.5e7]}},
     "gearbox.stiffness"),
    ("inertia_member_wrong", "gearbox",
     {"gearbox": {"inertia": [6730.0, 595.0, {"carrier": 1.0}, 5.0]}},
     "gearbox.inertia[2].carrier"),
    ("mesh_stage_missing", "gearbox",
     {"excitation": {"mesh": [{"stage": 4, "amplitude": 1e-5, "harmonics": [1.0]}]}},
     "excitation.mesh[0].stage"),
    ("cycle_unknown", "gearbox", {"tsa": _variants({"name": "m", "cycles": ["mesh7"]})},
     "tsa.variants[0].cycles[0]"),
    ("variant_names_twice", "gearbox",
     {"tsa": _variants({"name": "a", "cycles": ["hss"]}, {"name": "a", "cycles": ["mesh2"]})},
     "tsa.variants[1].name"),
    # campaign and sweep records
    ("step_stops_bench", "records", {"campaign": {"step": {"speed_rpm": 1200.0}}},
     "campaign.step.speed_rpm"),
    ("step_beyond_range", "records", {"campaign": {"step": {"torque": 30000.0}}},
     "campaign.step.torque"),
    ("rate_below_excitation", "records", {"campaign": {"sample_rate": 500.0}},
     "campaign.sample_rate"),
    ("sweep_no_range", "records", {"sweep": {"rpm_end": 400.0}}, "sweep.rpm_end"),
    ("sweep_too_fast", "records", {"sweep": {"duration": 5.0}}, "sweep.duration"),
    ("sweep_beyond_bench_speed", "records", {"sweep": {"rpm_end": 2500.0, "duration": 100.0}},
     "sweep.rpm_end"),
    ("sweep_beyond_bench_torque", "records", {"sweep": {"torque": 50000.0}}, "sweep.torque"),
    ("clock_too_slow", "records", {"tachometer": {"clock_hz": 20.0}}, "tachometer.clock_hz"),
    ("model_grid_empty", "records", {"model": {"frf": {"f_min": 600.0}}}, "model.frf.f_min"),
    ("sweep_too_large", "records", {"sweep": {"sample_rate": 1.0e6}}, "sweep.sample_rate"),
    ("test_too_large", "records", {"campaign": {"hold": 5000.0}}, "campaign.sample_rate"),
    # harmonic removal and spectra
    ("tsa_cycles_exceed_sweep", "tsa", {"tsa": {"n_cycles": 200}},
     "tsa.variants[1].cycles[0]"),
    ("quadratic_few_cycles", "tsa", {"tsa": {"n_cycles": 3}}, "tsa.n_cycles"),
    ("unbiased_removes_all", "tsa",
     {"tsa": {"n_cycles": 2, "unbiased": True,
              **_variants({"name": "joint", "cycles": ["hss", "mesh2"]})}}, "tsa.unbiased"),
    ("two_variants", "tsa", {"tsa": {"variants": _variants()["variants"][:2]}},
     "tsa.variants"),
    ("tsa_tests_empty", "tsa", {"tsa": {"tests": []}}, "tsa.tests"),
    ("tsa_tests_exceed_record", "tsa",
     {"tsa": {"tests": ["carrier1"]}},
     "tsa.tests[0]"),
    ("overlap_no_hop", "spectra", {"spectra": {"overlap": 0.99999}}, "spectra.overlap"),
    ("overlap_memory", "spectra", {"spectra": {"overlap": 0.9995}}, "spectra.overlap"),
    ("spectra_signal_unknown", "spectra", {"spectra": {"signal": "torque_meter"}},
     "spectra.signal"),
    ("window_unknown", "spectra", {"spectra": {"window": "hanning2"}}, "spectra.window"),
    ("resolution_too_fine", "spectra", {"spectra": {"resolution": 0.01}},
     "spectra.resolution"),
    ("order_resolution_too_fine", "spectra", {"spectra": {"order_resolution": 0.001}},
     "spectra.order_resolution"),
    ("max_frequency_above_nyquist", "spectra", {"spectra": {"max_frequency": 3000.0}},
     "spectra.max_frequency"),
    ("mode_above_spectra", "spectra", {"spectra": {"mode_max_frequency": 800.0}},
     "spectra.mode_max_frequency"),
    # identification
    ("order_500", "identify", {"identify": {"order": 500}}, "identify.order"),
    ("past_below_future", "identify", {"identify": {"past": 40, "future": 50}},
     "identify.past"),
    ("best_pairing_unknown", "identify", {"identify": {"best": {"pairing": "nope"}}},
     "identify.best.pairing"),
    ("best_test_not_identified", "identify", {"identify": {"best": {"test": "torque_up"}}},
     "identify.best.test"),
    ("best_version_not_identified", "identify",
     {"identify": {"versions": ["clean", "raw"], "best": {"version": "tsa"}}},
     "identify.best.version"),
    ("pairing_output_unknown", "identify",
     {"identify": {"pairings": [{**_PAIR, "outputs": ["speed_hss"]}]}},
     "identify.pairings[0].outputs[0]"),
    ("pairing_names_twice", "identify", {"identify": {"pairings": [_PAIR, _PAIR]}},
     "identify.pairings[1].name"),
    ("id_rate_not_divisor", "identify", {"identify": {"sample_rate": 3000.0}},
     "identify.sample_rate"),
    ("frf_above_passband", "identify", {"identify": {"frf": {"f_max": 450.0}}},
     "identify.frf.f_max"),
    ("frf_empty", "identify", {"identify": {"frf": {"f_min": 380.0}}}, "identify.frf.f_min"),
    ("windows_exceed_record", "identify", {"identify": {"past": 5000}}, "identify.past"),
    ("fit_segment_too_long", "identify", {"identify": {"fit_segment": 100.0}},
     "identify.fit_segment"),
    ("settle_too_short", "identify", {"campaign": {"settle": 0.001}}, "campaign.settle"),
    ("raw_without_measured", "identify", {"campaign": {"measured_like": False}},
     "campaign.measured_like"),
    # harmonic removal beyond TSA
    ("typo_removal_vkf", "removal", {"removal": {"vkf": {"bandwith": 2.0}}},
     "removal.vkf.bandwith"),
    ("unknown_removal_method", "removal", {"removal": {"methods": ["tsa", "kalman"]}},
     "removal.methods[1]"),
    ("knot_spacing_not_a_family", "removal",
     {"removal": {"regression": {"knot_spacing": {"shat": 2.0}}}},
     "removal.regression.knot_spacing.shat"),
    ("knot_spacing_zero", "removal", {"removal": {"regression": {"knot_spacing": 0.0}}},
     "removal.regression.knot_spacing"),
    ("version_not_a_removal_method", "removal",
     {"removal": {"methods": ["tsa"]}, "identify": {"versions": ["clean", "vkf"]}},
     "identify.versions"),
    ("removal_version_without_families", "removal",
     {"removal": {"tests": []}, "identify": {"versions": ["clean", "regression"]}},
     "removal.tests"),
    ("removal_cycle_unknown", "removal", {"removal": {"tests": ["hss", "mesh9"]}},
     "removal.tests[1]"),
    # measured-like noise (issue 14): per-motor ripple, encoder, tachometer jitter
    ("ripple_old_scalar_form", "noise", {"noise": {"motor_ripple": {"driver": 150.0}}},
     "noise.motor_ripple.driver"),
    ("ripple_typo", "noise", _ripple(pulsatig=[]), "noise.motor_ripple.driver.pulsatig"),
    ("ripple_harmonic_zero", "noise",
     _ripple(pulsating=[{"harmonic": 0, "amplitude": 10.0}]),
     "noise.motor_ripple.driver.pulsating[0].harmonic"),
    ("ripple_negative_amplitude", "noise",
     _ripple(pulsating=[{"harmonic": 6, "amplitude": -1.0}]),
     "noise.motor_ripple.driver.pulsating[0].amplitude"),
    ("ripple_pole_pairs_zero", "noise", _ripple(pole_pairs=0),
     "noise.motor_ripple.driver.pole_pairs"),
    ("encoder_zero_counts", "noise", {"noise": {"encoder": {"counts_per_rev": 0}}},
     "noise.encoder.counts_per_rev"),
    ("jitter_negative", "noise", {"tachometer": {"jitter": -1e-6}}, "tachometer.jitter"),
    ("jitter_near_pulse_interval", "noise", {"tachometer": {"jitter": 5e-3}},
     "tachometer.jitter"),
    ("torque_limit_zero", "noise", {"bench": {"torque_limit": {"driver": 0.0}}},
     "bench.torque_limit.driver"),
    # designed-excitation tests
    ("designed_typo", "designed", _designed({**_MS, "amplitude": 1.0}),
     "campaign.designed[0].amplitude"),
    ("designed_unknown_signal", "designed", _designed({**_MS, "signal": "chirp"}),
     "campaign.designed[0].signal"),
    ("designed_name_of_ramp_test", "designed", _designed({**_MS, "name": "speed_up"}),
     "campaign.designed[0].name"),
    ("designed_name_twice", "designed", _designed(_MS, {**_PRBS, "name": "ms"}),
     "campaign.designed[1].name"),
    ("designed_base_not_simulated", "designed", _designed({**_MS, "base": "torque_up"}),
     "campaign.designed[0].base"),
    ("designed_band_above_nyquist", "designed", _designed({**_MS, "band": [1.0, 2600.0]}),
     "campaign.designed[0].band"),
    ("designed_band_reversed", "designed", _designed({**_MS, "band": [100.0, 10.0]}),
     "campaign.designed[0].band"),
    ("designed_prbs_with_phases", "designed", _designed({**_PRBS, "phases": "random"}),
     "campaign.designed[0].phases"),
    ("designed_prbs_band_too_high", "designed", _designed({**_PRBS, "band": [0.0, 2000.0]}),
     "campaign.designed[0].band"),
    ("designed_period_beyond_record", "designed", _designed({**_MS, "period": 100.0}),
     "campaign.designed[0].period"),
    ("designed_beyond_torque_limit", "designed", _designed({**_MS, "rms": 20000.0}),
     "campaign.designed[0].rms"),
    ("bounds_groups_too_many", "designed", {"identify": {"bounds": {"groups": 400}}},
     "identify.bounds.groups"),
    ("bounds_groups_two", "designed", {"identify": {"bounds": {"groups": 2}}},
     "identify.bounds.groups"),
    ("identify_unknown_test", "designed", {"identify": {"tests": ["speed_up", "ms_torqe"]}},
     "identify.tests[1]"),
    # closed-loop stability
    ("unstable_torque_ki", "stability", {"bench": {"torque_controller": {"ki": 500.0}}},
     "bench.torque_controller.ki"),
]
