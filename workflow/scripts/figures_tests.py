"""Rule `figures_tests`: figures 7-10 with their report captions."""

import numpy as np

from gbpipe import io, runlog
from gbpipe.figures.captions import write_caption
from gbpipe.figures.time_plots import fig_speed, fig_torque

snakemake = globals()["snakemake"]
log = runlog.setup(snakemake.log[0])
out = snakemake.output
speed = [io.read(p) for p in snakemake.input.speed]
torque = [io.read(p) for p in snakemake.input.torque]
RPM = 60 / (2 * np.pi)


def tail(ds, name):
    # mean over the last second: the final level
    return float(ds[name].isel(time=slice(-int(ds.attrs["sample_rate"]), None)).mean())


def hold(ds, name):
    # mean over the last second before the return step: the stepped level
    i1 = int((ds.time.size - 1) * 0.55)
    return float(ds[name].isel(time=slice(i1 - int(ds.attrs["sample_rate"]), i1)).mean())


figs = [(fig_speed, speed, "Fig. 7", "speed vs time, speed-ramp tests"),
        (fig_torque, speed, "Fig. 8", "torque vs time, speed-ramp tests"),
        (fig_speed, torque, "Fig. 9", "speed vs time, torque-ramp tests"),
        (fig_torque, torque, "Fig. 10", "torque vs time, torque-ramp tests")]
for k, (plot, recs, paper, what) in enumerate(figs):
    plot(recs, out[3 * k], f"{paper} — {what} (GB1 driven, GB2 driving)")
    numbers = {}
    for ds in recs:
        tag = f"{ds.attrs['test']} ({ds.attrs['profile']})"
        numbers[f"{tag}: final GB1 HSS speed"] = f"{tail(ds, 'speed_gb1_hss') * RPM:.2f} rpm"
        numbers[f"{tag}: driven torque meter, final"] = (
            f"{tail(ds, 'torque_meter_driven') / 1e3:.3f} kN·m")
        if "torque_meter_driven_measured" in ds:
            numbers[f"{tag}: harmonic + noise torque rms"] = (
                f"{float((ds.torque_meter_driven_measured - ds.torque_meter_driven).std()):.0f}"
                " N·m")
    write_caption(out[3 * k + 2], what.capitalize(), f"paper {paper}",
                  "Measured-like HSS signals of both gearboxes (with shaft and mesh harmonics "
                  "and sensor noise) and the reference.", numbers)
log.info("wrote figures 7-10")
