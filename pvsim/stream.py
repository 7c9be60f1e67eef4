"""The yield model fused into the integrator's output stream.

:func:`widesky.pvsim.simulate` hands a :class:`YieldStream` to ``widesky.irradiance.poa_irradiance(output=OutputOptions(consumer=...))``:
for every chunk of daylight steps the integrator has just assembled, the stream reduces the faces'
broadband and cover parts, angles of incidence and sub-cell currents to the per-group, per-technology
sums of the yield model (:mod:`widesky.pvsim.system`'s ``_GroupAccumulator``) in one pass of a small C kernel
(``widesky.pvsim._kernel.accumulate``, the GIL released), so the per-face currents are never written and
read back. The result is :func:`widesky.pvsim.pv_yield`'s on the saved run, to float32 rounding
(tests/test_pvsim_stream.py compares the two).

The per-face arithmetic is that of ``pv_yield`` (effective irradiance from the sub-cell currents,
the bifacial rear, the low-irradiance law, the cell temperature linear in the POA irradiance, DC per
module area), in float32 per face with double sums; the step's direct normal irradiance for the
unshaded POA is recovered from the faces that see the sun, as ``pv_yield`` does.
"""

from __future__ import annotations

import numpy as np

from widesky.irradiance import FaceTable, OutputOptions, poa_irradiance

from . import _kernel
from .module import G_STC, stack_power
from .reference import widesky_am15g
from .system import (COVER_RESPONSE, _GroupAccumulator, _techs, _yield_finish, _yield_setup, technology_parts,
                     technology_responses)
from .technologies import TandemTechnology

__all__ = ["YieldStream", "simulate"]

_BROADBAND = (("broadband", "direct"), ("broadband", "sky_diffuse"), ("broadband", "ground_diffuse"))
_COVER = ((COVER_RESPONSE, "direct"), (COVER_RESPONSE, "sky_diffuse"), (COVER_RESPONSE, "ground_diffuse"))
_COMMON = ("poa_global", "poa_direct", "poa_sky_diffuse", "poa_ground_diffuse", "aoi_w", "aoi_a", "cover",
           "unshaded")


