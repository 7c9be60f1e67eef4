"""The report's glazing and loads section (cases with a ``[thermal]`` section): rated values of the units, window
gains per orientation, effective g, heating and cooling per unit, the cooling load over time, and ``loads.csv``.

Units: gains and loads [W], [kWh]; per m2 of glass [kWh m-2]; temperatures [degC]; U [W m-2 K-1].
"""

from __future__ import annotations

from html import escape

import pandas as pd

from .building_loads import ThermalRun
from .charts import ChartBook

__all__ = ["thermal_columns", "thermal_summary", "thermal_section"]


def thermal_columns(th: ThermalRun):
    """Time-series columns (name -> (T,)): per unit the window gain per orientation [W] and the building's
    cooling and heating [W]; the air temperature [degC]."""
    cols = {"building:temp_air [degC]": th.temp_air}
    for name in th.units:
        for o, (_, gain, _) in th.orientation_gains(name).items():
            cols[f"{name}:window gain {o} [W]"] = gain
        lr = th.loads[name]
        cols[f"{name}:cooling [W]"] = lr.cooling.sum(axis=1).to_numpy()
        cols[f"{name}:heating [W]"] = lr.heating.sum(axis=1).to_numpy()
    return cols


def thermal_summary(th: ThermalRun, step_hours):
    """Per unit: ``orientation`` -> {area_m2, gain_kwh, gain_kwh_m2, incident_kwh_m2, effective_g, peak_w_m2};
    ``cooling_kwh``, ``heating_kwh``, ``peak_cooling_w``, ``peak_cooling_time``, ``window_gain_kwh``."""
    out = {}
    for name in th.units:
        per = {}
        for o, (a, gain, inc) in th.orientation_gains(name).items():
            g_kwh, i_kwh = float(gain.sum() * step_hours / 1000.0), float(inc.sum() * step_hours / 1000.0)
            per[o] = {"area_m2": a, "gain_kwh": g_kwh, "gain_kwh_m2": g_kwh / a, "incident_kwh_m2": i_kwh / a,
                      "effective_g": g_kwh / i_kwh if i_kwh > 0 else float("nan"),
                      "peak_w_m2": float(gain.max() / a)}
        s = th.loads[name].summary().loc["total"]
        out[name] = {"orientation": per, "cooling_kwh": float(s["cooling_kWh"]), "heating_kwh": float(s["heating_kWh"]),
                     "peak_cooling_w": float(s["peak_cooling_W"]), "peak_cooling_time": s["peak_cooling_time"],
                     "window_gain_kwh": sum(v["gain_kwh"] for v in per.values())}
    return out


def _table(header, rows):
    h = "".join(f"<th>{escape(str(c))}</th>" for c in header)
    body = "".join("<tr>" + "".join(f"<td>{escape(str(c))}</td>" for c in r) + "</tr>" for r in rows)
    return f"<table><thead><tr>{h}</tr></thead><tbody>{body}</tbody></table>"


