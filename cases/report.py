"""The report folder of a case run: time series, per-face table, the integrator result, renders and an
offline HTML page (inline CSS, inline SVG charts, images embedded as data URIs: it opens without a network)."""

from __future__ import annotations

import base64
import shutil
from html import escape
from pathlib import Path

import numpy as np
import pandas as pd
from tqdm import tqdm

from widesky.irradiance import PRESETS
from widesky.pvsim import WATERFALL_STAGES
from widesky.skymodel.render import render_sky, write_exr, write_png

from .charts import bar_chart, line_chart
from .render3d import render_scene, write_glb, write_ply
from .report_thermal import thermal_columns, thermal_section
from .run_result import BANDS, CaseRun, dump_json

__all__ = ["write_report", "label_means"]

_CSS = """
body { font: 15px/1.45 system-ui, sans-serif; max-width: 1000px; margin: 1.5em auto; padding: 0 1em; color: #222; }
h1 { font-size: 1.6em; margin-bottom: 0.2em; } h2 { margin-top: 1.6em; border-bottom: 1px solid #ddd; }
table { border-collapse: collapse; font-variant-numeric: tabular-nums; margin: 0.6em 0; }
td, th { border-bottom: 1px solid #e3e3e3; padding: 0.2em 0.7em; text-align: right; }
th:first-child, td:first-child { text-align: left; }
.chart { width: 100%; height: auto; font: 12px sans-serif; }
.renders { display: flex; flex-wrap: wrap; gap: 1em; } .renders img { max-width: 480px; width: 100%; }
.note { color: #555; font-size: 0.93em; } code { background: #f3f3f3; padding: 0 0.2em; }
"""


def label_means(values, labels, area):
    """Area-weighted mean over the faces of each label: values (T, F) -> dict label -> (T,)."""
    out = {}
    labels = np.asarray(labels, dtype=object)
    for lab in dict.fromkeys(labels):
        sel = labels == lab
        w = area[sel] / area[sel].sum()
        out[lab] = np.asarray(values[:, sel], float) @ w
    return out


def _img_tag(path, alt):
    data = base64.b64encode(Path(path).read_bytes()).decode()
    return f'<img src="data:image/png;base64,{data}" alt="{escape(alt)}">'


def _table(header, rows):
    h = "".join(f"<th>{escape(str(c))}</th>" for c in header)
    body = "".join("<tr>" + "".join(f"<td>{escape(str(c))}</td>" for c in r) + "</tr>" for r in rows)
    return f"<table><thead><tr>{h}</tr></thead><tbody>{body}</tbody></table>"


def _write_series(run: CaseRun, folder: Path):
    res, area = run.result, run.result.faces.area
    cols = {}
    for q in res.QUANTITIES:
        for lab, v in label_means(getattr(res, q), run.labels, area).items():
            cols[f"{lab}:{q} [W m-2]"] = v
    for band in BANDS:
        for lab, v in label_means(res.get(band, "global"), run.labels, area).items():
            cols[f"{lab}:{band} [W m-2]"] = v
    if run.pv is not None:
        for name, ty in run.pv.technologies.items():
            for kind in ("dc", "ac"):
                cols[f"plant:{name}:{kind} [W]"] = sum(ty.series[g][kind].to_numpy() for g in run.pv_groups)
    if run.thermal is not None:
        cols.update(thermal_columns(run.thermal))
    df = pd.DataFrame(cols, index=res.times)
    df.index.name = "time (interval start)"
    df.to_csv(folder / "timeseries.csv", float_format="%.4g")
    written = ["timeseries.csv"]
    try:
        df.to_parquet(folder / "timeseries.parquet")
        written.append("timeseries.parquet")
    except ImportError:
        pass                       # no Parquet engine installed: the report says so
    return df, written


def hour_spectrum(hour):
    """(F, C) global spectral irradiance [W m-2 nm-1] of a one-step spectral result (the parts summed)."""
    return sum(np.asarray(a[0], float) for a in hour.spectral.values())


def _write_result(run: CaseRun, folder: Path, provenance):
    run.result.provenance.update(case=provenance)
    run.result.save(folder / "poa.h5", compression="gzip")   # the integrator's own HDF5 layout (POAResult.load); gzip: night rows and repeated parts compress ~5x (pv_plant: 396 -> 79 MB)
    run.hour.save(folder / "spectral_hour.h5")         # the report hour with its spectral parts
    dump_json(folder / "provenance.json", provenance)


