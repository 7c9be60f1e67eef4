"""One pipeline from a site or a weather file to per-face spectral irradiance: sky options, their one table of
defaults, the one function that turns a site's period or a weather file into sky states, and :class:`Simulation`.

Every front end (``widesky poa``, ``widesky pv``, ``widesky thermal``, the case runner, the explorer's plane
irradiance) goes through here, so the same weather file gives the same spectra whichever command reads it.

Example::

    import widesky
    import widesky.irradiance as ir
    scene = ir.make_scene("roof.obj")
    sim = widesky.Simulation(scene, weather="data:weather/USA_CO_Denver.Intl.AP.725650_TMY3.epw")  # shipped year
    poa = sim.run()                                  # POAResult, broadband [W m-2]; all-sky spectra (the default)
    print(sim.description)   # "weather file USA_CO_...epw (Denver Intl Ap, USA), all-sky spectra scaled to ..."

Units: visibility [km], albedo [1], angles [deg], irradiance [W m-2] and [W m-2 nm-1].
"""

from __future__ import annotations

import calendar
import dataclasses
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .allsky import AllSkyOptions
from .allsky_sky import AllSkyWeather, weather_measurements
from .integrator import IntegratorSettings
from .location import Site
from .poa import poa_irradiance
from .poa_options import MeasuredSky, OutputOptions, RunOptions
from .skies import PragueSky, SkyStates
from .skystate import sky_states_for
from .weather import WeatherData, WeatherFileError, read_weather

from widesky.core.paths import DATA_PREFIX, data_reference

__all__ = ["SkyOptions", "SKY_DEFAULTS", "DEFAULTS_TABLE", "SkyInput", "sky_input", "Simulation",
           "SPECTRAL_MODELS", "AEROSOL_SOURCES", "GROUND_SPECTRA"]

SPECTRAL_MODELS = ("allsky", "clear")
AEROSOL_SOURCES = ("aod", "visibility")
GROUND_SPECTRA = ("vegetation", "grey")


@dataclass(frozen=True)
class SkyOptions:
    """How a site's period or a weather file becomes sky states and spectra (defaults: :data:`SKY_DEFAULTS`).

    Attributes
    ----------
    spectral_model : {"allsky", "clear"}
        Under a weather file's measured DNI and DHI: "allsky" (default) gives each step the all-sky model's
        spectra (cloud spectra, CIE overcast light, haze below the dataset's visibility; docs/all-sky.md);
        "clear" keeps the clear sky's spectral and angular shape scaled to the measured DNI/DHI. Without a
        weather file the sky is the dataset's clear sky and this is not used.
    aerosol : {"aod", "visibility"}
        Under a weather file: each step's aerosol from its aerosol optical depth column where valid (default;
        station visibility mixes in fog, rain and humid near-surface haze) or from its station visibility.
    visibility : float
        Visibility [km] for a site's period, and where a weather file gives none; > 0.
    albedo : float
        Ground albedo [1] for a site's period, and where a weather file gives none; in [0, 1].
    ground_spectrum : {"vegetation", "grey"}
        With the all-sky model: the spectrum the ground reflects (green vegetation where the albedo is at most
        0.3 and no snow is reported, the broadband albedo kept) or grey.
    use_measured : bool
        Under a weather file: scale to its measured DNI/DHI (default). False keeps the unscaled clear sky of
        the file's steps (an upper bound, labelled so).
    dataset : str or path-like, optional
        PSM dataset file (default: the embedded dataset, or ``WIDESKY_DATASET``).
    """

    spectral_model: str = "allsky"
    aerosol: str = "aod"
    visibility: float = 50.0
    albedo: float = 0.2
    ground_spectrum: str = "vegetation"
    use_measured: bool = True
    dataset: str | None = None

    def __post_init__(self):
        for name, valid in (("spectral_model", SPECTRAL_MODELS), ("aerosol", AEROSOL_SOURCES),
                            ("ground_spectrum", GROUND_SPECTRA)):
            if getattr(self, name) not in valid:
                raise ValueError(f"{name}={getattr(self, name)!r} is not one of {', '.join(valid)}")
        v, a = float(self.visibility), float(self.albedo)
        if not (np.isfinite(v) and v > 0):
            raise ValueError(f"visibility={self.visibility!r} km outside the valid range > 0")
        if not (np.isfinite(a) and 0.0 <= a <= 1.0):
            raise ValueError(f"albedo={self.albedo!r} outside the valid range [0, 1]")

    def replace(self, **changes) -> "SkyOptions":
        """A copy with ``changes``; keys that are None keep the current value."""
        return dataclasses.replace(self, **{k: v for k, v in changes.items() if v is not None})


