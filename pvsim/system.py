"""The system layer: one integrator run for many technologies, then yield per module group.

``technology_responses`` turns technologies into the integrator's ``Response`` list (each sub-cell's
EQE with the cover's angular optic, deduplicated where one sub-cell is a scalar multiple of another,
plus one ``"cover"`` unit weight with the same optic for the angle-loss bookkeeping).
``pv_yield`` reads a ``POAResult`` (in memory or streamed to HDF5) face chunk by face chunk and gives
per technology and module group the time series with pvlib's column names, energies, kWh/kWp and a
loss waterfall. :func:`widesky.pvsim.stream.simulate` does both around ``widesky.irradiance.poa_irradiance``.

Loss waterfall (per group, as reference yields [kWh/kWp] = irradiation at STC-equivalent [kWh m-2]):

    unshaded POA  -> shading (beam blocked by the scene)
    POA           -> angle (cover optics; the "cover" response)
    cover         -> spectral (cell EQE under the actual vs the AM1.5G spectrum; for a 2T tandem it
                     includes the current mismatch)
    effective     -> + bifacial rear gain
    total         -> low irradiance -> temperature -> DC losses -> inverter (AC)

Broadband stages are the whole solar spectrum: the integrator's irradiance over the sky's channels
(280-2480 nm for the PSM) divided by :func:`widesky.core.spectral.in_band_share` (992.48 / 1000 for 280-2480 nm,
the AM1.5G irradiance over the channels per 1000 W m-2), widesky's one convention between band-limited spectra
and broadband values (docs/pvsim.md, "Weather files and the 280-2480 nm band"): an AM1.5G spectrum has no
spectral loss, and under a weather file, whose DNI and DHI the sky carries times the same share, the
plane-of-array stage is the measured irradiance transposed. The series' ``poa_*`` columns and the cell
temperature's irradiance are broadband the same way. The
unshaded beam uses each step's direct normal irradiance recovered from the faces that see the sun
(``direct / (sun_visible cos aoi)``, exact for planar faces); steps where no face sees the sun add
no shading loss.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from tqdm import tqdm

from widesky.core.spectral import in_band_share
from widesky.irradiance import Response, SpectralAngularTable

from .module import (G_STC, current_mismatch_loss, effective_irradiance, low_irradiance_factor, pvwatts_inverter,
                     reference_currents, tandem_stc_efficiency, temperature_factor)
from .optics import cover_iam, rubin_soda_lime_index, spectral_cover_iam
from .spectra import am15g_channels, channel_edges
from .technologies import TECHNOLOGIES, TandemTechnology, get_technology
from .temperature import faiman, pvsyst_cell

__all__ = ["CoverOptics", "SystemSpec", "technology_parts", "technology_responses", "pv_yield", "YieldResult",
           "TechnologyYield", "COVER_RESPONSE", "WATERFALL_STAGES"]

COVER_RESPONSE = "cover"
_FINE = np.arange(280.0, 2480.5, 1.0)
WATERFALL_STAGES = ("unshaded", "poa", "cover", "effective", "bifacial", "low_irradiance", "temperature",
                    "dc", "ac")


@dataclass(frozen=True)
class CoverOptics:
    """Front cover optics applied per incoming direction.

    Attributes
    ----------
    n : float
        Refractive index [1] (ignored with ``spectral``).
    K : float
        Absorption coefficient [m-1].
    L : float
        Thickness [m].
    n_ar : float or None
        AR layer index [1].
    spectral : bool
        Use Rubin's soda-lime n(lambda) (a wavelength-dependent IAM, per channel) instead of ``n``.
    """

    n: float = 1.526
    K: float = 4.0
    L: float = 0.002
    n_ar: float = None
    spectral: bool = False

    def angular(self):
        """The optic for ``widesky.irradiance.Response``: a callable IAM, or a SpectralAngularTable."""
        if not self.spectral:
            cover_iam(0.0, self.n, self.K, self.L, self.n_ar)         # validates
            return _Iam(self.n, self.K, self.L, self.n_ar)
        ang = np.concatenate([np.arange(0.0, 80.0, 5.0), np.arange(80.0, 90.01, 1.0)])
        w = np.arange(280.0, 2480.5, 20.0)           # the PSM range (Rubin n extrapolated below 310 nm)
        k = self.K * w * 1e-9 / (4.0 * np.pi)          # the grey absorption coefficient as extinction k
        fac = spectral_cover_iam(ang, w, rubin_soda_lime_index(w), k=k, L=self.L, n_ar=self.n_ar)
        return SpectralAngularTable(ang, w, fac)


@dataclass(frozen=True)
class _Iam:
    n: float
    K: float
    L: float
    n_ar: float

    def __call__(self, aoi_deg):
        return cover_iam(np.clip(aoi_deg, 0.0, 90.0), self.n, self.K, self.L, self.n_ar)


@dataclass(frozen=True)
class SystemSpec:
    """Mounting and balance of system.

    Attributes
    ----------
    temperature_model : {"faiman", "pvsyst"}
    temperature_params : dict
        Model parameters (pvlib's names; default Faiman u0 = 25, u1 = 6.84 / PVsyst u_c = 29).
    dc_loss : float
        DC losses (wiring, mismatch, soiling) [1], [0, 1).
    dc_ac_ratio : float
        DC rating / inverter DC input limit [1], > 0.
    eta_inv_nom, eta_inv_ref : float
        PVWatts inverter efficiencies [1].
    """

    temperature_model: str = "faiman"
    temperature_params: dict = field(default_factory=dict)
    dc_loss: float = 0.02
    dc_ac_ratio: float = 1.2
    eta_inv_nom: float = 0.96
    eta_inv_ref: float = 0.9637

    def __post_init__(self):
        if self.temperature_model not in ("faiman", "pvsyst"):
            raise ValueError(f"temperature_model={self.temperature_model!r} must be 'faiman' or 'pvsyst'")
        if not 0 <= self.dc_loss < 1:
            raise ValueError(f"dc_loss={self.dc_loss!r} outside the valid range [0, 1)")
        if not self.dc_ac_ratio > 0:
            raise ValueError(f"dc_ac_ratio={self.dc_ac_ratio!r} must be > 0")

    def cell_temperature(self, poa_global, temp_air, wind_speed, eta_stc):
        """Cell temperature [degC] from POA global [W m-2], air temperature [degC], wind [m s-1]."""
        if self.temperature_model == "faiman":
            return faiman(poa_global, temp_air, wind_speed, **self.temperature_params)
        p = {"module_efficiency": eta_stc, **self.temperature_params}
        return pvsyst_cell(poa_global, temp_air, wind_speed, **p)


def _techs(technologies):
    ts = [get_technology(t) for t in technologies]
    names = [t.name for t in ts]
    if len(set(names)) != len(names):
        raise ValueError(f"technologies must have distinct names, got {names}")
    if not ts:
        raise ValueError("technologies is empty; valid presets: " + ", ".join(TECHNOLOGIES))
    return ts


def technology_responses(technologies, cover=None):
    """The integrator responses for a set of technologies.

    Parameters
    ----------
    technologies : list of str or technology objects
    cover : CoverOptics, optional
        Default ``CoverOptics()``; ``False`` for none.

    Returns
    -------
    responses : list of irradiance.Response
        One per distinct sub-cell EQE (unit "qe") with the cover's optic, then ``"cover"`` (unit
        weight with the optic).
    source : dict
        sub-cell name -> (response name, factor): the sub-cell's current [A m-2] is the response's
        output times the factor (sub-cells proportional to an earlier one share its response).
    """
    optic = None if cover is False else (cover or CoverOptics()).angular()
    resp, source, kept = [], {}, []
    for t in _techs(technologies):
        for sub, qe in t.subcell_qe(_FINE).items():
            for name, q0 in kept:
                m = q0 > 1e-6 * q0.max()
                f = float(np.median(qe[m] / q0[m])) if m.any() else 0.0
                if f > 0 and np.allclose(qe, f * q0, rtol=1e-9, atol=1e-12):
                    source[sub] = (name, f)
                    break
            else:
                kept.append((sub, qe))
                source[sub] = (sub, 1.0)
                resp.append(Response(sub, _FINE, qe, unit="qe", angular=optic))
    resp.append(Response(COVER_RESPONSE, [280.0, 2480.0], [1.0, 1.0], unit="weight", angular=optic))
    return resp, source


def technology_parts(responses):
    """``poa_irradiance(output=OutputOptions(parts=...))`` for the responses of
    :func:`technology_responses`: the yield model reads only each sub-cell current's global part, so only that is kept (a third of their
    output; the numbers are those of a full run); the cover keeps its three parts (the angle loss
    per part)."""
    return {r.name: "global" for r in responses if r.name != COVER_RESPONSE}


@dataclass
class TechnologyYield:
    """One technology's yield per module group.

    Attributes
    ----------
    technology : CellTechnology or TandemTechnology
    eta_stc : float
        Module efficiency at STC [1].
    pdc0 : dict
        group -> DC rating [W] (front area x eta_stc x 1000 W m-2).
    series : dict
        group -> pandas.DataFrame indexed by time: ``poa_global``, ``poa_direct``,
        ``poa_sky_diffuse``, ``poa_ground_diffuse`` (broadband: the whole solar spectrum, the in-band
        irradiance / in-band share; no optics) [W m-2], ``aoi`` [deg],
        ``effective_irradiance`` (front + bifaciality x rear), ``effective_irradiance_front``,
        ``poa_global_cover`` (broadband after the cover optics) [W m-2], ``spectral_factor``
        (front effective irradiance / STC-scaled cover irradiance) [1],
        ``temp_air``, ``cell_temperature`` [degC], ``wind_speed`` [m s-1], ``dc``, ``ac`` [W]
        (area-weighted means over the group's front faces; powers summed).
    waterfall : dict
        group -> dict stage -> reference yield [kWh/kWp] (stages WATERFALL_STAGES).
    current_mismatch_loss : dict
        group -> annual 2T current-mismatch loss [1] (0 for others).
    """

    technology: object
    eta_stc: float
    pdc0: dict
    series: dict
    waterfall: dict
    current_mismatch_loss: dict

    def energy(self, group, column="ac"):
        """Energy over the period [kWh] of ``column`` ("dc" or "ac")."""
        s = self.series[group]
        return float((s[column] * s.attrs["step_hours"]).sum() / 1000.0)

    def specific_yield(self, group, column="ac"):
        """Energy per rated power [kWh/kWp]."""
        return self.energy(group, column) / (self.pdc0[group] / 1000.0)

    def losses(self, group):
        """Waterfall steps as fractions [1] of the stage before (negative = gain)."""
        w = self.waterfall[group]
        out = {}
        for a, b in zip(WATERFALL_STAGES[:-1], WATERFALL_STAGES[1:]):
            out[b] = 1.0 - w[b] / w[a] if w[a] > 0 else 0.0
        return out


@dataclass
class YieldResult:
    """``technologies``: dict name -> TechnologyYield; ``groups``: tuple of group names;
    ``times``; ``visibility`` (T,) [km] of the sky states; ``g_ref_band`` [W m-2] (the STC reference over the
    channels); ``in_band_share`` [1] (:func:`widesky.core.spectral.in_band_share` of the channels: broadband =
    in-band / share)."""

    technologies: dict
    groups: tuple
    times: object
    visibility: np.ndarray
    g_ref_band: float
    in_band_share: float = 1.0


def _step_hours(times, T):
    if times is None or T < 2:
        return 1.0
    d = np.asarray((times[1:] - times[:-1]).total_seconds(), dtype=float) / 3600.0
    return float(np.median(d))


def _columns(res, attr, idx):
    """(T, len(idx)) of ``res.aoi`` or ``res.sun_visible`` for some faces (only those columns are read)."""
    return np.asarray(res.face_columns(attr, idx), dtype=float)


def _dni_estimate(res, chunk):
    """(T,) direct normal irradiance [W m-2] recovered from faces that see the sun."""
    T, F = res.n_steps, res.n_faces
    dni = np.zeros(T)
    for f0 in range(0, F, chunk):
        idx = np.arange(f0, min(F, f0 + chunk))
        d = res.get("broadband", "direct", faces=idx)
        r = np.nonzero(d.max(axis=1) > 0)[0] if d.size else np.zeros(0, int)   # steps with sun
        if r.size == 0:
            continue
        d = d[r].astype(float)
        aoi = _columns(res, "aoi", idx)[r]
        sv = _columns(res, "sun_visible", idx)[r]
        with np.errstate(invalid="ignore"):
            c = np.cos(np.radians(aoi))                # NaN at night: not ok below
            ok = (sv > 0.5) & (c > 0.2)
        with np.errstate(invalid="ignore", divide="ignore"):
            est = np.where(ok, d / np.where(ok, sv * c, 1.0), 0.0)
        dni[r] = np.maximum(dni[r], est.max(axis=1))
    return dni


def _weather(name, value, T):
    a = np.asarray(value, dtype=float)
    a = np.broadcast_to(a, (T,)) if a.ndim == 0 else a
    if a.shape != (T,):
        raise ValueError(f"{name} must be a scalar or have the result's {T} steps, got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} has NaN or infinite values (fill gaps first)")
    return a


def pv_yield(result, technologies, temp_air=20.0, wind_speed=1.0, *, sources=None, system=None,
             reference=None, reference_path=None, face_chunk=2048, progress=False):
    """Yield of each technology on every module group of a POA result.

    Parameters
    ----------
    result : irradiance.POAResult
        From a run with ``technology_responses(technologies)`` (the responses must be present).
    technologies : list of str or technology objects
    temp_air : float or array_like (T,)
        Air temperature [degC].
    wind_speed : float or array_like (T,)
        Wind speed [m s-1].
    sources : dict, optional
        The second output of :func:`technology_responses` (default: recomputed; pass it when the
        run used your own responses).
    system : SystemSpec, optional
    reference : array_like (C,), optional
        Band-mean reference spectrum for STC [W m-2 nm-1] on the result's channels (e.g.
        ``widesky.pvsim.reference.widesky_am15g()["spectrum"]``); default ASTM G173 global tilted.
    reference_path : str, optional
        ASTM G173 file for the default reference (default from the input data directory).
    face_chunk : int
        Faces read at a time (bounds memory: about 50 x T x face_chunk bytes).
    progress : bool
        A tqdm bar over technologies x groups.

    Returns
    -------
    YieldResult
    """
    techs = _techs(technologies)
    if sources is None:
        sources = technology_responses(techs)[1]
    T = result.n_steps
    edges = result.channel_edges if result.channel_edges is not None else channel_edges()
    setup = _yield_setup(techs, T, edges, temp_air, wind_speed, system, reference, reference_path)
    system, ta, ws, kb, prep = setup["system"], setup["ta"], setup["ws"], setup["kb"], setup["prep"]
    needed = {src for t in techs for sub in t.subcells for src in [sources[sub][0]]} | {COVER_RESPONSE}
    missing = sorted(needed - set(result.responses))
    if missing:
        raise ValueError(f"the POA result lacks response(s) {missing}; run poa_irradiance with "
                         "widesky.pvsim.technology_responses(technologies)")
    faces = result.faces
    side = np.asarray(faces.side)
    dni = _dni_estimate(result, face_chunk)
    bar = None
    if progress:
        bar = tqdm(total=len(faces.group_names), desc="pv yield", unit="group")
    accs = {}
    for g, gname in enumerate(faces.group_names):
        accs[gname] = {t.name: _GroupAccumulator(T, kb) for t in techs}
        idx_all = np.nonzero(faces.group == g)[0]
        front = idx_all[side[idx_all] == "front"]
        back_of = {int(faces.parent[b]): b for b in idx_all[side[idx_all] == "back"]}
        for f0 in range(0, front.size, face_chunk):
            fi = front[f0:f0 + face_chunk]
            bi = np.array([back_of.get(int(p), -1) for p in faces.parent[fi]], dtype=int)
            chunk = _Chunk(result, fi, bi, dni, ta, ws, any(t.bifaciality > 0 for t in techs))
            if chunk.rows.size == 0:
                continue
            for t in techs:
                accs[gname][t.name].add(chunk, t, sources, *prep[t.name], system)
        if bar is not None:
            bar.update(1)
    if bar is not None:
        bar.close()
    return _yield_finish(accs, faces, techs, setup, result.times, result.states)


def _yield_setup(techs, T, edges, temp_air, wind_speed, system, reference, reference_path):
    """What the yield model needs before the faces: the weather, the STC reference, per technology
    (eta_stc, reference currents)."""
    system = system or SystemSpec()
    ta = _weather("temp_air", temp_air, T)
    ws = _weather("wind_speed", wind_speed, T)
    if np.any(ws < 0):
        raise ValueError(f"wind_speed must be >= 0 [m s-1], got min {ws.min()!r}")
    if reference is None:
        g_ref = am15g_channels(edges, reference_path)
    else:
        g_ref = np.asarray(reference, dtype=float)
        if g_ref.shape != (edges.size - 1,) or not np.all(np.isfinite(g_ref)) or np.any(g_ref < 0):
            raise ValueError(f"reference must be finite, >= 0 with shape ({edges.size - 1},), got {g_ref.shape}")
    g_ref_band = float(np.sum(g_ref * np.diff(edges)))
    prep = {t.name: (_eta_stc(t, edges, g_ref), reference_currents(t, edges, reference=g_ref)) for t in techs}
    share = in_band_share(edges[0], edges[-1])     # in-band -> broadband (the whole spectrum) [1]
    return {"system": system, "ta": ta, "ws": ws, "g_ref_band": g_ref_band, "kb": 1.0 / share,
            "share": share, "prep": prep, "T": T}


def _yield_finish(accs, faces, techs, setup, times, states):
    """YieldResult from the accumulated sums (dict group name -> technology name -> _GroupAccumulator)."""
    system, ta, ws, prep, T = setup["system"], setup["ta"], setup["ws"], setup["prep"], setup["T"]
    hours = _step_hours(times, T)
    per = {t.name: ({}, {}, {}, {}) for t in techs}          # pdc0, series, waterfall, mismatch
    side = np.asarray(faces.side)
    for g, gname in enumerate(faces.group_names):
        idx_all = np.nonzero(faces.group == g)[0]
        area = float(faces.area[idx_all[side[idx_all] == "front"]].sum())
        for t in techs:
            eta = prep[t.name][0]
            pdc0, series, waterfall, cml = per[t.name]
            acc = accs[gname][t.name]
            pdc0[gname] = eta * area * G_STC
            s = acc.series(area, times, ta, ws)
            dc_net = s["dc"] * (1.0 - system.dc_loss)
            s["dc"] = dc_net
            s["ac"] = (pvwatts_inverter(dc_net, pdc0[gname] / system.dc_ac_ratio, system.eta_inv_nom,
                                        system.eta_inv_ref) if pdc0[gname] > 0 else 0.0 * dc_net)
            s.attrs["step_hours"] = hours
            series[gname] = s
            waterfall[gname] = acc.waterfall(area, eta, hours, s, pdc0[gname])
            cml[gname] = acc.mismatch_loss(t)
    out = {t.name: TechnologyYield(t, prep[t.name][0], *per[t.name]) for t in techs}
    vis = np.asarray(states.visibility, dtype=float) if states is not None else np.full(T, np.nan)
    return YieldResult(out, tuple(faces.group_names), times, np.broadcast_to(vis, (T,)).copy(),
                       setup["g_ref_band"], setup["share"])


class _Chunk:
    """One chunk of a group's front faces (and their rear sides): the arrays every technology needs,
    read once, restricted to the steps with light (``rows``); response currents read on first use."""

    def __init__(self, res, fi, bi, dni, ta, ws, want_back):
        self.res, self.fi, self.area = res, fi, res.faces.area[fi]
        parts = {p: res.get("broadband", p, faces=fi) for p in ("direct", "sky_diffuse", "ground_diffuse")}
        g = parts["direct"].astype(float) + parts["sky_diffuse"] + parts["ground_diffuse"]
        self.rows = np.nonzero(g.max(axis=1) > 0)[0] if g.size else np.zeros(0, int)
        r = self.rows
        self.parts = {p: v[r].astype(float) for p, v in parts.items()}
        self.g = g[r]
        self.cover = res.get(COVER_RESPONSE, "global", faces=fi)[r].astype(float)
        self.aoi = _columns(res, "aoi", fi)[r]
        cos_aoi = np.maximum(np.cos(np.radians(np.nan_to_num(self.aoi, nan=90.0))), 0.0)
        d = self.parts["direct"]
        self.unshaded = self.g - d + np.maximum(dni[r, None] * cos_aoi, d)
        self.ta, self.ws = ta[r, None], ws[r, None]
        self.has_back = (bi >= 0) if want_back else np.zeros(fi.size, bool)
        self.bsel = bi[self.has_back]
        self._cache = {}
        day = np.isfinite(self.aoi)
        a = self.area
        # area-weighted sums every technology shares, computed once per chunk
        self.common = {"poa_global": self.g @ a, "poa_direct": d @ a,
                       "poa_sky_diffuse": self.parts["sky_diffuse"] @ a,
                       "poa_ground_diffuse": self.parts["ground_diffuse"] @ a,
                       "aoi_w": np.where(day, np.nan_to_num(self.aoi), 0.0) @ a, "aoi_a": day @ a,
                       "cover": self.cover @ a, "unshaded": self.unshaded @ a}
        self._tc = {}

    def cell_temperature(self, system, eta, kb):
        """(cell temperature (rows, F) [degC], its area-weighted sum (rows,)), shared by technologies
        whose temperature model does not depend on their efficiency (Faiman); from the broadband POA
        irradiance (in-band times ``kb`` = 1 / in-band share [1]), what the models' pyranometers measured."""
        key = (system.temperature_model, tuple(sorted(system.temperature_params.items())),
               eta if system.temperature_model == "pvsyst" else None, kb)
        if key not in self._tc:
            tc = system.cell_temperature(self.g * kb, self.ta, self.ws, eta)
            self._tc[key] = (tc, tc @ self.area)
        return self._tc[key]

    def current(self, name, back=False):
        key = (name, back)
        if key not in self._cache:
            faces = self.bsel if back else self.fi
            self._cache[key] = self.res.get(name, "global", faces=faces)[self.rows].astype(float)
        return self._cache[key]


