"""The report's glazing and loads section (cases with a ``[thermal]`` section): rated values of the units, window
gains per orientation, effective g, the gains and long-wave losses per facade, the building's energy balance, heating
and cooling per unit with the per-zone peaks and their dates, the cooling load over time, the spectral-versus-rated
glazing difference per month, and ``loads.csv``.

Units: gains and loads [W], [kWh]; per m2 of glass [kWh m-2]; temperatures [degC]; U [W m-2 K-1].
"""

from __future__ import annotations

from html import escape

import numpy as np
import pandas as pd

from widesky.irradiance.skystate import interval_months, interval_starts, interval_text, utc_offset_text

from .building_loads import ThermalRun
from .charts import ChartBook

__all__ = ["thermal_columns", "thermal_summary", "thermal_section", "FACADE_PARTS"]

FACADE_PARTS = {"transmitted": "transmitted solar", "opaque": "opaque solar", "sky_loss": "long-wave loss"}
"""Per-facade parts of the solar and long-wave balance: key -> column and chart name."""
_MONTHS = ["Jan", "Feb", "Mar", "Apr", "May", "Jun", "Jul", "Aug", "Sep", "Oct", "Nov", "Dec"]


def thermal_columns(th: ThermalRun):
    """Time-series columns (name -> (T,)): per unit the window gain per orientation [W], per facade the transmitted
    solar, opaque solar and long-wave loss [W], the whole building's window gain without the shading device on the
    spectral and on the rated route [W], and the building's cooling and heating [W]; the air and sky temperatures
    [degC], the internal gains per m2 of floor [W m-2] and the occupied steps [1]."""
    cols = {"building:temp_air [degC]": th.temp_air}
    if th.temp_sky is not None:
        cols["building:temp_sky [degC]"] = th.temp_sky
    if th.internal is not None:
        cols["building:internal gains [W m-2]"] = th.internal["total"]
        cols["building:occupied [1]"] = th.occupied.astype(float)
    for name in th.units:
        for o, (_, gain, _) in th.orientation_gains(name).items():
            cols[f"{name}:window gain {o} [W]"] = gain
        if th.facade_of is not None and th.loads[name].parts is not None:
            for f, parts in th.facade_parts(name).items():
                for k, label in FACADE_PARTS.items():
                    cols[f"{name}:{label} {f} [W]"] = parts[k]
        if th.rated_gain and name in th.rated_gain:
            cols[f"{name}:window gain unshaded spectral [W]"] = th.bare_gain[name] @ th.window_area
            cols[f"{name}:window gain unshaded rated [W]"] = th.rated_gain[name] @ th.window_area
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
                     "peak_heating_w": float(s["peak_heating_W"]), "peak_heating_time": s["peak_heating_time"],
                     "window_gain_kwh": sum(v["gain_kwh"] for v in per.values())}
    return out


def _table(header, rows):
    h = "".join(f"<th>{escape(str(c))}</th>" for c in header)
    body = "".join("<tr>" + "".join(f"<td>{escape(str(c))}</td>" for c in r) + "</tr>" for r in rows)
    return f"<table><thead><tr>{h}</tr></thead><tbody>{body}</tbody></table>"


def _fmt_time(t, label, step):
    """A step's hour as its interval, e.g. "31 Dec 23:00-24:00" for the EPW hour labelled 1 Jan 00:00 (its end):
    by the interval's start (irradiance.skystate.interval_starts), whatever the label."""
    return interval_text(t, label, step)