def thermal_section(run, folder, book: ChartBook):
    """HTML of the glazing and loads section (its charts registered in ``book``); writes ``loads.csv`` (per unit and
    zone: heating, cooling, solar [kWh], peaks [W] and their times) into ``folder``."""
    th, tcfg = run.thermal, run.config["thermal"]
    summ = thermal_summary(th, run.step_hours)
    frames = []
    for name in th.units:
        df = th.loads[name].summary()
        df.insert(0, "glazing", name)
        frames.append(df)
    pd.concat(frames).to_csv(folder / "loads.csv", index_label="zone", float_format="%.5g")
    rated_rows = [[name, f"{r['u_value']:.2f}", f"{r['g_normal']:.3f}", f"{r['g_diffuse']:.3f}",
                   f"{r['t_solar']:.3f}", f"{r['t_visible']:.3f}", f"{r['t_visible'] / r['g_normal']:.2f}"]
                  for name, r in th.rated.items()]
    orients = [o for o in ("north", "east", "south", "west") if o in summ[next(iter(summ))]["orientation"]]
    gain_rows, eff = [], {}
    for name, sm in summ.items():
        per = sm["orientation"]
        gain_rows.append([name, *(f"{per[o]['gain_kwh_m2']:.1f}" for o in orients),
                          *(f"{per[o]['effective_g']:.3f}" for o in orients), f"{sm['window_gain_kwh'] / 1000:.2f}"])
        eff[name] = [per[o]["gain_kwh_m2"] for o in orients]
    inc = summ[next(iter(summ))]["orientation"]
    area_text = ", ".join(f"{o} {inc[o]['area_m2']:.0f} m2 ({inc[o]['incident_kwh_m2']:.1f} kWh m-2 incident)"
                          for o in orients)
    fa = th.floor_area
    load_rows = [[name, f"{sm['cooling_kwh'] / 1000:.2f}", f"{sm['cooling_kwh'] / fa:.2f}",
                  f"{sm['peak_cooling_w'] / 1000:.1f}", f"{sm['peak_cooling_w'] / fa:.1f}",
                  str(sm["peak_cooling_time"])[:16], f"{sm['heating_kwh'] / 1000:.2f}"] for name, sm in summ.items()]
    times = run.result.times
    days = (times[-1] - times[0]).total_seconds() / 86400.0
    cols = {name: f"{name}:cooling [W]" for name in th.units}
    if days <= 15:
        series = {name: th.loads[name].cooling.sum(axis=1).to_numpy() / 1000.0 for name in th.units}
        chart = book.line("cooling-load", times.tz_localize(None).to_numpy(dtype="datetime64[ns]"), series,
                          title="Building cooling load per glazing unit", xlabel="time (local, interval label)",
                          ylabel="cooling [kW]", dates=True, legend_title="glazing",
                          source={"file": "timeseries.csv", "columns": cols, "how": "each step's value / 1000"})
    else:
        day = times.tz_localize(None).normalize()
        series = {name: pd.Series(th.loads[name].cooling.sum(axis=1).to_numpy() * run.step_hours / 1000.0,
                                  index=day).groupby(level=0).sum() for name in th.units}
        dn = next(iter(series.values())).index.to_numpy(dtype="datetime64[ns]")
        chart = book.line("cooling-daily", dn, {k: v.to_numpy() for k, v in series.items()},
                          title="Daily cooling energy per glazing unit", xlabel="date", ylabel="cooling [kWh day-1]",
                          dates=True, legend_title="glazing",
                          source={"file": "timeseries.csv", "columns": cols,
                                  "how": "sum over the steps of each local day x step hours / 1000"},
                          meta={"step_hours": run.step_hours})
    weather = run.config["sky"]["weather"] is not None
    temp_text = ("the weather file's air temperature" if weather else
                 f"a cosine design day repeated (mean {tcfg['temp_air']:g} degC, range {tcfg['temp_air_range']:g} K, "
                 "warmest at 15:00)")
    sky_loss = ("long-wave loss to the sky from the file's horizontal infrared" if th.temp_sky is not None
                else "no long-wave loss to the sky (no weather file)")
    return f"""<h2>Glazing, window gains and loads</h2>
<h3>The glazing units</h3>
{_table(["unit", "U [W m-2 K-1]", "g normal", "g diffuse", "T solar", "T visible", "selectivity T_vis/g"], rated_rows)}
<p class="note">Computed by thermal's layer model (EN 673 U-value, EN 410 g per wavelength and angle) and weighted
by the sky model's AM1.5 global spectrum (T visible: CIE 1931 photopic weighting). The built-in units are
modelled glass with idealised coatings (cases/glazing.py); <code>igdb:</code> units are measured IGDB samples.</p>
<h3>Window gains per orientation</h3>
{_table(["unit", *(f"{o} [kWh m-2]" for o in orients), *(f"eff. g {o}" for o in orients), "all windows [MWh]"],
        gain_rows)}
{book.bars("window-gain", orients, eff, title="Solar gain per m2 of glass over the period, per glazing unit",
           xlabel="facade", ylabel="gain [kWh m-2 of glass]", legend_title="glazing",
           source={"file": "timeseries.csv",
                   "columns": {n: {o: f"{n}:window gain {o} [W]" for o in orients} for n in summ},
                   "how": "sum over the period x step hours / 1000 / the facade's glass area"},
           meta={"glass_area_m2": {o: inc[o]["area_m2"] for o in orients}, "step_hours": run.step_hours})}
<p class="note">Gain: transmitted plus inward-flowing absorbed solar per m2 of glass, with each unit's g applied per
wavelength and per incoming direction (the sun at its angle of incidence, every sky patch and reflected ray at its
own; thermal's spectral route), shading and reflections by the scene included. Effective g: gain / global irradiance
on the glass. Glass per facade: {area_text}.</p>
<h3>Heating and cooling of the building</h3>
{_table(["unit", "cooling [MWh]", "cooling [kWh m-2 floor]", "peak cooling [kW]", "peak [W m-2 floor]",
         "peak at", "heating [MWh]"], load_rows)}
{chart}
<p class="note">ISO 13790 5R1C zones (thermal), {len(th.loads[next(iter(th.loads))].cooling.columns)} zones,
{fa:.0f} m2 of floor; ideal plant holding {tcfg['heating_setpoint']:g} / {tcfg['cooling_setpoint']:g} degC;
{tcfg['air_changes']:g} h-1, internal gains {tcfg['internal_gains']:g} W m-2 (constant), {tcfg['mass']} mass,
walls U {tcfg['wall_u']:g}, roof {tcfg['roof_u']:g}, ground floor {tcfg['floor_u']:g} W m-2 K-1 (b = 0.5);
outdoor air: {temp_text}; {sky_loss}. The first 14 days are run twice (warm-up). Per zone: <code>loads.csv</code>.</p>
"""
