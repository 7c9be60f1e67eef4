"""Run a case end to end: configuration -> geometry -> sky states -> per-face irradiance -> report folder.

The report folder is written into a temporary folder beside its destination and renamed into place
only when complete, so an interrupted or failed run leaves no half-written report (and an earlier
report stays as it was until the new one replaces it).
"""

from __future__ import annotations

import hashlib
import importlib.util
import json
import os
import shutil
import sys
import tempfile
import time
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

import numpy as np
import pandas as pd

import widesky.irradiance as ir
from widesky import pvsim
from widesky.core.atomic import interrupts_deferred, plain_mode, raise_if_interrupted
from widesky.irradiance import Response
from widesky.irradiance.simulation import weather_path
from widesky.irradiance.skystate import interval_starts
from widesky.thermal import sky_temperature

from .building_loads import (building_thermal, design_day_temperature, glazing_responses, prepare_building,
                             surface_display_labels)
from .config import ConfigError, load_config
from .glazing import glazing_units, unit_summary
from .report import write_report
from .run_result import BANDS, CaseRun, dump_json

__all__ = ["BANDS", "CaseRun", "run_case", "build_geometry", "band_responses", "face_labels"]


def build_geometry(path: Path, parameters: dict):
    """The meshes of a case: ``{"analysis": {name: mesh}, "context": {name: mesh}}``, optionally with
    ``"building"``: a :class:`widesky.thermal.Building` whose non-shading surfaces are analysed too (one group per
    surface label; its shading surfaces are context).

    ``path`` is a Python file defining ``build(parameters) -> dict`` as above (meshes as trimesh meshes
    or (vertices, faces) pairs, metres east-north-up), or a mesh file analysed as one group.
    """
    path = Path(path)
    if path.suffix != ".py":
        return {"analysis": {path.stem: str(path)}, "context": {}}
    if not path.is_file():
        raise ConfigError(f"scene.geometry: {str(path)!r} not found")
    spec = importlib.util.spec_from_file_location(f"widesky_case_geometry_{path.parent.name}", path)
    module = importlib.util.module_from_spec(spec)
    try:
        spec.loader.exec_module(module)
    except SyntaxError as exc:
        raise ConfigError(f"{exc.filename or path}:{exc.lineno}: the geometry script has a syntax error: "
                          f"{exc.msg}" + (f" in {exc.text.strip()!r}" if exc.text else "")) from None
    except Exception as exc:  # noqa: BLE001 - any error of the user's script, with its line
        raise ConfigError(f"{_script_line(exc, path)}: the geometry script failed while loading: "
                          f"{type(exc).__name__}: {exc}") from None
    if not hasattr(module, "build"):
        raise ConfigError(f"{path}: defines no build(parameters) function")
    try:
        geo = module.build(dict(parameters))
    except (KeyboardInterrupt, MemoryError):
        raise
    except Exception as exc:  # noqa: BLE001 - the user's script: one line naming it and the failing line
        raise ConfigError(f"{_script_line(exc, path)}: build(parameters) of the geometry script failed: "
                          f"{type(exc).__name__}: {exc}") from None
    if not isinstance(geo, dict) or not isinstance(geo.setdefault("analysis", {}), dict) or not (
            geo["analysis"] or geo.get("building") is not None):
        raise ConfigError(f"{path}: build() must return {{'analysis': {{name: mesh}}, 'context': {{...}}}} "
                          "(and optionally 'building': a thermal.Building)")
    geo.setdefault("context", {})
    building = geo.get("building")
    if building is not None:
        meshes, labels, shade = building.analysis_meshes()
        clash = set(labels) & set(geo["analysis"])
        if clash:
            raise ConfigError(f"{path}: analysis group {sorted(clash)[0]!r} is also a building surface label")
        geo["analysis"] = {**dict(zip(labels, meshes)), **geo["analysis"]}
        if shade is not None:
            geo["context"] = {**geo["context"], "building shading": shade}
    return geo