_STAGE_TEXT = {"unshaded": "unshaded POA", "poa": "POA (after shading)", "cover": "after cover optics",
               "effective": "effective (spectral)", "bifacial": "with rear gain", "low_irradiance": "low irradiance",
               "temperature": "temperature", "dc": "DC", "ac": "AC"}


def _pv_section(run: CaseRun):
    """HTML of the PV yield: per technology the plant's rating, energy, specific yield and loss waterfall."""
    y = run.pv
    groups = run.pv_groups
    rows, wf, monthly = [], {}, {}
    months = y.times.month
    month_names = sorted(set(months))
    for name, ty in y.technologies.items():
        kwp = sum(ty.pdc0[g] for g in groups) / 1000.0
        e_ac = sum(ty.energy(g, "ac") for g in groups)
        e_dc = sum(ty.energy(g, "dc") for g in groups)
        w = {st: sum(ty.waterfall[g][st] * ty.pdc0[g] for g in groups) / (1000.0 * kwp) for st in WATERFALL_STAGES}
        wf[name] = w
        ac = sum(ty.series[g]["ac"].to_numpy() for g in groups) * ty.series[groups[0]].attrs["step_hours"] / 1000.0
        monthly[ty.technology.label] = [float(ac[months == m].sum() / kwp) for m in month_names]
        spectral = w["effective"] / w["cover"] - 1.0 if w["cover"] > 0 else 0.0
        rear = w["bifacial"] / w["effective"] - 1.0 if w["effective"] > 0 else 0.0
        rows.append([ty.technology.label, f"{100 * ty.eta_stc:.1f}", f"{kwp:.2f}", f"{e_dc / 1000:.2f}",
                     f"{e_ac / 1000:.2f}", e_ac / kwp, f"{e_dc / kwp:.1f}", f"{100 * spectral:+.2f}",
                     f"{100 * rear:+.2f}"])
    order = sorted(range(len(rows)), key=lambda i: -rows[i][5])
    for rank, i in enumerate(order, 1):
        rows[i] = rows[i][:5] + [f"{rows[i][5]:.1f}", str(rank)] + rows[i][6:]
    table = _table(["technology", "STC efficiency [%]", "rating [kWp]", "DC [MWh]", "AC [MWh]",
                    "specific yield [kWh/kWp]", "rank", "DC specific yield [kWh/kWp]", "spectral gain [%]",
                    "rear gain [%]"], rows)
    stage_rows = [[_STAGE_TEXT[st], *(f"{wf[n][st]:.1f}" for n in wf)] for st in WATERFALL_STAGES]
    waterfall = _table(["stage [kWh/kWp]", *(y.technologies[n].technology.label for n in wf)], stage_rows)
    month_label = ["Jan", "Feb", "Mar", "Apr", "May", "Jun", "Jul", "Aug", "Sep", "Oct", "Nov", "Dec"]
    chart = bar_chart([month_label[m - 1] for m in month_names], monthly, title="monthly specific yield (AC)",
                      xlabel="month", ylabel="specific yield [kWh/kWp]") if len(month_names) > 1 else ""
    pv = run.config["pv"]
    air = (f"Air temperature and wind from the weather file (hour by hour; {pv['temp_air']:g} degC and "
           f"{pv['wind_speed']:g} m s-1 where it gives none)" if run.config["sky"]["weather"] is not None else
           f"Air temperature {pv['temp_air']:g} degC and wind {pv['wind_speed']:g} m s-1 (constant)")
    return f"""<h2>PV yield per technology</h2>
{table}
<p class="note">The plant: every analysed module group ({', '.join(groups)}), front faces rated at STC
(front area x STC efficiency x 1000 W m-2), rear light added with each technology's bifaciality. Spectral gain:
the cell's effective irradiance against the same broadband light at the AM1.5G spectrum
({'the sky model' if pv['reference'] == 'widesky' else 'ASTM G173'} reference). {air}, {pv['temperature_model']} cell temperature,
DC losses {100 * pv['dc_loss']:g} %, PVWatts inverter (pvsim, docs/pvsim.md). The rank is by AC specific yield:
where the inverter clips (DC/AC ratio 1.2, pvsim's default), technologies with close DC yields can tie or swap in AC
(docs/pvsim.md, "Two oddities"): compare the DC column.</p>
<h3>Loss waterfall (reference yield per stage)</h3>
{waterfall}
{chart}
"""


