"""Facade solar gains through widesky's integrator: glazing as a spectral-angular Response.

The spectral route: each glazing unit's solar heat gain coefficient g(theta, lambda) (transmitted
plus inward-flowing absorbed, :meth:`widesky.thermal.glazing.GlazingUnit.optics`) becomes an
:class:`widesky.irradiance.Response` with a :class:`widesky.irradiance.SpectralAngularTable`. The integrator applies
it per incoming direction (the beam at its angle of incidence, every sky patch and reflected ray at
its own) and per channel of the sky's spectrum, so ``result.get(name, part)`` is the gain per m2 of
glass from that part [W m-2]. The broadband route users know: the unit's rated g (AM1.5 global
weighted) times its normalised angular curve, as an :class:`widesky.irradiance.AngularTable`, applied by
the same integrator to broadband light. The two differ only by the spectrum the glazing sees.

Broadband light is the whole solar spectrum, as a weather file's DNI/DHI and a pyranometer give it: the
integrator's irradiance over the sky's channels (280-2480 nm) divided by
:func:`widesky.core.spectral.in_band_share` (0.99248), widesky's one convention (docs/thermal.md, "Total
shortwave"). :func:`irradiance_by_surface` (the total shortwave on opaque surfaces and the broadband window
route) and both routes of :func:`window_gain_by_surface` are broadband so: the light beyond 2480 nm (0.75 % of
AM1.5G) passes at each route's own mean g (the rated route's AM1.5-weighted g(theta), the spectral route's
g weighted by the step's in-band spectrum from each direction), so the routes still differ only by the spectrum.

Units: [W m-2] per m2 of glass, angles [deg], wavelength [nm].
"""

from __future__ import annotations

import numpy as np

from widesky.core.spectral import in_band_share
from widesky.irradiance import AngularTable, Response, SpectralAngularTable, make_scene

from .glazing import ANGLES, WAVELENGTHS, GlazingUnit
from .loads import glazing_g_table

__all__ = ["glazing_response", "rated_glazing_response", "building_scene", "irradiance_by_surface",
           "window_gain_by_surface", "group_weights", "front_faces", "result_in_band_share"]


def glazing_response(unit: GlazingUnit, name=None, quantity="shgc"):
    """The unit's g (or ``quantity`` "transmittance") by angle and wavelength as a Response.

    Parameters
    ----------
    unit : GlazingUnit
    name : str, optional
        Response name (default ``"<unit.name>:spectral"``).
    quantity : {"shgc", "transmittance"}

    Returns
    -------
    irradiance.Response
        Unit weight over 280-2500 nm with a SpectralAngularTable (A angles x K wavelengths) [1].
    """
    if quantity not in ("shgc", "transmittance"):
        raise ValueError(f"quantity={quantity!r} not one of ('shgc', 'transmittance')")
    o = unit.optics(ANGLES, WAVELENGTHS)
    table = SpectralAngularTable(ANGLES, WAVELENGTHS, np.clip(o[quantity], 0.0, None))
    return Response(name or f"{unit.name}:spectral", WAVELENGTHS, np.ones_like(WAVELENGTHS),
                    unit="weight", angular=table)


def rated_glazing_response(unit: GlazingUnit, spectrum_wavelength, spectrum, name=None):
    """The broadband route: rated g(theta) (one spectrum, e.g. AM1.5 global) as a Response.

    Returns
    -------
    irradiance.Response
        Unit weight with an AngularTable of the spectrum-weighted g by angle [1].
    """
    ang, g, _, _ = glazing_g_table(unit, spectrum_wavelength, spectrum)
    return Response(name or f"{unit.name}:rated", np.array([280.0, 2500.0]), np.ones(2),
                    unit="weight", angular=AngularTable(ang, g))