def _script_line(exc, path):
    """``path:line`` of the innermost frame of ``exc``'s traceback inside the script ``path`` (else ``path``)."""
    import traceback
    where = str(path)
    for frame in traceback.extract_tb(exc.__traceback__):
        if Path(frame.filename).resolve() == Path(path).resolve():
            where = f"{path}:{frame.lineno}"
    return where


def band_responses():
    """:data:`BANDS` as unit-weight responses (no optics): 1 inside the band, 0 outside [1]."""
    return [Response(name, [a, b], [1.0, 1.0], unit="weight") for name, (a, b) in BANDS.items()]


def face_labels(scene, rename=None):
    """Group label of every analysed face side: the mesh name (or ``rename[name]``), with " front"/" back"
    when two-sided."""
    rename = rename or {}
    names = np.array([rename.get(n, n) for n in scene.group_names], dtype=object)[scene.face_group]
    if np.any(scene.face_side == 1):
        sides = np.where(scene.face_side == 1, " back", " front")
        return [f"{n}{s}" for n, s in zip(names, sides)]
    return list(names)


def _site(cfg):

    s = cfg["site"]
    tz = s["tz"]
    try:
        tz = float(tz)
    except ValueError:
        pass
    try:
        site = ir.Site(s["latitude"], s["longitude"], s["altitude"], tz=tz, name=s["name"])
    except ValueError as exc:
        raise ConfigError(f"[site]: {exc}") from None
    return site


def _sha1(path, limit=1 << 26):
    h = hashlib.sha1()
    with open(path, "rb") as f:
        while chunk := f.read(1 << 20):
            h.update(chunk)
            limit -= len(chunk)
            if limit <= 0:
                return h.hexdigest() + " (first 64 MiB)"
    return h.hexdigest()


def sky_options(cfg):
    """The case's [sky] table as :class:`widesky.irradiance.SkyOptions` (its defaults are SKY_DEFAULTS)."""

    sk = cfg["sky"]
    return ir.SKY_DEFAULTS.replace(spectral_model=sk["spectral_model"], aerosol=sk["aerosol"],
                                   visibility=sk["visibility"], albedo=sk["albedo"],
                                   ground_spectrum=sk["ground_spectrum"], use_measured=sk["use_measured"],
                                   dataset=sk["dataset"] or None)


def simulation(cfg, scene, settings, n_jobs=None, progress=False, sky_source=None):
    """The case's :class:`widesky.irradiance.Simulation`: the clear-sky period of [site], or the weather file's
    steps inside [period] (its records moved to period.start's year)."""

    p, sk = cfg["period"], cfg["sky"]
    kw = dict(sky=sky_options(cfg), settings=settings, n_jobs=n_jobs, progress=progress, sky_source=sky_source)
    if sk["weather"] is None:
        return ir.Simulation(scene, site=_site(cfg), start=str(p["start"]), end=str(p["end"]), step=p["step"],
                             **kw)
    path = sk["weather"]
    try:
        years = sorted(set(ir.read_weather(weather_path(path)).data.index.year))
        sim = ir.Simulation(scene, weather=path, start=str(p["start"]), end=str(p["end"]),
                            coerce_year=p["start"].year, **kw)
    except ValueError as exc:            # WeatherFileError is a ValueError; so is an empty period
        raise ConfigError(f"sky.weather = {str(path)!r}: {exc}") from None
    if len(years) == 1 and years[0] != p["start"].year:
        # one measured year (a typical year mixes years, and moving it is what it is for): say that it moves
        sim.warnings.append(f"sky.weather = {str(path)!r}: its records are of {years[0]}, one measured year, and "
                            f"the period is in {p['start'].year}: they are moved to {p['start'].year} (weekdays "
                            f"and 29 February do not carry over); set period.start/end in {years[0]} to run the "
                            "year as measured")
    return sim