class YieldStream:
    """Consumer of ``poa_irradiance`` that accumulates the yield model per chunk of steps.

    Parameters
    ----------
    faces : irradiance.FaceTable
        The scene's faces (``FaceTable.from_scene``).
    states : irradiance.SkyStates
        The run's T states (sun direction and elevation [deg]).
    technologies : list of technology objects
    sources : dict
        Sub-cell -> (response name, factor), from :func:`widesky.pvsim.technology_responses`.
    temp_air, wind_speed : float or array_like (T,)
        [degC], [m s-1].
    system : SystemSpec, optional
    edges : array_like
        Channel edges [nm] of the sky.
    reference, reference_path
        As :func:`widesky.pvsim.pv_yield`.
    """

    def __init__(self, faces, states, technologies, sources, temp_air=20.0, wind_speed=1.0, *, system=None,
                 edges=None, reference=None, reference_path=None):
        self.faces, self.states, self.techs = faces, states, list(technologies)
        T = len(states)
        self.setup = _yield_setup(self.techs, T, np.asarray(edges, float), temp_air, wind_speed, system,
                                  reference, reference_path)
        st = self.setup
        self.accs = {g: {t.name: _GroupAccumulator(T, st["kb"]) for t in self.techs} for g in faces.group_names}
        names = []
        for t in self.techs:
            for sub in t.subcells:
                if sources[sub][0] not in names:
                    names.append(sources[sub][0])
        self.currents = names
        self.tech_table = np.array([self._row(t, sources, names) for t in self.techs], dtype=np.float64)
        ws = st["ws"]
        # the temperature models are linear in the POA irradiance; they take it broadband (in-band x kb)
        self.tcoef = np.array([st["system"].cell_temperature(1.0, 0.0, ws, st["prep"][t.name][0]) * st["kb"]
                               * np.ones(T) for t in self.techs], dtype=np.float64)
        self.runs = self._runs(any(t.bifaciality > 0 for t in self.techs))
        self.normals = np.ascontiguousarray(np.asarray(faces.normal, dtype=np.float32).T)
        self.area = np.ascontiguousarray(faces.area, dtype=np.float32)
        self.sun = np.zeros((T, 4))
        self.sun[:, :3] = states.sun_direction
        self.sun[:, 3] = states.sun_elevation > 0
        self.dni = np.zeros(T)
        self._zeros = None

    def _row(self, tech, sources, names):
        """The kernel's parameters of one technology (see pvsim/_kernel.c)."""
        eta, jref = self.setup["prep"][tech.name]
        p_ref = float(stack_power(tech, jref))
        if not p_ref > 0:
            raise ValueError(f"reference power of {tech.name!r} is {p_ref!r}: the cell collects nothing "
                             "under the reference spectrum")
        subs = list(tech.subcells)
        r = [(names.index(sources[s][0]), float(sources[s][1])) for s in subs]
        if isinstance(tech, TandemTechnology):
            kind, (v0, v1) = tech.terminals, tech.voltages
        else:
            kind, v0, v1 = 1, 0.0, 0.0
            r.append(r[0])
        a = (tech.low_irradiance_200 - 1.0) / np.log(0.2)
        return [kind, r[0][0], r[0][1], r[1][0], r[1][1], v0, v1, G_STC / p_ref, tech.bifaciality, a,
                tech.gamma_pdc, eta]

    def _runs(self, want_back):
        """(n, 4) int64: group, first front face, count, first back face (-1: none), for runs of
        consecutive front faces whose backs are consecutive too (or absent)."""
        f = self.faces
        side = np.asarray(f.side)
        out = []
        for g in range(len(f.group_names)):
            idx = np.nonzero(f.group == g)[0]
            front = idx[side[idx] == "front"]
            back_of = {int(f.parent[b]): int(b) for b in idx[side[idx] == "back"]}
            back = np.array([back_of.get(int(p), -1) if want_back else -1 for p in f.parent[front]], dtype=np.int64)
            i = 0
            while i < front.size:
                j = i + 1
                while (j < front.size and front[j] == front[j - 1] + 1
                       and ((back[j] < 0 and back[i] < 0) or (back[j] >= 0 and back[i] >= 0
                                                              and back[j] == back[j - 1] + 1))):
                    j += 1
                out.append((g, int(front[i]), j - i, int(back[i])))
                i = j
        return np.array(out, dtype=np.int64).reshape(-1, 4)

    def __call__(self, steps, block, rows, currents):
        Tc = steps.size
        gps = []
        for name in self.currents:
            gp = currents.get(name)
            if gp is None:                         # kept in full with an angle x wavelength optic
                tot = np.ascontiguousarray(block[(name, "global")][rows])
                gp = (tot, np.zeros(Tc, np.float32), tot)
            gps.append(gp)
        G, K = len(self.faces.group_names), len(self.techs)
        dni_out = np.zeros(Tc)
        common = np.zeros((G, Tc, len(_COMMON)))
        tech = np.zeros((G, K, Tc, 7))
        if _COVER[0] in block:
            cover = tuple(block[k] for k in _COVER)
        else:                                      # the cover kept as its global part only
            g = block[(COVER_RESPONSE, "global")]
            if self._zeros is None or self._zeros.shape != g.shape:
                self._zeros = np.zeros(g.shape, np.float32)
            cover = (g, self._zeros, self._zeros)
        planes = tuple(block[k] for k in _BROADBAND) + cover + (block["aoi"], block["sun_visible"])
        _kernel.accumulate(planes, np.ascontiguousarray(rows, dtype=np.int64),
                           tuple(g[0] for g in gps), tuple(g[2] for g in gps),
                           np.ascontiguousarray(np.stack([g[1] for g in gps]), dtype=np.float32).reshape(-1)
                           if gps else np.zeros(0, np.float32),
                           np.ascontiguousarray(self.sun[steps]), self.normals, self.area, self.runs,
                           self.tech_table, np.ascontiguousarray(self.tcoef[:, steps]),
                           np.ascontiguousarray(self.setup["ta"][steps]), dni_out, common, tech)
        self.dni[steps] = dni_out
        for g, gname in enumerate(self.faces.group_names):
            for k, t in enumerate(self.techs):
                q = self.accs[gname][t.name].q
                for c, key in enumerate(_COMMON):
                    q[key][steps] += common[g, :, c]
                for c, key in enumerate(("effective_front", "effective", "low", "dc", "tc")):
                    q[key][steps] += tech[g, k, :, c]
                if isinstance(t, TandemTechnology):
                    acc = self.accs[gname][t.name]
                    if acc.j_sum is None:
                        acc.j_sum = {s: np.zeros(len(q["dc"])) for s in t.subcells}
                    for c, s in enumerate(t.subcells):
                        acc.j_sum[s][steps] += tech[g, k, :, 5 + c]

    def result(self, times=None):
        """The YieldResult of everything accumulated (call after the run)."""
        return _yield_finish(self.accs, self.faces, self.techs, self.setup,
                             self.states.times if times is None else times, self.states)


