"""Rule `figures_harmonics`: figures 11-17 and the resonance-band check, with captions."""

import numpy as np

from gbpipe import io, runlog
from gbpipe.figures.captions import write_caption
from gbpipe.figures.waterfalls import fig_mode_band, fig_order_waterfall, fig_power_waterfall
from gbpipe.kinematics import order_of

snakemake = globals()["snakemake"]
log = runlog.setup(snakemake.log[0])
out = snakemake.output
raw = io.read(snakemake.input.raw)
var = {n: io.read(p) for n, p in zip(snakemake.params.variants, snakemake.input.variants,
                                      strict=True)}
modes = var[next(iter(var))].mode_frequency.values
vmax = fig_power_waterfall(raw, out[0], "Fig. 11 — torque power spectrum vs rpm, raw sweep (GB1)",
                           modes=modes)
f11 = raw.power.sum("frequency")
write_caption(out[2], "Raw sweep waterfall", "paper Fig. 11",
              "Power spectrum of the GB1 torque meter vs HSS speed: shaft orders and mesh "
              "harmonics are diagonal lines, the bench resonance a vertical band.",
              {"bench modes marked": ", ".join(f"{f:.1f}" for f in modes) + " Hz",
               "speed range": f"{float(raw.rpm.min()):.0f}-{float(raw.rpm.max()):.0f} rpm",
               "total power (mean over rpm)": f"{10 * np.log10(float(f11.mean())):.1f} dB"})
# Figures 12-17 show the first three TSA variants in config order (the paper's: hss,
# carrier2, mesh2); another gearbox names its own cycles.
DESCRIBE = {"hss": "HSS cycles", "carrier2": "planet-carrier-2 revolutions",
            "mesh2": "stage-2 gear-mesh periods"}
names = list(var)[:3]
stages = snakemake.params.stages
marks = {"3×": 3.0} | {f"GMF{i}": float(order_of(stages, f"mesh{i}"))
                       for i in range(1, len(stages) + 1)}
if len(names) < 3:
    raise ValueError("figures 12-17 need three TSA variants in config tsa.variants")
k = 3
for n, name in zip((12, 14, 16), names, strict=True):
    cyc = var[name].attrs["cycles"]
    what = f"{snakemake.params.n_cycles} " + " + ".join(
        DESCRIBE.get(c, f"{c} cycles") for c in cyc.split())
    if var[name].attrs.get("averaging", "block") != "block":
        what += f" ({var[name].attrs['averaging']} average)"
    ds = var[name]
    fig_power_waterfall(ds, out[k], f"Fig. {n} — power spectrum of the residual\nafter "
                        f"averaging {what}", vmax=vmax, modes=modes)
    fig_order_waterfall(ds, out[k + 3], f"Fig. {n + 1} — order spectrum of the residual\n"
                        f"after averaging {what}", marks=marks)
    numbers = {f"{fam} removed": f"{float(ds.attenuation.sel(family=fam)):.1f} dB "
               f"(band measure {float(ds.attenuation_band.sel(family=fam)):.1f} dB)"
               for fam in ds.family.values}
    for m, f in enumerate(ds.mode_frequency.values):
        ch = ds.mode_change_vs_rpm.isel(mode=m).values
        cross = ds.crossing.isel(mode=m).any("family").values.astype(bool)
        free = np.where(cross, np.nan, np.abs(ch))
        text = f"{float(ds.mode_change.isel(mode=m)):+.2f} dB overall (bins without a crossing)"
        if np.isfinite(free).any():
            w = int(np.nanargmax(free))
            text += f"; worst such bin {float(ds.metric_rpm[w]):.0f} rpm: {ch[w]:+.2f} dB"
        if cross.any():
            text += (f"; {int(cross.sum())} bin(s) where a removed family crosses the band: "
                     f"{', '.join(f'{c:+.1f}' for c in ch[cross])} dB (the harmonic itself)")
        numbers[f"mode {f:.1f} Hz band change"] = text
    for j, label in ((0, "power"), (3, "order")):
        write_caption(out[k + j + 2], f"Residual {label} spectrum, {name} TSA",
                      f"paper Fig. {n + (j > 0)}",
                      f"GB1 torque after subtracting the block average of {what} "
                      f"(cycle order {ds.attrs['cycle_orders']}).", numbers)
    k += 6
fig_mode_band(var, out[k])
numbers = {}
for name, ds in var.items():
    for m, f in enumerate(ds.mode_frequency.values):
        numbers[f"{name}, mode {f:.1f} Hz"] = f"{float(ds.mode_change.isel(mode=m)):+.2f} dB"
    if "cascade_attenuation" in ds:
        for fam in ds.family.values:
            numbers[f"{name}: {fam} joint vs cascade"] = (
                f"{float(ds.attenuation.sel(family=fam)):.1f} dB vs "
                f"{float(ds.cascade_attenuation.sel(family=fam)):.1f} dB (band measure "
                f"{float(ds.attenuation_band.sel(family=fam)):.1f} vs "
                f"{float(ds.cascade_attenuation_band.sel(family=fam)):.1f} dB)")
write_caption(out[k + 2], "Does TSA remove a resonance?", "extension (the paper's open question)",
              "Change in dB of the power in the band around each bench mode, per rpm bin and "
              "TSA variant; crosses mark bins where a removed family passes through the band.",
              numbers)
log.info("wrote figures 11-17 and the mode-band figure")