def report_hour(times, label, step, sky_time):
    """Index of the step whose interval [start, start + step) holds ``sky_time`` (tz-aware), by the interval's start
    whatever the label (:func:`widesky.irradiance.skystate.interval_starts`): an EPW or TMY3 hour labelled 10:00 is
    09:00-10:00, so ``report.sky_time`` 09:00 (or 09:30) picks it; None when no step holds it."""
    begins = interval_starts(times, label, step)
    hi = int(np.searchsorted(begins, sky_time, side="right")) - 1
    if hi < 0 or hi >= len(times) or not begins[hi] <= sky_time < begins[hi] + pd.Timedelta(step):
        return None
    return hi


def compute(folder, *, n_jobs=None, progress=True, cfg=None) -> CaseRun:
    """Validate the case in ``folder`` and compute its irradiance, yield and loads (no files written); ``cfg``:
    an already validated configuration (default: read ``folder/case.toml``)."""

    folder = Path(folder).resolve()
    cfg = load_config(folder) if cfg is None else cfg
    t0 = time.perf_counter()
    timings = {}
    sky = ir.PragueSky(cfg["sky"]["dataset"])
    settings = ir.IntegratorSettings.for_tolerance(cfg["accuracy"]["tolerance"])
    sim = simulation(cfg, None, settings, n_jobs=n_jobs, progress=progress, sky_source=sky)
    for w in sim.warnings:
        print(f"widesky: warning: {w}", file=sys.stderr)
    states, site, how = sim.states, sim.input.site, sim.description
    times = states.times
    label = sim.input.label
    step = times[1] - times[0] if len(times) > 1 else pd.Timedelta(cfg["period"]["step"])
    hi = report_hour(times, label, step, site.localize([cfg["report"]["sky_time"]])[0])
    if hi is None:
        raise ConfigError(f"report.sky_time = {cfg['report']['sky_time']} is not inside the period "
                          f"{cfg['period']['start']} .. {cfg['period']['end']}")
    if states.sun_elevation[hi] <= sky.min_sun_elevation:
        raise ConfigError(f"report.sky_time = {cfg['report']['sky_time']}: the sun is below the horizon "
                          f"(elevation {states.sun_elevation[hi]:.1f} deg); choose a daylight hour")
    geo = build_geometry(cfg["scene"]["geometry"], cfg["scene"]["parameters"])
    tcfg = cfg.get("thermal")
    building = geo.get("building")
    if tcfg is not None and building is None:
        raise ConfigError(f"[thermal]: the geometry {cfg['scene']['geometry'].name} returns no 'building' "
                          "(a thermal.Building) to compute loads for")
    context = list(geo["context"].values())
    scene = ir.make_scene(list(geo["analysis"].values()), context, groups=list(geo["analysis"]),
                          samples_per_face=cfg["scene"]["samples_per_face"], two_sided=cfg["scene"]["two_sided"],
                          context_reflectance=cfg["scene"]["reflectance"] if context else 0.2)
    sim.scene = scene
    timings["setup"] = time.perf_counter() - t0
    responses = band_responses()
    pv = cfg.get("pv")
    pv_groups = ()
    if pv is not None:
        pv_resp, pv_sources = pvsim.technology_responses(pv["technologies"])
        responses = pv_resp + responses
        pv_groups = tuple(pv["groups"]) or tuple(g for g in geo["analysis"]
                                                 if building is None or g not in _surface_labels(building))
        bad = [g for g in pv_groups if g not in geo["analysis"]]
        if bad:
            raise ConfigError(f"pv.groups: {bad[0]!r} is not an analysis group; groups: {', '.join(geo['analysis'])}")
    units = rated = None
    if tcfg is not None:
        try:
            units = glazing_units(tcfg["glazing"])
        except FileNotFoundError as exc:
            raise ConfigError(f"thermal.glazing: {exc}") from None
        building = prepare_building(building, tcfg)
        am15 = pvsim.widesky_am15g(sky)
        rated = {n: unit_summary(u, am15["channel_edges"], am15["scaled"]) for n, u in units.items()}
        responses = responses + glazing_responses(units, am15)
    t1 = time.perf_counter()
    res = sim.run(responses)
    timings["integrator"] = time.perf_counter() - t1
    T = len(times)
    step_h = (times[1] - times[0]).total_seconds() / 3600.0 if len(times) > 1 else 1.0
    pv_result = None
    if pv is not None:
        t3 = time.perf_counter()
        reference = pvsim.widesky_am15g(sky)["scaled"] if pv["reference"] == "widesky" else None
        system = pvsim.SystemSpec(temperature_model=pv["temperature_model"], dc_loss=pv["dc_loss"])
        pv_result = pvsim.pv_yield(res, pv["technologies"], sim.weather_series("temp_air", pv["temp_air"]),
                                   np.maximum(sim.weather_series("wind_speed", pv["wind_speed"]), 0.0),
                                   sources=pv_sources, system=system, reference=reference, progress=progress)
        timings["pv_yield"] = time.perf_counter() - t3
    thermal_run = None
    if tcfg is not None:
        t4 = time.perf_counter()
        design = design_day_temperature(times, step_h, tcfg["temp_air"], tcfg["temp_air_range"])
        temp_sky = None
        rows = sim.input.weather
        if rows is not None and "ghi_infrared" in rows and np.isfinite(rows["ghi_infrared"].to_numpy(float)).all():
            temp_sky = sky_temperature(np.maximum(rows["ghi_infrared"].to_numpy(float), 1.0))
        thermal_run = building_thermal(res, building, tcfg, units, rated, sim.weather_series("temp_air", design),
                                       temp_sky, label=label)
        timings["thermal"] = time.perf_counter() - t4
    t2 = time.perf_counter()
    hour = sim.run(steps=slice(hi, hi + 1), spectral=True, progress=False)
    timings["spectral_hour"] = time.perf_counter() - t2
    rename = None
    if building is not None:
        rename = surface_display_labels(building)
    return CaseRun(folder, cfg, scene, res, hour, hi,
                   (float(states.sun_elevation[hi]), float(states.sun_azimuth[hi])),
                   face_labels(scene, rename), step_h, sky, settings, timings, pv_result, pv_groups, thermal_run,
                   how, site, label)