def _facade_html(th, step_hours, book):
    """Per unit and facade: transmitted solar, opaque solar, long-wave loss [MWh], hours with the device deployed;
    the chart of the first unit."""
    if th.facade_of is None or th.loads[next(iter(th.units))].parts is None:
        return ""
    orient = th.orientation_of()
    rows, first = [], next(iter(th.units))
    chart = {}
    for name in th.units:
        for f, parts in th.facade_parts(name).items():
            e = {k: float(v.sum() * step_hours / 1e6) for k, v in parts.items()}
            sel = [j for j, o in enumerate(orient) if o == f]
            hours = (f"{th.deployed[name][:, sel].mean(axis=1).sum() * step_hours:.0f}"
                     if sel and th.deployed is not None else "-")
            rows.append([name, f, f"{e['transmitted']:.2f}", f"{e['opaque']:.2f}", f"{e['sky_loss']:.2f}",
                         f"{e['transmitted'] + e['opaque'] - e['sky_loss']:.2f}", hours])
            if name == first:
                chart[f] = e
    facades = list(chart)
    series = {FACADE_PARTS["transmitted"]: [chart[f]["transmitted"] for f in facades],
              FACADE_PARTS["opaque"]: [chart[f]["opaque"] for f in facades],
              FACADE_PARTS["sky_loss"]: [-chart[f]["sky_loss"] for f in facades]}
    img = book.bars("facade-balance", facades, series,
                    title=f"Solar gains and long-wave loss per facade, {first} glazing",
                    xlabel="facade", ylabel="energy over the period [MWh] (loss < 0)", legend_title="part",
                    source={"file": "timeseries.csv",
                            "columns": {lab: {f: f"{first}:{lab} {f} [W]" for f in facades}
                                        for lab in FACADE_PARTS.values()},
                            "how": "sum over the period x step hours / 1e6; the long-wave loss negated"},
                    meta={"unit": first, "step_hours": step_hours})
    return f"""<h3>Gains and losses per facade</h3>
{_table(["unit", "facade", "transmitted solar [MWh]", "opaque solar [MWh]", "long-wave loss [MWh]", "net [MWh]",
         "blinds lowered [h]"], rows)}
{img}
<p class="note">Transmitted solar: through the glass into the zones (after the shading device); opaque solar: the
share of the shortwave absorbed on walls, window frames and the roof that reaches the zones (ISO 13790 11.3.4,
alpha R_se U A E); long-wave loss: to the sky, R_se U A h_r F_r (theta_air - theta_sky) (ISO 13790 11.3.5), from the
walls, frames, glass and roof. Blinds lowered: hours with the device down, averaged over the facade's windows.</p>"""


def _balance_html(th):
    """The building's energy balance per unit [MWh]."""
    lr0 = th.loads[next(iter(th.units))]
    if lr0.parts is None or lr0.flows is None:
        return ""
    names = {"internal": "internal gains", "solar_transmitted": "transmitted solar", "solar_opaque": "opaque solar",
             "sky_loss": "long-wave loss to the sky", "radiated_out": "radiated out through the glazing",
             "ventilation": "ventilation", "transmission_windows": "transmission, windows",
             "transmission_opaque": "transmission, opaque", "heating": "heating", "cooling": "cooling",
             "storage": "stored in the mass", "residual": "residual"}
    bal = {name: th.loads[name].balance().loc["total"] for name in th.units}
    rows = [[label, *(f"{bal[n][k] / 1000:.3f}" if k in ("storage", "residual") else f"{bal[n][k] / 1000:.2f}"
                      for n in th.units)] for k, label in names.items()]
    return f"""<h3>Energy balance of the building</h3>
{_table(["term [MWh]", *th.units], rows)}
<p class="note">In: internal, transmitted and opaque solar gains, heating; out: the long-wave loss to the sky, the
share of the radiative gains the 5R1C network sends straight out through the glazing (ISO 13790 C.2), ventilation,
transmission through windows (glass and frames) and opaque elements, cooling, and the heat stored in the mass over
the period. Residual: in - out - stored, zero to rounding.</p>"""