def _eta_stc(tech, edges, g_ref):
    if isinstance(tech, TandemTechnology):
        return tandem_stc_efficiency(tech, edges, reference=g_ref)
    return tech.eta_stc


class _GroupAccumulator:
    """Sums over a group's faces (area-weighted (T,) series and waterfall energies)."""

    def __init__(self, T, kb):
        self.q = {k: np.zeros(T) for k in ("poa_global", "poa_direct", "poa_sky_diffuse", "poa_ground_diffuse",
                                           "aoi_w", "aoi_a", "cover", "effective_front", "effective", "tc",
                                           "unshaded", "low", "dc")}
        self.kb = kb
        self.j_sum = None

    def add(self, c: _Chunk, tech, sources, eta, jref, system):
        a, r = c.area, c.rows
        cur = {sub: c.current(sources[sub][0]) * sources[sub][1] for sub in tech.subcells}
        e_front = effective_irradiance(tech, cur, jref)
        e_tot = e_front
        if tech.bifaciality > 0 and c.has_back.any():
            curb = {sub: c.current(sources[sub][0], back=True) * sources[sub][1] for sub in tech.subcells}
            e_tot = e_front.copy()
            e_tot[:, c.has_back] += tech.bifaciality * effective_irradiance(tech, curb, jref)
        tc, tc_sum = c.cell_temperature(system, eta, self.kb)
        low = e_tot * low_irradiance_factor(e_tot, tech.low_irradiance_200)
        dc = eta * low * temperature_factor(tc, tech.gamma_pdc)          # W m-2 of module
        q = self.q
        for k, v in c.common.items():
            q[k][r] += v
        q["tc"][r] += tc_sum
        for k, v in (("effective_front", e_front), ("effective", e_tot), ("low", low), ("dc", dc)):
            q[k][r] += v @ a
        if isinstance(tech, TandemTechnology):
            js = {k: v @ a for k, v in cur.items()}
            if self.j_sum is None:
                self.j_sum = {k: np.zeros(len(q["dc"])) for k in js}
            for k, v in js.items():
                self.j_sum[k][r] += v

    def series(self, area, times, ta, ws):
        q, A = self.q, (area if area > 0 else 1.0)
        kb = self.kb / A                          # in-band sums -> broadband means [m-2]
        with np.errstate(invalid="ignore", divide="ignore"):
            aoi = np.where(q["aoi_a"] > 0, q["aoi_w"] / q["aoi_a"], np.nan)
            sf = np.where(q["cover"] > 0, (q["effective_front"] / G_STC) / (q["cover"] * self.kb / G_STC),
                          np.nan)
        return pd.DataFrame({
            "poa_global": q["poa_global"] * kb, "poa_direct": q["poa_direct"] * kb,
            "poa_sky_diffuse": q["poa_sky_diffuse"] * kb, "poa_ground_diffuse": q["poa_ground_diffuse"] * kb,
            "aoi": aoi, "effective_irradiance": q["effective"] / A,
            "effective_irradiance_front": q["effective_front"] / A, "poa_global_cover": q["cover"] * kb,
            "spectral_factor": sf,
            "temp_air": ta, "wind_speed": ws, "cell_temperature": np.where(q["poa_global"] > 0, q["tc"] / A, ta),
            "dc": q["dc"]}, index=times)

    def waterfall(self, area, eta, hours, s, pdc0):
        q = self.q
        A = area if area > 0 else 1.0
        ry = lambda e: float(np.sum(e) * hours / A / 1000.0)  # noqa: E731  kWh m-2 = kWh/kWp
        w = {"unshaded": ry(q["unshaded"]) * self.kb, "poa": ry(q["poa_global"]) * self.kb,
             "cover": ry(q["cover"]) * self.kb, "effective": ry(q["effective_front"]),
             "bifacial": ry(q["effective"]), "low_irradiance": ry(q["low"])}
        kwp = pdc0 / 1000.0 if pdc0 > 0 else 1.0
        w["temperature"] = float(np.sum(q["dc"]) * hours / 1000.0 / (eta * A))
        w["dc"] = float(np.sum(s["dc"]) * hours / 1000.0 / kwp)
        w["ac"] = float(np.sum(s["ac"]) * hours / 1000.0 / kwp)
        return w

    def mismatch_loss(self, tech):
        if self.j_sum is None:
            return 0.0
        return current_mismatch_loss(tech, self.j_sum)