def _surface_labels(building):
    return {s.label for s in building.surfaces if s.kind != "shading"}


REPORT_MARKER = ".widesky-report"
"""File in every report folder widesky writes: only a folder holding it (or nothing) is ever replaced."""


def is_report_folder(path) -> bool:
    """True for a report folder widesky wrote: it holds :data:`REPORT_MARKER`, or (reports written before the
    marker) a ``provenance.json`` naming a case and its dataset's SHA-1 beside an ``index.html``."""
    path = Path(path)
    if (path / REPORT_MARKER).is_file():
        return True
    prov = path / "provenance.json"
    if not (prov.is_file() and (path / "index.html").is_file()):
        return False
    try:
        data = json.loads(prov.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return False
    return isinstance(data, dict) and {"case", "dataset_sha1", "versions"} <= set(data)


def _atomic_folder(dest: Path, fill):
    """Call ``fill(tmp)`` on a fresh temporary folder beside ``dest`` and mark it a report; then put it in place of
    ``dest`` (absent, empty, or an earlier report: :func:`_check_output`), removing only that earlier report."""
    dest = Path(dest).resolve()
    dest.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(dir=dest.parent, prefix=f".{dest.name}.tmp-"))
    plain_mode(tmp, folder=True)
    try:
        fill(tmp)
        dump_json(tmp / REPORT_MARKER, {"written_by": "widesky run", "folder": dest.name})
        _check_output(dest)                       # again: the folder may have changed during the computation
        raise_if_interrupted()                    # a Ctrl-C that a library swallowed: put nothing in place
        old = None
        try:
            with interrupts_deferred():           # both renames or neither: never the earlier report moved away alone
                raise_if_interrupted()
                if dest.exists():
                    old = dest.with_name(f".{dest.name}.old-{os.getpid()}")
                    os.rename(dest, old)
                os.rename(tmp, dest)
        finally:
            if old is not None and not tmp.exists():   # the new report is in place (a Ctrl-C raised after it too)
                shutil.rmtree(old, ignore_errors=True)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return dest