def simulate(scene, sky, states, technologies, temp_air=20.0, wind_speed=1.0, *, cover=None, system=None,
             weather=None, times=None, settings=None, output=None, run=None, reference=None,
             reference_path=None, keep_currents=True):
    """One integrator run for all ``technologies`` (shared geometry and sky) with the yield model
    fused into its output stream (:class:`YieldStream`: no current is read back).

    Parameters
    ----------
    scene, sky, states : as ``widesky.irradiance.poa_irradiance``.
    technologies : list of str or technology objects
    temp_air, wind_speed : float or (T,) [degC], [m s-1]
    cover : CoverOptics, optional
    system : SystemSpec, optional
    weather : irradiance.MeasuredSky, optional
        Measured irradiance (T,) [W m-2] the sky is scaled to, the spectral shape under it ("clear" or
        "allsky", docs/all-sky.md; the ``widesky pv`` commands use "allsky" whenever a weather file gives DNI
        and DHI) and the all-sky model's parts; default the clear sky as modelled.
    times, settings : as ``widesky.irradiance.poa_irradiance``.
    run : irradiance.RunOptions, optional
        Processes, progress bars, ... of the integrator run.
    output : str, optional
        HDF5 file for the POA result (streams; bounded memory).
    reference : None, "widesky" or array_like (C,)
        STC reference spectrum: ASTM G173 (default), the sky model's own AM1.5G
        (:func:`widesky.pvsim.reference.widesky_am15g`), or band means [W m-2 nm-1].
    keep_currents : bool
        Keep every sub-cell current (its global part per face) and the cover's three parts in the POA
        result, in memory or in ``output``, so :func:`pv_yield` can be run on it again; False keeps
        the broadband parts and the cover's global part (the currents and the cover's split exist
        only chunk by chunk: less memory, less writing).

    Returns
    -------
    (irradiance.POAResult, YieldResult)
    """
    techs = _techs(technologies)
    resp, sources = technology_responses(techs, cover)
    if isinstance(reference, str):
        if reference != "widesky":
            raise ValueError(f"reference={reference!r} must be None, 'widesky' or an array")
        reference = widesky_am15g(sky)["scaled"]
    stream = YieldStream(FaceTable.from_scene(scene), states, techs, sources, temp_air, wind_speed,
                         system=system, edges=sky.channel_edges, reference=reference,
                         reference_path=reference_path)
    parts = technology_parts(resp)
    if not keep_currents:
        parts = {**{k: () for k in parts}, COVER_RESPONSE: "global"}
    res = poa_irradiance(scene, sky, states, responses=resp, settings=settings, weather=weather, times=times,
                         output=OutputOptions(path=output, parts=parts, consumer=stream), run=run)
    return res, stream.result(times if times is not None else res.times)
