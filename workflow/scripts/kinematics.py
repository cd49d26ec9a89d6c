"""Rule `kinematics`: frequencies and orders of every shaft and mesh; Table 2 as CSV."""

from gbpipe import io, kinematics, tables

snakemake = globals()["snakemake"]  # injected by Snakemake's script: directive
log = io.setup_log(snakemake.log[0])
stages = snakemake.params.gearbox["stages"]
ds = kinematics.frequencies(stages, snakemake.params.hss_rpm)
rows, notes = tables.table2(ds, stages)
for note in notes:
    log.warning(note)
ds.attrs["notes"] = " | ".join(notes) if notes else "none"
io.write(ds, snakemake.output.nc, sources=snakemake.input,
         stage="kinematics", config=snakemake.params.gearbox,
         title=f"Shaft and gear-mesh frequencies, {snakemake.params.gearbox['name']}")
io.write_csv(rows, snakemake.output.table)
log.info("gearbox ratio %.4f; table with %d rows", float(ds.total_ratio), len(rows))
