"""Validated view parameters of the sky explorer (one request's sky state, view and plane).

Every value arrives as text in a query string; :func:`parse_view` converts it once, checks it against
the loaded dataset's ranges and raises :class:`ParameterError` naming the parameter, its value and the
valid range or choices.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["ParameterError", "View", "parse_view", "QUANTITY_CHOICES", "VIEW_CHOICES", "MAX_VIEW_RESOLUTION",
           "MAX_SAVE_RESOLUTION", "EXPOSURE_EV"]

QUANTITY_CHOICES = ("sky", "sun", "polarisation", "transmittance")
VIEW_CHOICES = ("up", "side")
MAX_VIEW_RESOLUTION = 1024     # [pixels] the interactive image (a slider move renders it)
MAX_SAVE_RESOLUTION = 10000    # [pixels] a saved image (as the reference GUI's largest)
EXPOSURE_EV = 20.0             # [EV] exposure range, +-: 2**20 ~ 1e6 (twilight to the sun's disc)


class ParameterError(ValueError):
    """A request parameter is missing, malformed or out of range (HTTP 400)."""


@dataclass(frozen=True)
class View:
    """One sky state, view and analysis plane.

    Attributes
    ----------
    dataset : int
        Index of the dataset among those named on the command line.
    sun_elevation, sun_azimuth : float
        [deg]; azimuth clockwise from north (180 = south). With ``sun="site"`` they come from the site
        and ``time`` (NREL SPA, apparent elevation).
    visibility : float  [km]
    albedo : float  [1]
    altitude : float  [m]
    quantity : str  one of :data:`QUANTITY_CHOICES`
    channel : str  ``"rgb"`` (sRGB composite of the visible channels) or a channel centre such as ``"550nm"``
    view : str  ``"up"`` or ``"side"``
    view_azimuth : float  [deg] azimuth the side view looks towards
    resolution : int  [pixels] at most :data:`MAX_VIEW_RESOLUTION` (a save may ask for up to
        :data:`MAX_SAVE_RESOLUTION`)
    exposure : float  [EV] within +-:data:`EXPOSURE_EV`
    surface_tilt, surface_azimuth : float  [deg] the tilted plane of the irradiance readout
    """

    dataset: int = 0
    sun_elevation: float = 30.0
    sun_azimuth: float = 180.0
    visibility: float = 50.0
    albedo: float = 0.2
    altitude: float = 0.0
    quantity: str = "sky"
    channel: str = "rgb"
    view: str = "up"
    view_azimuth: float = 180.0
    resolution: int = 512
    exposure: float = 0.0
    surface_tilt: float = 35.0
    surface_azimuth: float = 180.0


def _number(query, name, default, lo, hi, unit, integer=False):
    raw = query.get(name)
    if raw is None or raw == "":
        return default
    try:
        value = int(raw) if integer else float(raw)
    except ValueError:
        raise ParameterError(f"{name}={raw!r} is not a number; expected {lo:g} to {hi:g} {unit}".rstrip()) from None
    if not math.isfinite(value) or value < lo - 1e-9 or value > hi + 1e-9:
        raise ParameterError(f"{name}={raw} {unit}".rstrip() + f" outside [{lo:g}, {hi:g}]")
    return value


def _choice(query, name, default, choices):
    raw = query.get(name, default)
    if raw not in choices:
        raise ParameterError(f"{name}={raw!r}: expected one of {', '.join(choices)}")
    return raw


def channel_names(model):
    """The channel choices of a dataset: ``"rgb"`` and each band centre as ``"<nm>nm"``."""
    return ["rgb"] + [f"{w:g}nm" for w in model.wavelengths]


def parse_view(query, models, n_datasets, site_sun=None) -> View:
    """A :class:`View` from a query mapping (name -> text) and the list of dataset opener objects.

    Parameters
    ----------
    query : mapping of str to str
    n_datasets : int
        Number of datasets named on the command line.
    models : callable
        ``models(index)`` -> the loaded :class:`widesky.skymodel.SkyModel` of that dataset index.
    site_sun : callable, optional
        ``site_sun(query) -> (elevation, azimuth)`` [deg] used when ``sun=site``.
    """
    di = _number(query, "dataset", 0, 0, n_datasets - 1, "", integer=True)
    m = models(di)
    sun_mode = _choice(query, "sun", "manual", ("manual", "site"))
    e_lo, e_hi = (float(min(m.elevation_range)), float(max(m.elevation_range)))
    if sun_mode == "site":
        if site_sun is None:
            raise ParameterError("sun='site' is not available")
        elevation, azimuth = site_sun(query)
    else:
        elevation = _number(query, "elevation", 30.0, -90.0, 90.0, "deg")
        azimuth = _number(query, "azimuth", 180.0, 0.0, 360.0, "deg")
    # the sky model holds no data below its lowest elevation: the explorer refuses to extrapolate
    if elevation < e_lo - 1e-9:
        when = f" at time={query.get('time')!r}" if sun_mode == "site" else ""
        raise ParameterError(f"elevation={elevation:g} deg{when} outside the dataset's range [{e_lo:g}, {e_hi:g}]")
    ranges = {"visibility": (m.visibility_range, "km", 50.0), "albedo": (m.albedo_range, "", 0.2),
              "altitude": (m.altitude_range, "m", 0.0)}
    state = {}
    for name, (rng, unit, default) in ranges.items():
        lo, hi = float(min(rng)), float(max(rng))
        state[name] = _number(query, name, min(max(default, lo), hi), lo, hi, unit)
    quantities = [q for q in QUANTITY_CHOICES if q != "polarisation" or m.has_polarisation]
    return View(
        dataset=di, sun_elevation=float(elevation), sun_azimuth=float(azimuth) % 360.0,
        quantity=_choice(query, "quantity", "sky", quantities),
        channel=_choice(query, "channel", "rgb", channel_names(m)),
        view=_choice(query, "view", "up", VIEW_CHOICES),
        view_azimuth=_number(query, "view_azimuth", 180.0, 0.0, 360.0, "deg"),
        resolution=_number(query, "resolution", 512, 16, MAX_VIEW_RESOLUTION, "pixels", integer=True),
        exposure=_number(query, "exposure", 0.0, -EXPOSURE_EV, EXPOSURE_EV, "EV"),
        surface_tilt=_number(query, "surface_tilt", 35.0, 0.0, 180.0, "deg"),
        surface_azimuth=_number(query, "surface_azimuth", 180.0, 0.0, 360.0, "deg"),
        **state)


def parse_pixel(query):
    """The clicked position ``(u, v)`` in the image, each in [0, 1] (u to the right, v down)."""
    return (_number(query, "u", 0.5, 0.0, 1.0, ""), _number(query, "v", 0.5, 0.0, 1.0, ""))
