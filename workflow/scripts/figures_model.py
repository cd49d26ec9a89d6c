"""Rule `figures_model`: figures 3, 4 and 5."""

from gbpipe import io, runlog
from gbpipe.figures.model_plots import fig3_gearbox_bode, fig4_bench_bode
from gbpipe.figures.topology import fig5_topology

snakemake = globals()["snakemake"]
log = runlog.setup(snakemake.log[0])
stems = sorted({p.rsplit(".", 1)[0] for p in snakemake.output})
fig3_gearbox_bode(io.read(snakemake.input.gearbox), stems[0])
fig4_bench_bode(io.read(snakemake.input.bench), stems[1])
fig5_topology(snakemake.params.model, stems[2])
log.info("wrote %s", ", ".join(stems))
