"""Rule `figures_tests`: figures 7-10 with their report captions."""

from gbpipe import io
from gbpipe.figures.captions import write_caption
from gbpipe.figures.time_plots import fig_speed, fig_torque
from gbpipe.units import RPM_PER_RAD_S

snakemake = globals()["snakemake"]
log = io.setup_log(snakemake.log[0])
out = snakemake.output
speed = [io.read(p) for p in snakemake.input.speed]
torque = [io.read(p) for p in snakemake.input.torque]


def tail(ds, name):
    # mean over the last second: the final level
    return float(ds[name].isel(time=slice(-int(ds.attrs["sample_rate"]), None)).mean())


def hold(ds, name):
    # mean over the last second before the return step: the stepped level
    i1 = int((ds.time.size - 1) * 0.55)
    return float(ds[name].isel(time=slice(i1 - int(ds.attrs["sample_rate"]), i1)).mean())


figs = [(7, fig_speed, speed, "speed vs time, speed-ramp tests"),
        (8, fig_torque, speed, "torque vs time, speed-ramp tests"),
        (9, fig_speed, torque, "speed vs time, torque-ramp tests"),
        (10, fig_torque, torque, "torque vs time, torque-ramp tests")]
for n, plot, recs, what in figs:
    paper = f"Fig. {n}"
    plot(recs, out[f"fig{n}_png"], f"{paper} — {what} (GB1 driven, GB2 driving)")
    numbers = {}
    for ds in recs:
        tag = f"{ds.attrs['test']} ({ds.attrs['profile']})"
        numbers[f"{tag}: final GB1 HSS speed"] = (
            f"{tail(ds, 'speed_gb1_hss') * RPM_PER_RAD_S:.2f} rpm")
        numbers[f"{tag}: driven torque meter, final"] = (
            f"{tail(ds, 'torque_meter_driven') / 1e3:.3f} kN·m")
        if "torque_meter_driven_measured" in ds:
            numbers[f"{tag}: harmonic + noise torque rms"] = (
                f"{float((ds.torque_meter_driven_measured - ds.torque_meter_driven).std()):.0f}"
                " N·m")
    write_caption(out[f"fig{n}_caption"], what.capitalize(), f"paper {paper}",
                  "Measured-like HSS signals of both gearboxes (with shaft and mesh harmonics "
                  "and sensor noise) and the reference.", numbers)
log.info("wrote figures 7-10")