def run_case(folder, output=None, *, n_jobs=None, progress=None, log=None) -> Path:
    """Run the case in ``folder`` and write its report folder (default ``./report-<case name>``).

    Returns the report folder. Raises :class:`widesky.cases.config.ConfigError` (a ``ValueError``) for an
    invalid configuration, naming the key and its valid values.
    """

    folder = Path(folder)
    if progress is None:
        progress = sys.stderr.isatty()
    log = log or (lambda msg: print(msg, file=sys.stderr))
    out = Path(output) if output else Path.cwd() / f"report-{folder.resolve().name}"
    _check_output(out)                            # before the computation, not after it
    t0 = time.perf_counter()
    run = compute(folder, n_jobs=n_jobs, progress=progress)
    others = []
    for site in (run.config.get("compare") or {}).get("sites", []):
        log(f"{folder.name}: the same case at {site['name'] or (site['latitude'], site['longitude'])} ...")
        site = dict(site)
        sky = {**run.config["sky"], "weather": site.pop("weather")}
        others.append(compute(folder, n_jobs=n_jobs, progress=progress, cfg={**run.config, "site": site, "sky": sky}))
    run.timings["compute_total"] = time.perf_counter() - t0
    log(f"{folder.name}: computed in {run.timings['compute_total']:.1f} s; writing the report (time series, "
        "integrator result, renders, HTML) ...")
    provenance = {
        "case": str(folder.resolve()), "command": " ".join(sys.argv),
        "dataset": str(run.dataset.model.path), "dataset_sha1": _sha1(run.dataset.model.path),
        "settings": {k: getattr(run.settings, k) for k in run.settings.__dataclass_fields__},
        "versions": _versions(), "timings_s": run.timings,
        "faces": int(run.scene.n_faces), "steps": int(len(run.result.times)),
    }
    report = _atomic_folder(out, lambda tmp: write_report(run, tmp, provenance, others, progress=progress))
    log(f"{folder.name}: {run.scene.n_faces} faces x {len(run.result.times)} steps in "
        f"{time.perf_counter() - t0:.1f} s -> {report}/index.html")
    return report


def _check_output(out: Path):
    """Refuse, up front, a report folder that cannot be written (a file in the way, an unwritable parent) or whose
    replacement would delete what widesky did not write: a non-empty folder that is not an earlier report, the
    current directory or a folder above it."""
    out = Path(out).resolve()
    if out.exists() and not out.is_dir():
        raise ValueError(f"--output {str(out)!r} is a file, not a report folder")
    cwd = Path.cwd().resolve()
    if out == cwd or out in cwd.parents:
        raise ValueError(f"--output {str(out)!r} is the current directory or holds it: the report replaces its "
                         "folder, so give a new or report folder inside it (e.g. -o report)")
    if out.is_dir() and any(out.iterdir()) and not is_report_folder(out):
        raise ValueError(f"--output {str(out)!r} is not empty and holds no widesky report (no {REPORT_MARKER} "
                         "file): a report replaces its whole folder, and widesky never deletes files it did not "
                         "write; choose a new folder")
    # the report's parent folders are created only when the report is written (a failed run leaves none behind):
    # here the nearest folder that exists must take a new entry
    base = out.parent
    while not base.exists():
        base = base.parent
    if not base.is_dir():
        raise ValueError(f"--output {str(out)!r}: cannot write a report folder there ({str(base)!r} is a file)")
    try:
        probe = Path(tempfile.mkdtemp(dir=base, prefix=f".{out.name}.probe-"))
        probe.rmdir()
    except OSError as e:
        raise ValueError(f"--output {str(out)!r}: cannot write a report folder there ({e.strerror})") from None


def _versions():
    out = {"python": sys.version.split()[0]}
    for pkg in ("widesky", "numpy", "pandas", "trimesh", "embreex"):
        try:
            out[pkg] = version(pkg)
        except PackageNotFoundError:
            out[pkg] = None
    return out