def _peaks_html(th, weather, label, step):
    """Per zone and unit: peak heating and cooling [kW] and their hours (as intervals)."""
    stamp = ("local standard time, as the weather file's hours" if weather else "local time")
    summ = {name: th.loads[name].summary() for name in th.units}
    zones = list(summ[next(iter(summ))].index)
    rows = []
    for z in zones:
        r = [z]
        for name in th.units:
            s = summ[name].loc[z]
            r += [f"{s['peak_heating_W'] / 1000:.1f} ({_fmt_time(s['peak_heating_time'], label, step)})",
                  f"{s['peak_cooling_W'] / 1000:.1f} ({_fmt_time(s['peak_cooling_time'], label, step)})"]
        rows.append(r)
    header = ["zone", *(f"{n}: {k} peak [kW] (at)" for n in th.units for k in ("heating", "cooling"))]
    return f"""<h3>Peak loads per zone</h3>
{_table(header, rows)}
<p class="note">Zone f&lt;storey&gt;_&lt;facade&gt;: the perimeter zone of that storey behind that facade (f0 the
ground floor). Each peak is shown as its step's interval, start-end ({stamp}; 31 Dec 23:00-24:00 is the
year's last hour); the building's peak (total) is the peak of
the summed load, not the sum of the zones' peaks.</p>"""


def _monthly(values, months):
    return [float(values[months == m].sum()) for m in range(1, 13)]


def _routes_html(th, times, step_hours, book, label="left"):
    """Spectral against rated glazing gains per month (by each step's interval start; whole building, without the
    shading device)."""
    if not th.rated_gain:
        return ""
    month = interval_months(times, label, pd.Timedelta(hours=step_hours))
    present = [m for m in range(1, 13) if np.any(month == m)]
    rows, series = [], {}
    tot = {}
    for name in th.units:
        sp = _monthly(th.bare_gain[name] @ th.window_area * step_hours / 1000.0, month)
        ra = _monthly(th.rated_gain[name] @ th.window_area * step_hours / 1000.0, month)
        series[name] = [100.0 * (sp[m - 1] - ra[m - 1]) / ra[m - 1] if ra[m - 1] > 0 else float("nan")
                        for m in present]
        tot[name] = (sum(sp), sum(ra))
    for i, m in enumerate(present):
        r = [_MONTHS[m - 1]]
        for name in th.units:
            sp = float((th.bare_gain[name] @ th.window_area)[month == m].sum() * step_hours / 1000.0)
            r += [f"{sp:.0f}", f"{series[name][i]:+.1f}"]
        rows.append(r)
    rows.append(["year", *(x for n in th.units for x in (f"{tot[n][0]:.0f}",
                                                         f"{100 * (tot[n][0] - tot[n][1]) / tot[n][1]:+.1f}"))])
    img = book.bars("spectral-rated", [_MONTHS[m - 1] for m in present], series,
                    title="Window gain on the spectral route against the rated route, per month",
                    xlabel="month", ylabel="(spectral - rated) / rated [%]", legend_title="glazing",
                    source={"file": "timeseries.csv",
                            "columns": {n: {"spectral": f"{n}:window gain unshaded spectral [W]",
                                            "rated": f"{n}:window gain unshaded rated [W]"} for n in th.units},
                            "how": "100 (sum of spectral - sum of rated) / sum of rated over each month's steps "
                                   "(by the interval's start)"})
    return f"""<h3>Spectral against rated glazing, per month</h3>
{_table(["month", *(x for n in th.units for x in (f"{n}: gain [kWh]", f"{n}: spectral - rated [%]"))], rows)}
{img}
<p class="note">The gain through all windows (glass area, without the shading device) with each unit's g applied per
wavelength and direction under each hour's sky spectrum (spectral route), against the same unit's AM1.5-global
weighted g by angle applied to the same light (rated route, what a program fed the rated g computes). The difference
is the spectrum alone: the sky's light is bluer than AM1.5 in diffuse light and redder at low sun, and a selective
(solar-control) unit passes less of the near infrared than its rated g assumes (docs/thermal.md).</p>"""


