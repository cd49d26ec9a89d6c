"""Rule `figures_design`: predicted band per pairing and test beside the achieved match
bandwidth, and the predicted error against frequency (docs/design.md)."""

from gbpipe import io
from gbpipe.figures.design_plots import fig_design
from gbpipe.figures.style import formats

snakemake = globals()["snakemake"]
log = io.setup_log(snakemake.log[0])
# achieved: the best method on the measured-like data after harmonic removal (tsa), else
# the raw measured-like data, else whatever version comes first; predicted: that version's
versions = snakemake.params.versions
version = next((v for v in ("tsa", "raw") if v in versions), versions[0])
designs = {}
for path in snakemake.input.designs:
    ds = io.read(path)
    designs[f"{ds.attrs['wildcard_test']} {ds.attrs['wildcard_profile']}"] = ds.sel(
        version=version)
achieved = {}
for path in snakemake.input.models:
    ds = io.read(path)
    label = f"{ds.attrs['wildcard_test']} {ds.attrs['wildcard_profile']}"
    for p, v, bw in zip(ds.pairing.values, ds.version.values, ds.match_bandwidth.values,
                        strict=True):
        if str(v) == version:
            key = (label, str(p))
            achieved[key] = max(achieved.get(key, 0.0), float(bw))
out = snakemake.output
with formats(snakemake.params.formats):  # config figures.formats
    numbers = fig_design(designs, out.fig_design_png, out.fig_design_caption, achieved,
                         version=version)
log.info("design figure (achieved: %s): %s", version, numbers)