SKY_DEFAULTS = SkyOptions()
"""The one table of sky defaults: every command, the case files and the Python API start from it."""

DEFAULTS_TABLE = (
    # (option, command-line flag, case-file key, meaning)
    ("spectral_model", "--spectral-model", "sky.spectral_model",
     "spectra under a weather file: all-sky model, or the clear sky scaled to measured DNI/DHI"),
    ("aerosol", "--aerosol", "sky.aerosol", "per-step aerosol from the weather file's AOD or its visibility"),
    ("visibility", "--visibility", "sky.visibility", "visibility [km] without weather, or where it gives none"),
    ("albedo", "--albedo", "sky.albedo", "ground albedo [1] without weather, or where it gives none"),
    ("ground_spectrum", "--ground-spectrum", "sky.ground_spectrum", "what the ground reflects (all-sky model)"),
    ("use_measured", "--clear-sky (sets False)", "sky.use_measured", "scale to the weather's measured DNI/DHI"),
    ("dataset", "--dataset", "sky.dataset", "PSM dataset file (default: the embedded dataset)"),
)
"""Rows of the defaults table in the documentation (docs/guide/concepts.md): option, flag, case key, meaning."""


@dataclass
class SkyInput:
    """Sky states of a run and what the integrator takes from the weather (:func:`sky_input`).

    Attributes
    ----------
    states : SkyStates
        (T,) states: times, mid-interval sun [deg], visibility [km], albedo [1], Earth-Sun distance [AU].
    measured : None, tuple of numpy.ndarray or AllSkyWeather
        What ``MeasuredSky(measured=...)`` takes: None (clear sky), (dni, dhi) (T,) [W m-2], or the
        all-sky model's weather.
    spectral_model : {"clear", "allsky"}
        What the integrator applies ("clear" whenever ``measured`` is not all-sky weather).
    weather : pandas.DataFrame or None
        The weather rows of the steps (temp_air [degC], wind_speed [m s-1], ...), None for a site's period.
    site : Site
    description : str
        For reports and summaries, e.g. "weather file x.epw (Denver), all-sky spectra scaled to measured
        DNI/DHI" or "clear sky (Prague)".
    sky_model : str
        "all-sky", "clear sky scaled to measured DNI/DHI" or "clear sky (an upper bound)".
    label : {"left", "right", "center"}
        What the ``states.times`` label: a site's period "left" (interval starts), a weather file its own
        (EPW, TMY3 "right": interval ends); months and hours go by the interval's start (``interval_starts``).
    """

    states: SkyStates
    measured: object
    spectral_model: str
    weather: object
    site: Site
    description: str
    sky_model: str
    label: str = "left"

    @property
    def times(self):
        return self.states.times


def weather_path(name) -> Path:
    """The file a weather argument names: a path, or ``data:weather/<file>`` (a year shipped in the package, else
    one in the reference data folder); a missing file is a FileNotFoundError naming it."""
    if str(name).startswith(DATA_PREFIX):
        return data_reference(str(name))
    p = Path(name).expanduser()
    if p.is_dir():
        raise IsADirectoryError(f"weather file {str(name)!r} is a folder: give an EPW, TMY3 or CSV weather file "
                                "(or data:weather/<file> for a year shipped with widesky)")
    if not p.is_file():
        raise FileNotFoundError(f"weather file {str(name)!r} not found (a path, or data:weather/<file> for a year "
                                f"shipped with widesky)")
    return p


def _read(path, coerce_year):
    """A weather file, its records moved to ``coerce_year`` when given (typical years mix years)."""
    path = weather_path(path)
    if coerce_year is None:
        return read_weather(path)
    try:
        return read_weather(path, coerce_year=coerce_year)
    except TypeError:                    # a CSV carries its own years
        return read_weather(path)
    except WeatherFileError:
        if calendar.isleap(coerce_year):
            raise ValueError(f"weather {Path(path).name!r}: its records take the year {coerce_year}, a leap "
                             f"year, and the file has no 29 February; choose a period in a common year "
                             f"(e.g. {coerce_year - 1})") from None
        raise


