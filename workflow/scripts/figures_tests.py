"""Rule `figures_tests`: figures 7-10."""

from gbpipe import io, runlog
from gbpipe.figures.time_plots import fig_speed, fig_torque

snakemake = globals()["snakemake"]
log = runlog.setup(snakemake.log[0])
stems = sorted({p.rsplit(".", 1)[0] for p in snakemake.output})
speed = [io.read(p) for p in snakemake.input.speed]
torque = [io.read(p) for p in snakemake.input.torque]
fig_speed(speed, stems[0], "Fig. 7 — speed vs time, speed-ramp tests (GB1 driven, GB2 driving)")
fig_torque(speed, stems[1], "Fig. 8 — torque vs time, speed-ramp tests")
fig_speed(torque, stems[2], "Fig. 9 — speed vs time, torque-ramp tests")
fig_torque(torque, stems[3], "Fig. 10 — torque vs time, torque-ramp tests")
log.info("wrote %s", ", ".join(stems))