def _monthly_loads_chart(th, times, step_hours, book, label="left"):
    month = interval_months(times, label, pd.Timedelta(hours=step_hours))    # by the interval's start
    present = [m for m in range(1, 13) if np.any(month == m)]
    series, cols = {}, {}
    for name in th.units:
        lr = th.loads[name]
        for k, df in (("heating", lr.heating), ("cooling", lr.cooling)):
            v = df.sum(axis=1).to_numpy() * step_hours / 1e6
            series[f"{name} {k}"] = [float(v[month == m].sum()) for m in present]
            cols[f"{name} {k}"] = f"{name}:{k} [W]"
    return book.bars("loads-monthly", [_MONTHS[m - 1] for m in present], series,
                     title="Monthly heating and cooling of the building per glazing unit", xlabel="month",
                     ylabel="energy [MWh]", legend_title="glazing and load",
                     source={"file": "timeseries.csv", "columns": cols,
                             "how": "sum over each month's steps (by the interval's start) x step hours / 1e6"})


def _thermostat_text(tcfg):
    """The thermostat in words: the set-points and when they hold."""
    heat, cool = tcfg["heating_setpoint"], tcfg["cooling_setpoint"]
    if tcfg.get("thermostat", "constant") != "office":
        return f"{heat:g} / {cool:g} degC every hour"
    return (f"{heat:g} / {cool:g} degC on weekdays 06:00-22:00 and Saturdays 06:00-18:00, "
            f"{tcfg['heating_setback']:g} / {tcfg['cooling_setup']:g} degC otherwise (the DOE reference office's "
            "thermostat hours)")


def _use_text(th, tcfg, step_hours=1.0):
    """The zones' use, frames and shading device in words (``step_hours`` [h])."""
    if tcfg.get("schedule", "constant") == "office":
        from widesky.thermal.schedules import OFFICE_DENSITIES as d
        occ = int(th.occupied.sum())
        use = (f"office use: people ({d['people_m2']:g} m2 per person, {d['people_w']:g} W sensible each), lighting "
               f"{d['lighting_w_m2']:g} W m-2 and equipment {d['equipment_w_m2']:g} W m-2 at their peaks, on the "
               "hourly weekday, Saturday and Sunday profiles of the ASHRAE 90.1 User's Manual office (the DOE "
               "reference office schedules; thermal.schedules), mean "
               f"{float(np.mean(th.internal['total'])):.1f} W m-2 over the period; {occ} occupied hours "
               "(occupancy at least half)")
    else:
        use = f"internal gains {tcfg['internal_gains']:g} W m-2 (constant, every hour)"
    ff = float(tcfg.get("frame_fraction", 0.0))
    frames = (f"frames {100 * ff:.0f} % of each window's area at U_f {tcfg['frame_u']:g} W m-2 K-1 (ISO 10077-1)"
              if ff > 0 else "no frames (the whole window is glass)")
    fsh = float(tcfg.get("shading_factor", 1.0))
    if fsh < 1:
        hours = ", ".join(f"{name} {th.deployed[name].mean(axis=1).sum() * step_hours:.0f}" for name in th.units) \
            if th.deployed is not None else "0"
        unless = (", unless its zone heated in the previous hour" if tcfg.get("shading_control") == "solar-not-heating"
                  else "")
        shade = (f"a shading device that multiplies the glazing's g by {fsh:g} when lowered (ISO 13790 Table 16), "
                 f"lowered in an occupied hour when the global irradiance on that window exceeds "
                 f"{tcfg['shading_threshold']:g} W m-2{unless} (hours per window on average: {hours})")
    else:
        shade = "no shading device"
    return f"{use}; {frames}; {shade}"