def sky_input(source, start=None, end=None, step="1h", *, options: SkyOptions = SKY_DEFAULTS, model=None,
              coerce_year=None, warn=True) -> SkyInput:
    """Sky states for a site's period (clear sky) or a weather file (measured): the one function every front
    end uses.

    Parameters
    ----------
    source : Site, WeatherData, str or path-like
        A site (``start`` and ``end`` required; the dataset's clear sky at ``options.visibility`` and
        ``options.albedo``) or a weather file (EPW, TMY3, CSV with pvlib names; a path, or
        ``data:weather/<file>`` for a year shipped with widesky) or its data.
    start, end : str or datetime-like, optional
        Period [start, end) in the site's zone; with a weather file, the part of it to run.
    step : str
        Step of a site's period, e.g. "1h", "15min" (a weather file carries its own).
    options : SkyOptions
        Default :data:`SKY_DEFAULTS`.
    model : SkyModel, optional
        The loaded dataset, for its ranges (states outside them are clamped and flagged).
    coerce_year : int, optional
        Move a weather file's records to this year (typical meteorological years mix years).
    warn : bool
        Warn (UserWarning) with the number of clamped steps.

    Returns
    -------
    SkyInput
    """
    if isinstance(source, Site):
        states = sky_states_for(source, start, end, step, model=model, visibility=options.visibility,
                                albedo=options.albedo, warn=warn)
        name = f" ({source.name})" if getattr(source, "name", None) else ""
        return SkyInput(states, None, "clear", None, source, f"clear sky{name}, an upper bound",
                        "clear sky (an upper bound)")
    if isinstance(source, WeatherData):
        wd, label = source, "weather data"
    else:
        wd, label = _read(source, coerce_year), f"weather file {Path(str(source)).name}"
    states = sky_states_for(wd, start, end, model=model, visibility=options.visibility, albedo=options.albedo,
                            prefer=options.aerosol, warn=warn)
    rows = wd.data.loc[states.times]
    model_name = options.spectral_model if options.use_measured else "clear"
    measured, how = weather_measurements(rows, model_name, options.aerosol, not options.use_measured)
    spectral_model = "allsky" if isinstance(measured, AllSkyWeather) else "clear"
    if measured is None:
        how, sky_model = "clear sky, not scaled to the file's DNI/DHI (an upper bound)", "clear sky (an upper bound)"
    elif spectral_model == "clear":
        how, sky_model = "clear-sky spectra " + how, "clear sky scaled to measured DNI/DHI"
    else:
        sky_model = "all-sky"
    where = wd.site.name or f"{wd.site.latitude:.3f}, {wd.site.longitude:.3f}"
    return SkyInput(states, measured, spectral_model, rows, wd.site, f"{label} ({where}), {how}", sky_model,
                    wd.label)


