"""Rule `tsa`: one TSA variant on the sweep; residual, waterfalls and removal metrics."""

import numpy as np
import xarray as xr

from gbpipe import harmonics, io, runlog

snakemake = globals()["snakemake"]
log = runlog.setup(snakemake.log[0])
p, w = snakemake.params, snakemake.wildcards
spec = p.spectra
sw = io.read(snakemake.input.sweep)
bench = io.read(snakemake.input.bench)
fs, pulses = float(sw.attrs["sample_rate"]), sw.pulse_time.values
ppr = int(sw.attrs["pulses_per_rev"])
sig = sw[spec["signal"]]
x = sig.values.astype(float)
cycles = harmonics.cycle_orders(p.stages, p.tsa["cycles"])
families = harmonics.removed_families(
    harmonics.excitation_families({"gearbox": {"stages": p.stages}, "excitation": p.excitation}),
    cycles)
modes = harmonics.structural_modes(bench.closed_mode_frequency.values, 10.0,
                                   spec["mode_max_frequency"], spec["mode_half_width"])
log.info("variant %s: cycles %s (orders %s); removed families %s", w.variant,
         p.tsa["cycles"], [f"{float(c):.4f}" for c in cycles], list(families))

r = harmonics.remove(x, fs, pulses, cycles, p.tsa, pulses_per_rev=ppr)
ds = harmonics.waterfalls(r, fs, pulses, spec, pulses_per_rev=ppr, units=sig.attrs["units"],
                          long_name=f"TSA residual of {sig.attrs['long_name']}")
met = harmonics.variant_metrics(x, r, fs, pulses, families, modes, spec, pulses_per_rev=ppr)
ds = xr.merge([ds, met], compat="override")
ds["residual"] = ("time", r, {"units": sig.attrs["units"],
                              "long_name": f"TSA residual of {sig.attrs['long_name']}"})
ds = ds.assign_coords(time=sw.time)
if len(cycles) > 1:
    # the plain cascade beside the joint removal: its own figure of merit
    rc = harmonics.remove(x, fs, pulses, cycles, p.tsa, pulses_per_rev=ppr, mode="cascade")
    mc = harmonics.variant_metrics(x, rc, fs, pulses, families, modes, spec,
                                   pulses_per_rev=ppr)
    for v in ("attenuation", "attenuation_band"):
        ds[f"cascade_{v}"] = mc[v].assign_attrs(
            long_name=mc[v].attrs["long_name"] + " (plain cascade)")
ds.attrs.update(variant=w.variant, cycles=" ".join(p.tsa["cycles"]),
                averaging=p.tsa.get("averaging", "block"),
                cycle_orders=" ".join(f"{c.numerator}/{c.denominator}" for c in cycles))
io.write(ds, snakemake.output[0], stage="tsa", config=dict(p), wildcards={"variant": w.variant},
         float32=True, title=f"TSA harmonic removal on the sweep, variant {w.variant}")
for fam in ds.family.values:
    log.info("%s: attenuation %.1f dB (band %.1f dB)", fam,
             float(ds.attenuation.sel(family=fam)), float(ds.attenuation_band.sel(family=fam)))
for m, f in zip(ds.mode.values, ds.mode_frequency.values, strict=True):
    log.info("mode %.1f Hz: band change %.2f dB (all bins %.2f dB)", f,
             float(ds.mode_change.sel(mode=m)), float(ds.mode_change_all.sel(mode=m)))
if "cascade_attenuation" in ds:
    log.info("cascade attenuation: %s", np.round(ds.cascade_attenuation.values, 1))