def _orientation(normals):
    n = np.asarray(normals, float)
    tilt = np.degrees(np.arccos(np.clip(n[:, 2], -1, 1)))
    az = np.degrees(np.arctan2(n[:, 0], n[:, 1])) % 360.0
    return tilt, az


def _site_name(run):
    s = run.config["site"]
    if run.config["sky"]["weather"] is not None:
        return run.site.name or Path(str(run.config["sky"]["weather"])).stem
    return s["name"] or f"{s['latitude']:.2f}, {s['longitude']:.2f}"


def _compare_section(runs, folder: Path):
    """HTML (and ``sites.csv``) comparing the same case at several sites: per site the specific yield of each
    technology and its rank (with a [pv] section), else the insolation per group."""
    rows, table = [], {}
    if runs[0].pv is not None:
        names = list(runs[0].pv.technologies)
        labels = [runs[0].pv.technologies[n].technology.label for n in names]
        for r in runs:
            y = r.pv
            sy = []
            for n in names:
                ty = y.technologies[n]
                kwp = sum(ty.pdc0[g] for g in r.pv_groups) / 1000.0
                sy.append(sum(ty.energy(g, "ac") for g in r.pv_groups) / kwp)
            order = np.argsort(-np.asarray(sy))
            rank = {names[i]: k + 1 for k, i in enumerate(order)}
            table[_site_name(r)] = sy
            rows.append([_site_name(r), f"{r.site.latitude:.2f}", f"{r.site.longitude:.2f}",
                         *(f"{v:.1f} ({rank[n]})" for n, v in zip(names, sy)), labels[int(order[0])]])
        header = ["site", "latitude [deg]", "longitude [deg]", *(f"{lab} [kWh/kWp] (rank)" for lab in labels), "best"]
        ylabel, cats = "specific yield [kWh/kWp]", labels
    else:
        labels = list(dict.fromkeys(runs[0].labels))
        for r in runs:
            kwh = r.result.poa_global.astype(float).sum(axis=0) * r.step_hours / 1000.0
            lab = np.asarray(r.labels, dtype=object)
            a = r.result.faces.area
            vals = [float((kwh[lab == g] * a[lab == g]).sum() / a[lab == g].sum()) for g in labels]
            table[_site_name(r)] = vals
            rows.append([_site_name(r), f"{r.site.latitude:.2f}", f"{r.site.longitude:.2f}",
                         *(f"{v:.1f}" for v in vals), labels[int(np.argmax(vals))]])
        header = ["site", "latitude [deg]", "longitude [deg]", *(f"{g} [kWh m-2]" for g in labels), "highest"]
        ylabel, cats = "insolation [kWh m-2]", labels
    pd.DataFrame({k: v for k, v in table.items()}, index=cats).to_csv(folder / "sites.csv", float_format="%.5g")
    chart = bar_chart(cats, table, title="the same case at each site", xlabel="", ylabel=ylabel)
    return f"""<h2>Sites compared</h2>
{_table(header, rows)}
{chart}
<p class="note">The same scene, period (local time at each site), sky settings and accuracy at every site; the
sections below are those of the first site, {escape(_site_name(runs[0]))}. Per-site values in
<code>sites.csv</code>.</p>
"""


REPORT_STAGES = ("time series", "integrator result", "sky EXR and PNG", "scene renders", "coloured meshes",
                 "HTML page")