class Simulation:
    """A scene under the sky of a site's period or of a weather file: the pipeline behind every front end.

    Parameters
    ----------
    scene : Scene
        From :func:`widesky.irradiance.make_scene`.
    site : Site, optional
        With ``start`` and ``end``: the dataset's clear sky for every step of the period.
    weather : str, path-like or WeatherData, optional
        A weather file (EPW, TMY3, CSV): its site, steps, aerosol, albedo and measured DNI/DHI (all-sky
        spectra by default, ``sky.spectral_model``). Exactly one of ``site`` and ``weather``.
    start, end : str or datetime-like, optional
        Period [start, end); with ``weather``, the part of the file to run.
    step : str
        Step of a site's period (default "1h").
    sky : SkyOptions
        Default :data:`SKY_DEFAULTS`.
    settings : IntegratorSettings, optional
        Integrator resolution (default ``IntegratorSettings()``; :meth:`IntegratorSettings.for_tolerance`).
    n_jobs : int, optional
        Ray-casting processes (default all cores).
    progress : bool
        Progress bars on long work.
    coerce_year : int, optional
        Move a weather file's records to this year.

    Attributes
    ----------
    sky_source : PragueSky
        The loaded sky model.
    input : SkyInput
        States, measured weather, description.
    """

    def __init__(self, scene, *, site=None, weather=None, start=None, end=None, step="1h",
                 sky: SkyOptions = SKY_DEFAULTS, settings=None, n_jobs=None, progress=False, coerce_year=None,
                 sky_source=None):
        if (site is None) == (weather is None):
            raise ValueError("give exactly one of site= (a clear-sky period) and weather= (a weather file)")
        if site is not None and (start is None or end is None):
            raise ValueError("a site's simulation needs start= and end= (the period)")
        if n_jobs is not None and int(n_jobs) < 1:
            raise ValueError(f"n_jobs={n_jobs} must be >= 1 (processes)")
        if not isinstance(sky, SkyOptions):
            raise TypeError(f"sky must be a SkyOptions, not {type(sky).__name__}")
        self.scene = scene
        self.options = sky
        self.sky_source = sky_source if sky_source is not None else PragueSky(sky.dataset)
        self.settings = settings if settings is not None else IntegratorSettings()
        self.n_jobs = n_jobs
        self.progress = progress
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", UserWarning)
            self.input = sky_input(site if site is not None else weather, start, end, step, options=sky,
                                   model=self.sky_source.model, coerce_year=coerce_year)
        self.warnings = [str(w.message) for w in caught]
        self.sky_source.check_states(self.input.states)

    @property
    def states(self) -> SkyStates:
        return self.input.states

    @property
    def times(self):
        return self.input.states.times

    @property
    def description(self) -> str:
        return self.input.description

    @property
    def allsky_options(self) -> AllSkyOptions:
        return AllSkyOptions(ground=self.options.ground_spectrum)

    def integrator_arguments(self, steps=None) -> dict:
        """Keyword arguments of :func:`widesky.irradiance.poa_irradiance` for this simulation's sky (all steps, or
        ``steps``, a slice or index array): ``states``, ``times``, ``settings``, ``weather``
        (:class:`~widesky.irradiance.poa_options.MeasuredSky`: the measured weather, spectral model and all-sky
        options) and ``run`` (:class:`~widesky.irradiance.poa_options.RunOptions`: ``n_jobs``, ``progress``).
        pvsim and thermal pass them on."""
        st, measured = self.input.states, self.input.measured
        if steps is not None:
            st = st.take(steps)
            if isinstance(measured, AllSkyWeather):
                measured = measured.take(steps)
            elif measured is not None:
                measured = tuple(np.asarray(m)[steps] for m in measured)
        weather = MeasuredSky(measured=measured, spectral_model=self.input.spectral_model,
                              allsky_options=self.allsky_options)
        return dict(states=st, times=st.times, settings=self.settings, weather=weather,
                    run=RunOptions(n_jobs=self.n_jobs, progress=self.progress))

    def run(self, responses=None, *, steps=None, output=None, spectral=False, parts=None, consumer=None,
            provenance=None, **kwargs):
        """Per-face plane-of-array irradiance (:func:`widesky.irradiance.poa_irradiance`).

        Parameters
        ----------
        responses : list of Response, or dict, optional
            Spectral responses (broadband [W m-2] is always computed); ``parts``, ``consumer``, ``output``
            (HDF5 file: ``OutputOptions.path``), ``spectral`` as
            :class:`~widesky.irradiance.poa_options.OutputOptions`.
        steps : slice or array_like, optional
            Run only these steps (e.g. one hour's spectra).
        **kwargs
            Fields of :class:`~widesky.irradiance.poa_options.RunOptions` for this run (e.g. ``progress=False``,
            ``coefficients``).

        Returns
        -------
        POAResult
        """
        args = self.integrator_arguments(steps)
        args["run"] = dataclasses.replace(args["run"], **kwargs)
        prov = {"sky": self.description, **(provenance or {})}
        out = OutputOptions(path=output, spectral=spectral, parts=parts, consumer=consumer, provenance=prov)
        return poa_irradiance(self.scene, self.sky_source, responses=responses, output=out, **args)

    def weather_series(self, column, fallback):
        """(T,) values [column's unit] of a weather column, gaps and a site's period filled by ``fallback``
        (scalar or (T,))."""
        T = len(self.input.states)
        fb = np.broadcast_to(np.asarray(fallback, dtype=float), (T,))
        rows = self.input.weather
        if rows is None or column not in rows:
            return fb.copy()
        v = rows[column].to_numpy(dtype=float)
        return np.where(np.isfinite(v), v, fb)

    def __repr__(self):
        return (f"Simulation({self.scene.n_faces} faces, {len(self.input.states)} steps, "
                f"{self.description})")
