"""Rule `figures_model`: figures 3, 4 and 5 with their report captions."""

from gbpipe import io
from gbpipe.figures.captions import write_caption
from gbpipe.figures.model_plots import fig3_gearbox_bode, fig4_bench_bode
from gbpipe.figures.topology import fig5_topology

snakemake = globals()["snakemake"]
log = io.setup_log(snakemake.log[0])
out = snakemake.output
gb, bench = io.read(snakemake.input.gearbox), io.read(snakemake.input.bench)
fig3_gearbox_bode(gb, out.fig3_png)
fig4_bench_bode(bench, out.fig4_png)
fig5_topology(snakemake.params.model, out.fig5_png)


def hz(values):
    return ", ".join(f"{v:.1f}" for v in values) + " Hz"


write_caption(out.fig3_caption, "Single gearbox: HSS torque to LSS speed", "paper Fig. 3",
              "Bode magnitude of one gearbox with free ends; each gear stage adds a resonance, "
              "the elastic housing mount one more.",
              {"modes": hz(gb.mode_frequency.values),
               "undamped (K, M)": hz(gb.undamped_frequency.values)})
closed = bench.closed_mode_frequency.values
write_caption(out.fig4_caption, "Complete back-to-back bench", "paper Fig. 4",
              "Bode magnitude of the open-loop bench from the driving motor torque to speeds "
              "and torque meters.",
              {"open-loop modes": hz(bench.plant_mode_frequency.values),
               "closed-loop modes": hz(closed),
               "bench resonance near 60 Hz": hz(closed[(closed > 50) & (closed < 75)])})
write_caption(out.fig5_caption, "Model topology",
              "paper Fig. 5 (Simscape model), extended to the bench",
              "Bodies, shafts, couplings with torque meters, gear stages and housing mounts, "
              "drawn from the configuration.",
              {"gearbox": snakemake.params.model["gearbox"]["name"]})
log.info("wrote figures 3-5")