def write_report(run: CaseRun, folder, provenance, others=None, progress=False):
    """Write every output of ``run`` into ``folder`` (an empty temporary folder); ``others``: the same case at
    more sites (a "Sites compared" section and ``sites.csv``); ``progress``: a tqdm bar over
    :data:`REPORT_STAGES`."""
    folder = Path(folder)
    bar = tqdm(total=len(REPORT_STAGES), desc="report", unit="part", disable=not progress)

    def stage(i):
        bar.set_postfix_str(REPORT_STAGES[i], refresh=False)
        if i:
            bar.update(1)
    cfg, res, sc = run.config, run.result, run.scene
    area = res.faces.area
    kwh = res.poa_global.astype(float).sum(axis=0) * run.step_hours / 1000.0          # (F,) [kWh m-2]
    stage(0)
    df, series_files = _write_series(run, folder)
    stage(1)
    _write_result(run, folder, provenance)
    tilt, az = _orientation(sc.face_normal)
    faces = pd.DataFrame({"label": run.labels, "area_m2": area, "tilt_deg": tilt, "azimuth_deg": az,
                          "x_m": sc.points.reshape(sc.n_faces, -1, 3).mean(axis=1)[:, 0] + sc.origin[0],
                          "y_m": sc.points.reshape(sc.n_faces, -1, 3).mean(axis=1)[:, 1] + sc.origin[1],
                          "z_m": sc.points.reshape(sc.n_faces, -1, 3).mean(axis=1)[:, 2] + sc.origin[2],
                          "insolation_kwh_m2": kwh})
    faces.to_csv(folder / "faces.csv", index_label="face", float_format="%.5g")
    shutil.copyfile(run.folder / "case.toml", folder / "case.toml")

    # sky of the report hour: spectral EXR and sRGB PNG
    stage(2)
    st = res.times[run.hour_index]
    sp_el, sp_az = run.hour_sun
    sky_r = render_sky(run.dataset.model, sun_elevation=sp_el, sun_azimuth=sp_az,
                       visibility=cfg["sky"]["visibility"], albedo=cfg["sky"]["albedo"], resolution=256)
    write_exr(folder / "sky.exr", sky_r)
    write_png(folder / "sky.png", sky_r)

    # scene renders coloured by insolation (front sides; back sides shown where they face the camera)
    tri_val = np.full(len(sc.triangles), np.nan)
    front = sc.face_side == 0
    tri_val[sc.face_triangle[front]] = kwh[front]
    verts = sc.vertices + sc.origin
    up = sc.face_normal[:, 2] > -0.99                                  # colour range of the faces a view shows
    vmin, vmax = (float(np.min(kwh[up])), float(np.max(kwh[up]))) if up.any() else (float(np.min(kwh)),
                                                                                    float(np.max(kwh)))
    renders = []
    stage(3)
    for view in cfg["report"]["views"]:
        img = render_scene(verts, sc.triangles, tri_val, vmin=vmin, vmax=vmax, view=view,
                           size=cfg["report"]["render_size"], label="insolation", unit="kWh m-2",
                           cull=None if cfg["scene"]["two_sided"] else np.isfinite(tri_val))
        name = f"scene_{view}.png"
        img.save(folder / name)
        renders.append(name)
    stage(4)
    write_ply(folder / "scene.ply", verts, sc.triangles, tri_val, vmin=vmin, vmax=vmax)
    write_glb(folder / "scene.glb", verts, sc.triangles, tri_val, vmin=vmin, vmax=vmax)
    stage(5)

    # --- the page -------------------------------------------------------------------------------------
    labels = list(dict.fromkeys(run.labels))
    lab_arr = np.asarray(run.labels, dtype=object)
    parts_total = {q: label_means(getattr(res, q), run.labels, area) for q in res.QUANTITIES}
    rows = []
    for lab in labels:
        sel = lab_arr == lab
        a = area[sel].sum()
        e = float((kwh[sel] * area[sel]).sum() / a)
        g = parts_total["poa_global"][lab].sum()
        share = [100 * parts_total[q][lab].sum() / g if g > 0 else 0.0 for q in res.QUANTITIES[1:]]
        rows.append([lab, int(sel.sum()), f"{a:.1f}", f"{e:.1f}", f"{e * a / 1000:.2f}",
                     f"{kwh[sel].min():.1f} - {kwh[sel].max():.1f}", f"{parts_total['poa_global'][lab].max():.0f}",
                     *(f"{s:.1f}" for s in share)])
    summary = _table(["group", "faces", "area [m2]", "insolation [kWh m-2]", "energy [MWh]", "face range [kWh m-2]",
                      "peak [W m-2]", "direct [%]", "sky diffuse [%]", "reflected [%]"], rows)
    months = res.times.month
    month_names = sorted(set(months))
    monthly = {lab: [float(parts_total["poa_global"][lab][months == m].sum() * run.step_hours / 1000) for m in month_names]
               for lab in labels}
    day = res.times.normalize()
    days = pd.Index(sorted(set(day)))
    daily = {lab: pd.Series(parts_total["poa_global"][lab] * run.step_hours / 1000, index=day).groupby(level=0).sum()
             .reindex(days).to_numpy() for lab in labels}
    month_label = ["Jan", "Feb", "Mar", "Apr", "May", "Jun", "Jul", "Aug", "Sep", "Oct", "Nov", "Dec"]
    charts = []
    if len(month_names) > 1:
        charts.append(bar_chart([month_label[m - 1] for m in month_names], monthly, title="monthly insolation",
                                xlabel="month", ylabel="insolation [kWh m-2]"))
    dnum = np.arange(len(days))
    step = max(1, len(days) // 8)
    charts.append(line_chart(dnum, daily, title="daily insolation", xlabel="day", ylabel="insolation [kWh m-2 day-1]",
                             xticks=[(i, days[i].strftime("%d %b")) for i in dnum[::step]]))
    band_means = {b: label_means(res.get(b, "global"), run.labels, area) for b in BANDS}
    band_tot = {lab: [float(band_means[b][lab].sum()) for b in BANDS] for lab in labels}
    band_frac = {lab: [100 * v / max(parts_total["poa_global"][lab].sum(), 1e-30) for v in vals]
                 for lab, vals in band_tot.items()}
    charts.append(bar_chart(list(BANDS), band_frac, title="spectral split of the period's irradiance",
                            xlabel="band", ylabel="share of 280-2480 nm [%]"))
    spec = label_means(hour_spectrum(run.hour).T, run.labels, area)                  # label -> (C,)
    charts.append(line_chart(res.wavelengths, spec, title=f"spectral irradiance at {st}",
                             xlabel="wavelength [nm]", ylabel="irradiance [W m-2 nm-1]"))
    s = _settings_text(run)
    files = ["index.html", *series_files, "faces.csv", "poa.h5", "spectral_hour.h5", "provenance.json", "case.toml",
             "sky.exr",
             "sky.png", *renders, "scene.ply", "scene.glb"]
    parquet_note = "" if "timeseries.parquet" in series_files else (
        "<p class='note'>timeseries.parquet was not written: no Parquet engine is installed "
        "(<code>pip install pyarrow</code>).</p>")
    tm = run.timings
    thermal_html = ""
    if run.thermal is not None:
        thermal_html = thermal_section(run, folder)
        files.append("loads.csv")
    compare = _compare_section([run, *others], folder) if others else ""
    if others:
        files.append("sites.csv")
    html = f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{escape(cfg['case']['title'])}</title>
<style>{_CSS}</style></head><body>
<h1>{escape(cfg['case']['title'])}</h1>
<p class="headline"><b>{escape(run.site.name or cfg['site']['name'] or 'site')}</b>
({run.site.latitude:.2f}, {run.site.longitude:.2f}) &middot; {cfg['period']['start']:%Y-%m-%d} to
{cfg['period']['end']:%Y-%m-%d} &middot; sky: {escape(run.weather)}</p>
<p>{escape(cfg['case']['description'])}</p>
{_table(["", ""], [
    ["site", f"{run.site.name or cfg['site']['name']} {run.site.latitude:.3f} N, {run.site.longitude:.3f} E, "
             f"{run.site.altitude:g} m, {cfg['site']['tz'] if not cfg['sky']['weather'] else run.site.tz}"
             + (" (the weather file's)" if cfg['sky']['weather'] else "")],
    ["period", f"{cfg['period']['start']} to {cfg['period']['end']} (exclusive), "
               + (f"step {cfg['period']['step']}, " if not cfg['sky']['weather'] else "the weather file's steps, ")
               + f"{len(res.times)} steps (times label the interval "
               + ("start" if not cfg['sky']['weather'] else "end, as the file does") + "; the sun at mid-interval)"],
    ["sky", f"{run.weather}, visibility {cfg['sky']['visibility']:g} km, albedo {cfg['sky']['albedo']:g}"
            + (" (where the file gives none)" if cfg['sky']['weather'] else "")
            + f", dataset {Path(str(run.dataset.model.path)).name}"],
    ["scene", f"{sc.n_faces} analysed faces in {len(labels)} groups, {len(sc.triangles)} triangles in all"],
    ["run time", f"{tm.get('compute_total', 0):.1f} s" + (f" for {1 + len(others)} sites; this site:" if others else "")
                 + f" (integrator {tm.get('integrator', 0):.1f} s, spectral hour "
                 f"{tm.get('spectral_hour', 0):.1f} s" + (f", PV yield {tm['pv_yield']:.1f} s" if "pv_yield" in tm else "")
                 + (f", loads {tm['thermal']:.1f} s" if "thermal" in tm else "")
                 + ")"],
])}
{compare}
{_pv_section(run) if run.pv is not None else ""}
{thermal_html}
<h2>Irradiance per group</h2>
{summary}
<p class="note">Insolation: the period's sum of plane-of-array global irradiance (280-2480 nm) per m2,
area-weighted over the group's faces; shares of direct (sun and circumsolar), sky-diffuse and reflected
(ground and scene surfaces) light.</p>
{''.join(charts[:-2])}
<h2>Spectra</h2>
{charts[-2]}
{charts[-1]}
<h2>Maps</h2>
<div class="renders">{''.join(_img_tag(folder / r, r) for r in renders)}</div>
<p class="note">The coloured mesh is in <code>scene.glb</code> (binary glTF: browsers' and most 3D viewers) and
<code>scene.ply</code>; grey: context geometry.</p>
<h2>Sky at {st}</h2>
{_img_tag(folder / 'sky.png', 'sky')}
<p class="note">Up-facing fisheye (north at the top, east on the left), sun elevation {sp_el:.1f} deg, azimuth
{sp_az:.1f} deg; all 55 channels in <code>sky.exr</code> (spectral OpenEXR layout).</p>
<h2>Accuracy and limits</h2>
{s}
<h2>Files</h2>
<ul>{''.join(f'<li><a href="{f}">{f}</a></li>' for f in files)}</ul>
{parquet_note}
<p class="note">widesky {escape(str(provenance['versions'].get('widesky')))}; provenance (versions, dataset
SHA-1, settings, timings) in <code>provenance.json</code>.</p>
</body></html>
"""
    (folder / "index.html").write_text(html, encoding="utf-8")
    bar.update(1)
    bar.close()


def _settings_text(run: CaseRun):
    tol = run.config["accuracy"]["tolerance"]
    bound = next(t for t, s in PRESETS if s == run.settings)
    st = run.settings
    return (f"<p>Integrator preset for tolerance {tol:g}: Reinhart subdivision mf={st.mf} "
            f"({145 if st.mf == 1 else 'more'} sky patches), {st.rays_per_patch}x{st.rays_per_patch} rays per patch, "
            f"sun bins of {st.sun_bin:g} deg. Its measured error: at most {100 * bound:.2g} % on a point's annual "
            "global irradiance on the two validation scenes against the brute-force reference "
            "(docs/irradiance-integrator.md, \"Accuracy against speed\"); other scenes can do worse.</p>"
            + _sky_limits(run))


def _sky_limits(run: CaseRun) -> str:
    """What the report's sky is and is not (the run's sky model, from its description)."""
    low = ("below 0 deg the sky is dark; the embedded dataset's low-sun sky (below 9 deg) comes from a "
           "spherical-shell solver (docs/default-dataset.md).")
    if "all-sky" in run.weather:
        return ("<p>The sky is measured weather: every hour keeps the file's broadband DNI and DHI, with the all-sky "
                "model's spectra and angular shape (cloud light shaped by droplets and water vapour, CIE overcast "
                "light, haze, a vegetated ground; docs/all-sky.md) on top of the dataset's clear sky; " + low + "</p>")
    if "clear-sky spectra" in run.weather:
        return ("<p>The sky is measured weather: every hour keeps the file's broadband DNI and DHI, with the clear "
                "sky's spectral and angular shape scaled to them (no cloud spectra: docs/all-sky.md); " + low + "</p>")
    return ("<p>The sky is the clear-sky Prague Sky Model of the dataset, every hour cloudless: the yields are an "
            "upper bound, not an expected year (give the case a weather file for that); " + low + "</p>")
