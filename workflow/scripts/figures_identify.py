"""Rule `figures_identify`: Fig 6 and the match-bandwidth figure, with report captions."""

import csv

from gbpipe import io
from gbpipe.figures.captions import write_caption
from gbpipe.figures.identification_plots import fig_bandwidth, fig_bode_identified

snakemake = globals()["snakemake"]
log = io.setup_log(snakemake.log[0])
out, best = snakemake.output, snakemake.params.best
datasets = [io.read(p) for p in snakemake.input.models]
case = [ds for ds in datasets
        if ds.attrs["test"] == best["test"] and ds.attrs["profile"] == best["profile"]]
bws = fig_bode_identified(case, best, out.fig6_png)
write_caption(out.fig6_caption, "Identified vs true Bode magnitude", "paper Fig. 6",
              f"{best['pairing']} on {best['test']} ({best['profile']}), {best['version']} data: "
              "true bench model (other loop closed as in the test) and the PBSID, MOESP and "
              "N4SID models; lower panel: magnitude error with the ±1 dB band.",
              {f"{m.upper()} match bandwidth": f"{bw:.1f} Hz" for m, bw in bws.items()})
with open(snakemake.input.table) as fh:
    rows = list(csv.DictReader(fh))
fig_bandwidth(rows, out.bandwidth_png)
best_row = max(rows, key=lambda r: float(r["match_bandwidth_hz"]))
write_caption(out.bandwidth_caption,
              "Match bandwidth across variants, methods, pairings and data versions",
              "extension (paper section 3 and future work)",
              "Highest frequency up to which the identified FRF stays within ±1 dB of the "
              "true model, for every test variant, method, signal pairing and data version.",
              {"widest": f"{best_row['match_bandwidth_hz']} Hz ({best_row['pairing']}, "
                         f"{best_row['version']}, {best_row['test']} {best_row['profile']}, "
                         f"{best_row['method']})"})
log.info("figures: %s", bws)