def building_scene(building, context=(), *, ground_albedo=None, samples_per_face=1,
                   analysis_reflectance=0.3):
    """:func:`widesky.irradiance.make_scene` of a building: one analysis group per non-shading surface
    (named by its label), shading surfaces and ``context`` meshes as context.

    Returns
    -------
    scene : irradiance.Scene
    labels : list of str
        The group names, in the order of the building's non-shading surfaces.
    """
    meshes, labels, shade = building.analysis_meshes()
    ctx = list(context) if isinstance(context, (list, tuple)) else [context]
    if shade is not None:
        ctx.append(shade)
    scene = make_scene(meshes, ctx, groups=labels, ground_albedo=ground_albedo,
                       samples_per_face=samples_per_face,
                       analysis_reflectance=analysis_reflectance)
    return scene, labels


def front_faces(res):
    """(F,) bool: the result faces that are front sides ("front" or 0 in ``faces.side``)."""
    side = np.asarray(res.faces.side)
    return (side == "front") if side.dtype.kind in "OUS" else (side == 0)


def group_weights(res, labels):
    """(F, S) area weights [1] of each result face in each labelled group (front sides), columns
    summing to 1."""
    names = list(res.faces.group_names)
    missing = [lab for lab in labels if lab not in names]
    if missing:
        raise ValueError(f"result has no group {missing[0]!r} (groups: {names[:5]} ...)")
    M = np.zeros((len(res.faces.area), len(labels)))
    for j, lab in enumerate(labels):
        sel = (res.faces.group == names.index(lab)) & front_faces(res)
        M[sel, j] = res.faces.area[sel]
    return M / M.sum(0)


def result_in_band_share(res):
    """:func:`widesky.core.spectral.in_band_share` [1] of a POAResult's channel range (280-2480 nm when the
    result carries no channel edges): broadband [W m-2] = in-band [W m-2] / share."""
    e = getattr(res, "channel_edges", None)
    lo, hi = (280.0, 2480.0) if e is None else (float(np.asarray(e)[0]), float(np.asarray(e)[-1]))
    return in_band_share(lo, hi)


def irradiance_by_surface(res, labels):
    """Area-weighted broadband (whole solar spectrum) parts per surface from a POAResult: the total shortwave.

    Returns
    -------
    dict of numpy.ndarray
        (T, S): ``poa_direct``, ``poa_sky_diffuse``, ``poa_ground_diffuse``, ``poa_global``
        [W m-2] (the integrator's in-band parts / :func:`result_in_band_share`) and ``aoi`` [deg] (NaN at night).
    """
    M = group_weights(res, labels) / result_in_band_share(res)
    out = {f"poa_{p}": res.get("broadband", p) @ M
           for p in ("direct", "sky_diffuse", "ground_diffuse", "global")}
    with np.errstate(invalid="ignore"):
        out["aoi"] = np.nan_to_num(res.aoi, nan=90.0) @ M
    return out


def window_gain_by_surface(res, labels, building, constructions, route="spectral"):
    """(T, W) solar gain per m2 of glass of every window surface [W m-2] from a POAResult.

    Parameters
    ----------
    res : POAResult
        Computed with the responses of :func:`glazing_response` (``route="spectral"``) or
        :func:`rated_glazing_response` (``"rated"``) of each window construction's unit, named
        ``"<construction>:spectral"`` / ``"<construction>:rated"``.
    labels : list of str
        From :func:`building_scene`.
    building : Building
    constructions : dict of str to Construction
    route : {"spectral", "rated"}
    """
    if route not in ("spectral", "rated"):
        raise ValueError(f"route={route!r} not one of ('spectral', 'rated')")
    surf = [s for s in building.surfaces if s.kind != "shading"]
    wins = [s for s in surf if s.kind == "window"]
    M = group_weights(res, [s.label for s in wins]) / result_in_band_share(res)     # on broadband light
    out = np.zeros((res.n_steps, len(wins)))
    for j, s in enumerate(wins):
        name = f"{constructions[s.construction].name}:{route}"
        out[:, j] = res.get(name, "global") @ M[:, j]
    return out