def thermal_section(run, folder, book: ChartBook):
    """HTML of the glazing and loads section (its charts registered in ``book``); writes ``loads.csv`` (per unit and
    zone: heating, cooling, solar [kWh], peaks [W] and their hours as intervals in local time) into ``folder``."""
    th, tcfg = run.thermal, run.config["thermal"]
    summ = thermal_summary(th, run.step_hours)
    frames = []
    step = pd.Timedelta(hours=run.step_hours)
    for name in th.units:
        df = th.loads[name].summary()
        df.insert(0, "glazing", name)
        # a peak's hour as its interval in local time, "2023-12-31 23:00-24:00 (UTC-07:00)", not the weather file's
        # end label of it ("2024-01-01 00:00:00-07:00", a year the file does not cover)
        for kind in ("heating", "cooling"):
            col = df.pop(f"peak_{kind}_time")
            df.insert(df.columns.get_loc(f"peak_{kind}_W") + 1, f"peak_{kind}_hour",
                      [f"{interval_text(t, run.label, step, '%Y-%m-%d %H:%M')} ({utc_offset_text(t)})" for t in col])
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
    step = pd.Timedelta(hours=run.step_hours)
    load_rows = [[name, f"{sm['cooling_kwh'] / 1000:.2f}", f"{sm['cooling_kwh'] / fa:.2f}",
                  f"{sm['peak_cooling_w'] / 1000:.1f}", f"{sm['peak_cooling_w'] / fa:.1f}",
                  _fmt_time(sm["peak_cooling_time"], run.label, step), f"{sm['heating_kwh'] / 1000:.2f}",
                  f"{sm['heating_kwh'] / fa:.2f}", f"{sm['peak_heating_w'] / 1000:.1f}",
                  _fmt_time(sm["peak_heating_time"], run.label, step)] for name, sm in summ.items()]
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
        day = interval_starts(times, run.label, step).tz_localize(None).normalize()    # by the interval's start
        series = {name: pd.Series(th.loads[name].cooling.sum(axis=1).to_numpy() * run.step_hours / 1000.0,
                                  index=day).groupby(level=0).sum() for name in th.units}
        dn = next(iter(series.values())).index.to_numpy(dtype="datetime64[ns]")
        chart = book.line("cooling-daily", dn, {k: v.to_numpy() for k, v in series.items()},
                          title="Daily cooling energy per glazing unit", xlabel="date", ylabel="cooling [kWh day-1]",
                          dates=True, legend_title="glazing",
                          source={"file": "timeseries.csv", "columns": cols,
                                  "how": "sum over the steps of each local day (by the interval's start) x step "
                                         "hours / 1000"},
                          meta={"step_hours": run.step_hours})
    annual = days > 60
    monthly = _monthly_loads_chart(th, times, run.step_hours, book, run.label) if annual else ""
    facade_html = _facade_html(th, run.step_hours, book)
    balance_html = _balance_html(th)
    peaks_html = _peaks_html(th, run.config["sky"]["weather"] is not None, run.label, step)
    routes_html = _routes_html(th, times, run.step_hours, book, run.label)
    weather = run.config["sky"]["weather"] is not None
    temp_text = ("the weather file's air temperature" if weather else
                 f"a cosine design day repeated (mean {tcfg['temp_air']:g} degC, range {tcfg['temp_air_range']:g} K, "
                 "warmest at 15:00)")
    sky_loss = ("long-wave loss to the sky at the sky temperature (IR_h / sigma)^(1/4) of the file's horizontal "
                "infrared IR_h" if th.temp_sky is not None else "no long-wave loss to the sky (no weather file)")
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
         "peak at", "heating [MWh]", "heating [kWh m-2 floor]", "peak heating [kW]", "peak at"], load_rows)}
{monthly}
{chart}
<p class="note">ISO 13790 5R1C zones (thermal), {len(th.loads[next(iter(th.loads))].cooling.columns)} zones,
{fa:.0f} m2 of floor; ideal plant holding {escape(_thermostat_text(tcfg))};
{tcfg['air_changes']:g} h-1, {escape(_use_text(th, tcfg, run.step_hours))}; {tcfg['mass']} mass,
walls U {tcfg['wall_u']:g}, roof {tcfg['roof_u']:g}, ground floor {tcfg['floor_u']:g} W m-2 K-1 (b = 0.5);
outdoor air: {temp_text}; {sky_loss}. The first 14 days are run twice (warm-up). Per zone: <code>loads.csv</code>.</p>
{peaks_html}
{facade_html}
{balance_html}
{routes_html}
"""
