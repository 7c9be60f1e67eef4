"""The report folder of a case run: time series, per-face table, the integrator result, renders and an
offline HTML page (inline CSS; charts drawn by matplotlib and images embedded as data URIs: it opens without a
network), and ``charts.json``: the data of every chart with the result file it comes from."""

from __future__ import annotations

import base64
import shutil
from html import escape
from pathlib import Path

import numpy as np
import pandas as pd
from tqdm import tqdm

from widesky.irradiance import PRESETS
from widesky.irradiance.skystate import interval_months, interval_starts, interval_text, utc_offset_text
from widesky.pvsim import WATERFALL_STAGES, SystemSpec, pvwatts_inverter
from widesky.skymodel.render import render_sky, write_exr, write_png

from .charts import ChartBook
from .render3d import render_scene, write_glb, write_ply
from .report_thermal import thermal_columns, thermal_section
from .run_result import BANDS, CaseRun, dump_json

__all__ = ["write_report", "label_means", "hour_spectrum", "format_position"]

_CSS = """
body { font: 15px/1.45 system-ui, sans-serif; max-width: 1000px; margin: 1.5em auto; padding: 0 1em; color: #222; }
h1 { font-size: 1.6em; margin-bottom: 0.2em; } h2 { margin-top: 1.6em; border-bottom: 1px solid #ddd; }
table { border-collapse: collapse; font-variant-numeric: tabular-nums; margin: 0.6em 0; }
td, th { border-bottom: 1px solid #e3e3e3; padding: 0.2em 0.7em; text-align: right; }
th:first-child, td:first-child { text-align: left; }
figure.chart { margin: 0.8em 0; } figure.chart img { max-width: 100%; height: auto; }
.glance { background: #f6f8fa; border: 1px solid #dde3ea; padding: 0.4em 1em 0.6em; margin: 0.8em 0; }
.glance h2 { margin-top: 0.3em; border: none; font-size: 1.15em; }
.glance td:first-child { font-weight: 600; vertical-align: top; white-space: nowrap; } .glance td { text-align: left; }
.caveat { color: #7a3b00; }
table.kv td { text-align: left; } table.kv td:first-child { white-space: nowrap; }
.renders { display: flex; flex-wrap: wrap; gap: 1em; } .renders img { max-width: 100%; }
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


def _kv_table(rows):
    """A two-column table of names and values (no header; values left-aligned)."""
    body = "".join(f"<tr><td>{escape(str(k))}</td><td>{escape(str(v))}</td></tr>" for k, v in rows)
    return f'<table class="kv"><tbody>{body}</tbody></table>'


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
    # the column says what the times label: a weather file's hours are stamped with their end (EPW, TMY3)
    df.index.name = f"time (interval {dict(left='start', right='end', center='middle')[run.label]})"
    df.to_csv(folder / "timeseries.csv", float_format="%.4g")
    written = ["timeseries.csv"]
    try:
        df.to_parquet(folder / "timeseries.parquet")
        written.append("timeseries.parquet")
    except ImportError:
        pass                       # no Parquet engine installed: the report says so
    return df, written


def hour_spectrum(hour):
    """(F, C) global spectral irradiance [W m-2 nm-1] of a one-step spectral result: its ``global`` array (the sum
    of its direct, sky-diffuse and ground-diffuse parts; only a result without one sums the parts)."""
    sp = hour.spectral
    if "global" in sp:
        return np.asarray(sp["global"][0], float)
    return sum(np.asarray(a[0], float) for a in sp.values())


def format_position(latitude, longitude):
    """``"39.833 N, 104.650 W"``: a position with hemisphere letters [deg]."""
    return (f"{abs(latitude):.3f} {'N' if latitude >= 0 else 'S'}, "
            f"{abs(longitude):.3f} {'E' if longitude >= 0 else 'W'}")


def _plural(n, word):
    return f"{n} {word}" + ("" if n == 1 else "s")


def _write_result(run: CaseRun, folder: Path, provenance):
    run.result.provenance.update(case=provenance)
    run.result.save(folder / "poa.h5", compression="gzip")   # the integrator's own HDF5 layout (POAResult.load); gzip: night rows and repeated parts compress ~5x (pv_plant: 396 -> 79 MB)
    run.hour.save(folder / "spectral_hour.h5")         # the report hour with its spectral parts
    dump_json(folder / "provenance.json", provenance)


_STAGE_TEXT = {"unshaded": "unshaded POA", "poa": "POA (after shading)", "cover": "after cover optics",
               "effective": "effective (spectral)", "bifacial": "with rear gain", "low_irradiance": "low irradiance",
               "temperature": "temperature", "dc": "DC (after DC losses)",
               "inverter": "AC before clipping (inverter efficiency)", "ac": "AC (after inverter clipping)"}
REPORT_STAGES_PV = (*WATERFALL_STAGES[:-1], "inverter", "ac")
"""The report's waterfall: pvsim's stages with the inverter split into its conversion loss and its clipping."""


def pv_numbers(run: CaseRun):
    """Per technology name: ``label``, ``eta_stc`` [1], ``kwp``, ``e_dc``, ``e_ac`` [kWh], ``sy_dc``, ``sy_ac``
    [kWh/kWp], ``waterfall`` (stage of :data:`REPORT_STAGES_PV` -> kWh/kWp over the plant's groups) and ``ac``
    (T,) plant AC power [W]."""
    y, groups = run.pv, run.pv_groups
    pv = run.config["pv"]
    system = SystemSpec(temperature_model=pv["temperature_model"], dc_loss=pv["dc_loss"])   # the runner's
    out = {}
    for name, ty in y.technologies.items():
        kwp = sum(ty.pdc0[g] for g in groups) / 1000.0
        h = ty.series[groups[0]].attrs["step_hours"]
        w = {st: sum(ty.waterfall[g][st] * ty.pdc0[g] for g in groups) / (1000.0 * kwp) for st in WATERFALL_STAGES}
        # AC without the clipping: pvsim's PVWatts inverter with the clip limit raised out of reach (its
        # efficiency depends on eta_inv_nom / eta_inv_ref only, kept), so the clipping is the difference to AC
        unclipped = 0.0
        for g in groups:
            if ty.pdc0[g] > 0:
                unclipped += float(np.sum(pvwatts_inverter(
                    ty.series[g]["dc"].to_numpy(), ty.pdc0[g] / system.dc_ac_ratio,
                    system.eta_inv_nom * 1e9, system.eta_inv_ref * 1e9)))
        w["inverter"] = unclipped * h / 1000.0 / kwp
        ac = sum(ty.series[g]["ac"].to_numpy() for g in groups)
        e_ac = sum(ty.energy(g, "ac") for g in groups)
        e_dc = sum(ty.energy(g, "dc") for g in groups)
        out[name] = {"label": ty.technology.label, "eta_stc": ty.eta_stc, "kwp": kwp, "e_dc": e_dc, "e_ac": e_ac,
                     "sy_dc": e_dc / kwp, "sy_ac": e_ac / kwp, "waterfall": w, "ac": ac, "step_hours": h}
    return out


def _pv_section(run: CaseRun, book: ChartBook, nums):
    """HTML of the PV yield: per technology the plant's rating, energy, specific yield and loss waterfall."""
    y = run.pv
    groups = run.pv_groups
    rows, monthly = [], {}
    months = interval_months(y.times, run.label, pd.Timedelta(hours=run.step_hours))    # by the interval's start
    month_names = sorted(set(months))
    for name, nm in nums.items():
        w = nm["waterfall"]
        monthly[nm["label"]] = [float(nm["ac"][months == m].sum() * nm["step_hours"] / 1000.0 / nm["kwp"])
                                for m in month_names]
        spectral = w["effective"] / w["cover"] - 1.0 if w["cover"] > 0 else 0.0
        rear = w["bifacial"] / w["effective"] - 1.0 if w["effective"] > 0 else 0.0
        rows.append([nm["label"], f"{100 * nm['eta_stc']:.1f}", f"{nm['kwp']:.2f}", f"{nm['e_dc'] / 1000:.2f}",
                     f"{nm['e_ac'] / 1000:.2f}", nm["sy_ac"], f"{nm['sy_dc']:.1f}", f"{100 * spectral:+.2f}",
                     f"{100 * rear:+.2f}"])
    order = sorted(range(len(rows)), key=lambda i: -rows[i][5])
    for rank, i in enumerate(order, 1):
        rows[i] = rows[i][:5] + [f"{rows[i][5]:.1f}", str(rank)] + rows[i][6:]
    table = _table(["technology", "STC efficiency [%]", "rating [kWp]", "DC [MWh]", "AC [MWh]",
                    "specific yield [kWh/kWp]", "rank", "DC specific yield [kWh/kWp]", "spectral gain [%]",
                    "rear gain [%]"], rows)
    stage_rows = []
    for i, st in enumerate(REPORT_STAGES_PV):
        cells = []
        for nm in nums.values():
            w = nm["waterfall"]
            prev = w[REPORT_STAGES_PV[i - 1]] if i else 0.0
            cells += [f"{w[st]:.1f}", f"{100 * (w[st] / prev - 1):+.1f}" if i and prev > 0 else ""]
        stage_rows.append([_STAGE_TEXT[st], *cells])
    waterfall = _table(["stage", *(h for nm in nums.values() for h in (f"{nm['label']} [kWh/kWp]", "step [%]"))],
                       stage_rows)
    month_label = ["Jan", "Feb", "Mar", "Apr", "May", "Jun", "Jul", "Aug", "Sep", "Oct", "Nov", "Dec"]
    chart = ""
    if len(month_names) > 1:
        chart = book.bars(
            "pv-monthly-specific-yield", [month_label[m - 1] for m in month_names], monthly,
            title="Monthly specific yield (AC) per technology", xlabel="month", ylabel="specific yield [kWh/kWp]",
            source={"file": "timeseries.csv",
                    "columns": {nm["label"]: f"plant:{n}:ac [W]" for n, nm in nums.items()},
                    "how": "sum over the steps of each month (by the interval's start) x step hours / 1000 / "
                           "rating [kWp]"},
            meta={"rating_kwp": {nm["label"]: nm["kwp"] for nm in nums.values()},
                  "step_hours": next(iter(nums.values()))["step_hours"], "months": [int(m) for m in month_names]})
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
<p class="note">Each stage's reference yield [kWh/kWp] (irradiation at STC-equivalent) and its change from the stage
above. The inverter's two losses are shown apart: its conversion efficiency (PVWatts curve), then the clipping at its
AC limit (DC/AC ratio {SystemSpec().dc_ac_ratio:g}).</p>
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


def _compare_section(runs, folder: Path, book: ChartBook):
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
            rows.append([_site_name(r), format_position(r.site.latitude, r.site.longitude),
                         *(f"{v:.1f} ({rank[n]})" for n, v in zip(names, sy)), labels[int(order[0])]])
        header = ["site", "position [deg]", *(f"{lab} [kWh/kWp] (rank)" for lab in labels), "best"]
        ylabel, cats = "specific yield [kWh/kWp]", labels
    else:
        labels = list(dict.fromkeys(runs[0].labels))
        for r in runs:
            kwh = r.result.poa_global.astype(float).sum(axis=0) * r.step_hours / 1000.0
            lab = np.asarray(r.labels, dtype=object)
            a = r.result.faces.area
            vals = [float((kwh[lab == g] * a[lab == g]).sum() / a[lab == g].sum()) for g in labels]
            table[_site_name(r)] = vals
            rows.append([_site_name(r), format_position(r.site.latitude, r.site.longitude),
                         *(f"{v:.1f}" for v in vals), labels[int(np.argmax(vals))]])
        header = ["site", "position [deg]", *(f"{g} [kWh m-2]" for g in labels), "highest"]
        ylabel, cats = "insolation [kWh m-2]", labels
    pd.DataFrame({k: v for k, v in table.items()}, index=cats).to_csv(folder / "sites.csv", float_format="%.5g")
    chart = book.bars("sites-compared", cats, table, title="The same case at each site", xlabel="",
                      ylabel=ylabel, legend_title="site",
                      source={"file": "sites.csv", "how": "one series per column (site), one bar per row"})
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

    # sky of the report hour: spectral EXR and PNG
    stage(2)
    hour_step = pd.Timedelta(hours=run.step_hours)
    st = interval_starts(res.times[run.hour_index:run.hour_index + 1], run.label, hour_step)[0]   # the hour's start
    sp_el, sp_az = run.hour_sun
    sky_r = render_sky(run.dataset.model, sun_elevation=sp_el, sun_azimuth=sp_az,
                       visibility=cfg["sky"]["visibility"], albedo=cfg["sky"]["albedo"], resolution=SKY_RESOLUTION)
    write_exr(folder / "sky.exr", sky_r)
    write_png(folder / "sky.png", sky_r)

    # scene renders coloured by insolation: front sides on one colour map and range, rear sides on another
    tri_front = np.full(len(sc.triangles), np.nan)
    tri_back = np.full(len(sc.triangles), np.nan)
    front = sc.face_side == 0
    tri_front[sc.face_triangle[front]] = kwh[front]
    tri_back[sc.face_triangle[~front]] = kwh[~front]
    two_sided = bool((~front).any())
    verts = sc.vertices + sc.origin
    up = front & (sc.face_normal[:, 2] > -0.99)                    # colour range of the front faces a view shows
    sel = up if up.any() else front
    vmin, vmax = float(np.min(kwh[sel])), float(np.max(kwh[sel]))
    bmin, bmax = (float(np.min(kwh[~front])), float(np.max(kwh[~front]))) if two_sided else (0.0, 1.0)
    renders = []
    stage(3)
    kw = dict(size=cfg["report"]["render_size"], label="insolation", unit="kWh m-2",
              back_values=tri_back if two_sided else None, back_vmin=bmin, back_vmax=bmax)
    for view in cfg["report"]["views"]:
        img = render_scene(verts, sc.triangles, tri_front, vmin=vmin, vmax=vmax, view=view,
                           cull=None if two_sided else np.isfinite(tri_front), **kw)
        name = f"scene_{view}.png"
        img.save(folder / name)
        renders.append(name)
    if two_sided:
        # the rear sides, seen from below and behind (the context, ground included, left out)
        nf = sc.face_normal[front] * area[front][:, None]
        mean_n = nf.sum(axis=0)
        az_rear = (float(np.degrees(np.arctan2(-mean_n[0], -mean_n[1])) % 360.0)
                   if np.hypot(mean_n[0], mean_n[1]) > 1e-6 * np.abs(mean_n).sum() else 0.0)
        img = render_scene(verts, sc.triangles, tri_front, vmin=vmin, vmax=vmax, view=(az_rear, -40.0),
                           context=False, **kw,
                           title=f"rear sides, seen from below looking {_compass((az_rear + 180.0) % 360.0)} "
                                 "(context not drawn)")
        img.save(folder / "scene_rear.png")
        renders.append("scene_rear.png")
    stage(4)
    write_ply(folder / "scene.ply", verts, sc.triangles, tri_front, vmin=vmin, vmax=vmax)
    write_glb(folder / "scene.glb", verts, sc.triangles, tri_front, vmin=vmin, vmax=vmax)
    stage(5)

    # --- the page -------------------------------------------------------------------------------------
    book = ChartBook()
    labels = list(dict.fromkeys(run.labels))
    lab_arr = np.asarray(run.labels, dtype=object)
    parts_total = {q: label_means(getattr(res, q), run.labels, area) for q in res.QUANTITIES}
    rows, insolation = [], {}
    for lab in labels:
        sel = lab_arr == lab
        a = area[sel].sum()
        e = float((kwh[sel] * area[sel]).sum() / a)
        insolation[lab] = e
        g = parts_total["poa_global"][lab].sum()
        share = [100 * parts_total[q][lab].sum() / g if g > 0 else 0.0 for q in res.QUANTITIES[1:]]
        rows.append([lab, int(sel.sum()), f"{a:.1f}", f"{e:.1f}", f"{e * a / 1000:.2f}",
                     f"{kwh[sel].min():.1f} - {kwh[sel].max():.1f}", f"{parts_total['poa_global'][lab].max():.0f}",
                     *(f"{s:.1f}" for s in share)])
    summary = _table(["group", "faces", "area [m2]", "insolation [kWh m-2]", "energy [MWh]", "face range [kWh m-2]",
                      "peak [W m-2]", "direct [%]", "sky diffuse [%]", "reflected [%]"], rows)
    nums = pv_numbers(run) if run.pv is not None else None
    pv_html = _pv_section(run, book, nums) if run.pv is not None else ""
    thermal_html = ""
    files = ["index.html", "charts.json", *series_files, "faces.csv", "poa.h5", "spectral_hour.h5", "provenance.json",
             "case.toml", "sky.exr", "sky.png", *renders, "scene.ply", "scene.glb"]
    if run.thermal is not None:
        thermal_html = thermal_section(run, folder, book)
        files.append("loads.csv")
    compare = _compare_section([run, *others], folder, book) if others else ""
    if others:
        files.append("sites.csv")
    # a step's month and day are its interval's start's (an EPW hour ending 1 Feb 00:00 is January's)
    begins = interval_starts(res.times, run.label, pd.Timedelta(hours=run.step_hours))
    months = np.asarray(begins.month)
    month_names = sorted(set(months))
    glob_cols = {lab: f"{lab}:poa_global [W m-2]" for lab in labels}
    monthly = {lab: [float(parts_total["poa_global"][lab][months == m].sum() * run.step_hours / 1000) for m in month_names]
               for lab in labels}
    day = begins.tz_localize(None).normalize()                       # local calendar days
    days = pd.Index(sorted(set(day)))
    daily = {lab: pd.Series(parts_total["poa_global"][lab] * run.step_hours / 1000, index=day).groupby(level=0).sum()
             .reindex(days).to_numpy() for lab in labels}
    month_label = ["Jan", "Feb", "Mar", "Apr", "May", "Jun", "Jul", "Aug", "Sep", "Oct", "Nov", "Dec"]
    charts = []
    if len(month_names) > 1:
        charts.append(book.bars(
            "monthly-insolation", [month_label[m - 1] for m in month_names], monthly,
            title="Monthly insolation per group", xlabel="month", ylabel="insolation [kWh m-2]",
            source={"file": "timeseries.csv", "columns": glob_cols,
                    "how": "sum over the steps of each month (local time, by the interval's start) x step hours "
                           "/ 1000"},
            meta={"step_hours": run.step_hours, "months": [int(m) for m in month_names]}))
    charts.append(book.line(
        "daily-insolation", days.to_numpy(dtype="datetime64[ns]"), daily, title="Daily insolation per group",
        xlabel="date" if len(days) > 62 else "day (local time)", ylabel="insolation [kWh m-2 day-1]", dates=True,
        source={"file": "timeseries.csv", "columns": glob_cols,
                "how": "sum over the steps of each local day (by the interval's start) x step hours / 1000"},
        meta={"step_hours": run.step_hours}))
    band_means = {b: label_means(res.get(b, "global"), run.labels, area) for b in BANDS}
    band_frac = {lab: [100 * float(band_means[b][lab].sum()) / max(parts_total["poa_global"][lab].sum(), 1e-30)
                       for b in BANDS] for lab in labels}
    charts.append(book.bars(
        "spectral-split", list(BANDS), band_frac, title="Spectral split of the period's irradiance per group",
        xlabel="band", ylabel="share of 280-2480 nm [%]",
        source={"file": "timeseries.csv",
                "columns": {lab: {b: f"{lab}:{b} [W m-2]" for b in BANDS} for lab in labels},
                "global": glob_cols, "how": "100 x the band's sum over the period / the global sum"}))
    spec = label_means(hour_spectrum(run.hour).T, run.labels, area)                  # label -> (C,)
    hour_text = f"{interval_text(st, 'left', hour_step, '%Y-%m-%d %H:%M')} ({utc_offset_text(st)})"
    charts.append(book.line(
        "hour-spectrum", np.asarray(res.wavelengths, float), spec,
        title=f"Global spectral irradiance per group, {hour_text}", legend_title=f"{st:%d %b %Y %H:%M}",
        xlabel="wavelength [nm]", ylabel="irradiance [W m-2 nm-1]",
        source={"file": "spectral_hour.h5", "array": "spectral global", "step": 0,
                "how": "area-weighted mean over each group's faces (faces.csv labels, poa.h5 face order)"}))
    book.write(folder / "charts.json")
    sky_html = _sky_figure(folder / "sky.png", sp_el, sp_az)
    s = _settings_text(run)
    parquet_note = "" if "timeseries.parquet" in series_files else (
        "<p class='note'>timeseries.parquet was not written: no Parquet engine is installed "
        "(<code>pip install pyarrow</code>).</p>")
    tm = run.timings
    site_name = run.site.name or cfg['site']['name'] or 'site'
    weather = cfg["sky"]["weather"]
    two_sided_note = "; front and rear sides each on their own colour scale" if two_sided else ""
    sky_note = " (the weather file scales it to its measured DNI and DHI)" if weather else ""
    html = f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{escape(cfg['case']['title'])}</title>
<style>{_CSS}</style></head><body>
<h1>{escape(cfg['case']['title'])}</h1>
{_glance(run, nums, insolation, others)}
<p>{escape(cfg['case']['description'])}</p>
<h2>Run</h2>
{_kv_table([
    ["site", f"{site_name} {format_position(run.site.latitude, run.site.longitude)}, "
             f"{run.site.altitude:g} m, {cfg['site']['tz'] if not weather else run.site.tz}"
             + (" (the weather file's)" if weather else "")],
    ["period", f"{cfg['period']['start']} to {cfg['period']['end']} (exclusive), "
               + (f"step {cfg['period']['step']}, " if not weather else "the weather file's steps, ")
               + f"{len(res.times)} steps (times label the interval "
               + ("start" if not weather else "end, as the file does") + "; the sun at mid-interval)"],
    ["sky", f"{run.weather}, visibility {cfg['sky']['visibility']:g} km, albedo {cfg['sky']['albedo']:g}"
            + (" (where the file gives none)" if weather else "")
            + f", dataset {Path(str(run.dataset.model.path)).name}"],
    ["scene", f"{_plural(sc.n_faces, 'analysed face')} in {_plural(len(labels), 'group')}, "
              f"{_plural(len(sc.triangles), 'triangle')} in all"],
    ["run time", f"{tm.get('compute_total', 0):.1f} s" + (f" for {1 + len(others)} sites; this site:" if others else "")
                 + f" (integrator {tm.get('integrator', 0):.1f} s, spectral hour "
                 f"{tm.get('spectral_hour', 0):.1f} s" + (f", PV yield {tm['pv_yield']:.1f} s" if "pv_yield" in tm else "")
                 + (f", loads {tm['thermal']:.1f} s" if "thermal" in tm else "")
                 + ")"],
])}
{compare}
{pv_html}
{thermal_html}
<h2>Irradiance per group</h2>
{summary}
<p class="note">Insolation: the period's sum of plane-of-array global irradiance (280-2480 nm) per m2,
area-weighted over the group's faces; shares of direct (sun and circumsolar), sky-diffuse and reflected
(ground and scene surfaces) light. The whole solar spectrum's (a weather file's and a pyranometer's measure, the
PV waterfall's stages) is this divided by 0.99248, the AM1.5G share of 280-2480 nm (docs/pvsim.md).</p>
{''.join(charts[:-2])}
<h2>Spectra</h2>
{charts[-2]}
{charts[-1]}
<p class="note">The spectrum of the hour {hour_text} (local time, the step holding <code>report.sky_time</code>;
sun elevation {sp_el:.1f} deg, azimuth
{sp_az:.1f} deg at mid-interval), from <code>spectral_hour.h5</code>: direct, sky-diffuse and ground-diffuse parts and
their sum per face.</p>
<h2>Maps</h2>
<div class="renders">{''.join(_img_tag(folder / r, r) for r in renders)}</div>
<p class="note">Insolation over the period [kWh m-2]{two_sided_note}.
The coloured mesh (front sides) is in <code>scene.glb</code> (binary glTF: browsers' and most 3D viewers) and
<code>scene.ply</code>; grey: context geometry.</p>
<h2>Sky at {hour_text}</h2>
{sky_html}
<p class="note">The dataset's clear sky of that hour{sky_note}:
up-facing fisheye, north at the top and east on the left (as seen looking up), sun elevation {sp_el:.1f} deg,
azimuth {sp_az:.1f} deg; all 55 channels in <code>sky.exr</code> (spectral OpenEXR layout), the plain picture in
<code>sky.png</code>.</p>
<h2>Accuracy and limits</h2>
{s}
<h2>Files</h2>
<ul>{''.join(f'<li><a href="{f}">{f}</a></li>' for f in files)}</ul>
{parquet_note}
<p class="note">widesky {escape(str(provenance['versions'].get('widesky')))}; provenance (versions, dataset
SHA-1, settings, timings) in <code>provenance.json</code>; every chart's numbers and their source file in
<code>charts.json</code>.</p>
</body></html>
"""
    (folder / "index.html").write_text(html, encoding="utf-8")
    bar.update(1)
    bar.close()


def _compass(az):
    """The 8-point compass name of an azimuth [deg, clockwise from north]."""
    return ("north", "north-east", "east", "south-east", "south", "south-west", "west", "north-west")[
        int(((az + 22.5) % 360.0) // 45.0)]


SKY_RESOLUTION = 512
"""Pixels across the report's sky picture (and ``sky.exr``)."""


def _sky_figure(png, sun_el, sun_az):
    """HTML ``<img>`` (PNG data URI) of the fisheye ``png`` with compass marks (N, E, S, W every 90 deg, ticks every
    30 deg) and the sun's position in words."""
    import io

    import matplotlib as mpl
    from matplotlib.figure import Figure
    from matplotlib.patches import Circle
    from PIL import Image

    img = np.asarray(Image.open(png).convert("RGB")).copy()
    n = img.shape[0]
    yy, xx = np.mgrid[0:n, 0:n]
    img[np.hypot(xx + 0.5 - n / 2, yy + 0.5 - n / 2) > n / 2] = 255            # white outside the disc
    with mpl.rc_context({"font.size": 12}):
        fig = Figure(figsize=(6.2, 6.4), dpi=100)
        ax = fig.add_axes((0.04, 0.07, 0.92, 0.89))
        ax.imshow(img, extent=(-1, 1, -1, 1), interpolation="lanczos")
        ax.set_xlim(-1.14, 1.14)
        ax.set_ylim(-1.14, 1.14)
        ax.set_aspect("equal")
        ax.set_axis_off()
        # looking up with north at the top: east on the left (azimuth clockwise from north runs anticlockwise here)
        for az in range(0, 360, 30):
            a = np.radians(az)
            x, y = -np.sin(a), np.cos(a)
            major = az % 90 == 0
            ax.plot([(0.95 if major else 0.975) * x, 1.02 * x], [(0.95 if major else 0.975) * y, 1.02 * y],
                    color="#333" if major else "#777", lw=1.6 if major else 1.0)
            if major:
                ax.text(1.09 * x, 1.09 * y, "NESW"[az // 90], ha="center", va="center", fontsize=15,
                        fontweight="bold")
        ax.add_patch(Circle((0, 0), 1.0, fill=False, color="#777", lw=1.0))
        fig.text(0.02, 0.015, f"sun: elevation {sun_el:.1f} deg, azimuth {sun_az:.1f} deg; {n} px fisheye, "
                 "horizon at the circle", fontsize=10, color="#444")
        buf = io.BytesIO()
        fig.savefig(buf, format="png")
    data = base64.b64encode(buf.getvalue()).decode()
    return f'<img class="sky" src="data:image/png;base64,{data}" alt="sky fisheye with compass marks" width="620">'


def _what_it_is(run: CaseRun) -> str:
    """One sentence: what the figures are and are not (the sky and weather they stand on)."""
    if run.config["sky"]["weather"] is None:
        return ("A clear-sky period: every hour cloudless, so the energies are an upper bound, not an expected "
                "yield (give the case a weather file for that).")
    return ("Measured weather: the file's hourly DNI and DHI, so the figures stand for that file's hours; a typical "
            "(TMY) year is a statistically typical year assembled from months of several years, not a forecast or "
            "any particular year, which can differ from it by several per cent.")


def _glance(run: CaseRun, nums, insolation, others) -> str:
    """The report's first screen: site, weather source, sky model, period and the headline results (energy and
    specific yield per technology, the building's loads, or insolation per group), and what they are not."""
    cfg = run.config
    weather = cfg["sky"]["weather"]
    site_name = run.site.name or cfg["site"]["name"] or "site"
    src = (f"weather file <code>{escape(Path(str(weather)).name)}</code>" if weather is not None
           else "none: the dataset's clear-sky model (no weather file)")
    if weather is None:
        sky = "clear sky (Prague Sky Model), every hour cloudless"
    elif "all-sky" in run.weather:
        sky = "all-sky: measured DNI and DHI with the all-sky model's spectra and angular shape"
    else:
        sky = "measured DNI and DHI with the clear sky's spectral and angular shape"
    p = cfg["period"]
    period = (f"{p['start']:%Y-%m-%d} to {p['end']:%Y-%m-%d} (exclusive), {len(run.result.times)} steps of "
              f"{run.step_hours * 60:g} min")
    rows = [["site", f"{escape(site_name)}, {format_position(run.site.latitude, run.site.longitude)}, "
                     f"{run.site.altitude:g} m" + (f" (and {_plural(len(others), 'more site')}: Sites compared)"
                                                   if others else "")],
            ["weather source", src], ["sky model", escape(sky)], ["period", period]]
    if nums:
        best = max(nums.values(), key=lambda nm: nm["sy_ac"])
        rows.append(["PV energy (AC)", "<br>".join(
            f"{escape(nm['label'])}: <b>{nm['e_ac'] / 1000:.2f} MWh</b>, "
            f"<b>{nm['sy_ac']:.{0 if nm['sy_ac'] >= 100 else 1}f} kWh/kWp</b> "
            f"({nm['kwp']:.1f} kWp{', highest' if nm is best and len(nums) > 1 else ''})" for nm in nums.values())])
    if run.thermal is not None:
        from .report_thermal import thermal_summary
        fa = run.thermal.floor_area
        summ = thermal_summary(run.thermal, run.step_hours)
        rows.append(["building loads", "<br>".join(
            f"{escape(name)} glazing: cooling <b>{sm['cooling_kwh'] / 1000:.2f} MWh</b> "
            f"({sm['cooling_kwh'] / fa:.1f} kWh m-2 of floor), peak {sm['peak_cooling_w'] / 1000:.1f} kW; "
            f"heating {sm['heating_kwh'] / 1000:.2f} MWh" for name, sm in summ.items())
            + f"<br><span class='note'>{fa:.0f} m2 of floor</span>"])
    if not nums and run.thermal is None:
        order = sorted(insolation, key=insolation.get, reverse=True)
        shown = order if len(order) <= 6 else order[:3] + order[-2:]
        rows.append(["insolation", ", ".join(f"{escape(g)} <b>{insolation[g]:.0f}</b>" for g in shown)
                     + " kWh m-2" + ("" if len(order) <= 6 else
                                     f" (the highest three and lowest two of {len(order)} groups)")])
    rows.append(["what it is not", f"<span class='caveat'>{_what_it_is(run)}</span>"])
    body = "".join(f"<tr><td>{a}</td><td>{b}</td></tr>" for a, b in rows)
    return f'<div class="glance"><h2>At a glance</h2><table><tbody>{body}</tbody></table></div>'


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
