"""Settings of :func:`widesky.irradiance.poa_irradiance`, in three small frozen objects.

* :class:`MeasuredSky`: how the sky is scaled to the weather (measured DNI/DHI, the spectral model, or
  explicit per-step factors);
* :class:`OutputOptions`: what is kept and where (memory or an HDF5 file, spectral parts, parts per
  response, a per-chunk consumer, block size, compression, provenance);
* :class:`RunOptions`: how it runs (processes, an executor, progress bars, precomputed coefficients, the
  incidence-angle class nodes of angle x wavelength optics).

Resolution stays in :class:`widesky.irradiance.IntegratorSettings`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, Optional

import numpy as np

from .allsky import AllSkyOptions
from .optics import DEFAULT_NODES

__all__ = ["MeasuredSky", "OutputOptions", "RunOptions", "SPECTRAL_MODELS", "COMPRESSIONS"]

#: Spectral models under measured weather.
SPECTRAL_MODELS = ("clear", "allsky")
#: Compressions of the result file's (T, F) datasets.
COMPRESSIONS = (None, "lzf", "gzip")


@dataclass(frozen=True, eq=False)
class MeasuredSky:
    """How the sky is scaled to the weather.

    Attributes
    ----------
    measured : tuple of array_like or AllSkyWeather, optional
        (dni, dhi): (T,) measured direct normal and diffuse horizontal irradiance [W m-2] (NaN =
        missing: the clear sky is kept); the per-step factors (:func:`widesky.irradiance.measured_scale_factors`
        on the model's own DNI/DHI from the same quadrature) are kept in ``result.scaling``. Not
        together with ``dni_scale``/``diffuse_scale``. With ``spectral_model="allsky"`` it may be an
        :class:`widesky.irradiance.AllSkyWeather` (adds GHI [W m-2], station visibility [km] and dew point [degC]).
    spectral_model : {"clear", "allsky"}
        With ``measured``: "clear" scales the clear sky's spectral and angular shape to the measured
        DNI/DHI [1]; "allsky" uses :mod:`widesky.irradiance.allsky` (per-step, per-channel factors and CIE
        overcast light; the same broadband DNI/DHI, docs/all-sky.md) [1].
    allsky_options : AllSkyOptions, optional
        Switches of the all-sky model (default all parts on) [1].
    dni_scale, diffuse_scale : array_like, optional
        (T,) or (T, C) factors [1] on the sun's direct normal irradiance and on the sky radiance
        ((T, C): per channel, applied to the spectral values before contraction); the reflected
        light follows. Finite and >= 0; their shape is checked against the states by the integrator.
    """

    measured: Any = None
    spectral_model: str = "clear"
    allsky_options: Optional[AllSkyOptions] = None
    dni_scale: Any = None
    diffuse_scale: Any = None

    def __post_init__(self):
        if self.spectral_model not in SPECTRAL_MODELS:
            raise ValueError(f"spectral_model={self.spectral_model!r} is not one of {SPECTRAL_MODELS}")
        if self.measured is not None and (self.dni_scale is not None or self.diffuse_scale is not None):
            raise ValueError("give measured=(dni, dhi) or dni_scale/diffuse_scale, not both")
        if self.spectral_model == "allsky" and self.measured is None:
            raise ValueError("spectral_model='allsky' needs measured=(dni, dhi) or an AllSkyWeather")
        if self.allsky_options is not None and not isinstance(self.allsky_options, AllSkyOptions):
            raise TypeError(f"allsky_options: expected AllSkyOptions, got {type(self.allsky_options).__name__}")


@dataclass(frozen=True, eq=False)
class OutputOptions:
    """What the integrator keeps and where.

    Attributes
    ----------
    path : str or path-like, optional
        HDF5 file the result streams to during the run (written atomically; the returned result
        reads from it). None keeps the result in memory.
    spectral : bool
        Also keep the spectral parts (T, F, C) [W m-2 nm-1] (broadband, no optics; large).
    parts : dict of str to str or sequence of str, optional
        Per response ("broadband" included) the parts to keep, from "direct", "sky_diffuse",
        "ground_diffuse" and "global" (default: the three parts, "global" read as their sum). A
        response kept as ``"global"`` alone is stored as one (T, F) array, the float32 sum of its
        three face-mean parts (the same numbers ``get(name, "global")`` gives from a full run), so
        many responses of which only the total is needed (PV cell currents) cost a third of the
        output; ``get`` of a part not kept is a ValueError. An empty tuple keeps nothing: the
        response is computed only for ``consumer`` (and absent from the result). Responses kept as
        "global" only (or not at all) without an angle x wavelength optic take the fused product:
        sky and reflected light through one matrix per optic, ``X @ (D + R x reflection optic)``,
        averaged over each face's points before the product (equal to the three-part sum within
        float32 rounding: tests/test_poa_parts.py). A response not kept is absent from
        ``result.responses`` (so is "broadband" kept as ``()``: ``poa_global`` ... are then unavailable).
    angles : bool
        Keep the beam's angle of incidence ``"aoi"`` [deg] and the sun visibility ``"sun_visible"`` [1]
        per face and step (default True). False computes neither: they are absent from the result
        (``result.aoi`` is a ValueError) and from a consumer's ``block``; two (T, F) arrays fewer.
    arrays : bool
        Keep the (T, F) arrays in the result (default True). False: the kept parts (and, with ``angles``,
        aoi and sun visibility) are computed block by block into reused buffers for ``consumer`` only
        and the result holds none of them (a reduce-only run, whose memory does not grow with the period:
        e.g. :class:`widesky.irradiance.sink.FaceSums`, per-face period sums [kWh m-2]). Needs a consumer;
        not with ``path`` nor ``spectral``.
    consumer : callable, optional
        Called once per chunk of daylight steps, when the chunk is assembled, as
        ``consumer(steps, block, rows, currents)``: ``steps`` (Tc,) step indices; ``block`` dict key
        -> (n, F) float32 arrays of the current output block (the kept parts as ``(name, part)``,
        ``"aoi"`` [deg] and ``"sun_visible"`` [1] when ``angles``), the chunk's values at rows ``rows`` (Tc,);
        ``currents`` dict name -> :class:`widesky.irradiance.poa.GlobalParts` of every response the fused
        product serves and of every response kept for the consumer only (the fused product's factors, so
        a consumer can use them without a copy; other kept globals are in ``block``). The arrays are
        reused afterwards: a consumer reduces them, it does not keep them (pvsim's yield model uses this
        to never write sub-cell currents). A consumer that takes a keyword ``faces`` is called with the
        slice of faces the arrays' columns hold (a run in blocks of faces, ``RunOptions.face_block``, calls
        it per block); one that does not sees all faces at once (the run is not split).
    block_steps : int, optional
        Steps per output block [steps] (default: a block of about 384 MB), >= 1.
    compression : {None, "lzf", "gzip"}
        Compression of the result file's (T, F) datasets (None: fastest, see
        :mod:`widesky.irradiance.result`).
    provenance : dict, optional
        Extra entries (e.g. the command line) for ``result.provenance``.
    """

    path: Any = None
    spectral: bool = False
    parts: Optional[dict] = None
    angles: bool = True
    arrays: bool = True
    consumer: Optional[Callable] = None
    block_steps: Optional[int] = None
    compression: Optional[str] = None
    provenance: Optional[dict] = None

    def __post_init__(self):
        if self.parts is not None and not isinstance(self.parts, dict):
            raise TypeError(f"parts: expected a dict response name -> parts, got {type(self.parts).__name__}")
        if self.consumer is not None and not callable(self.consumer):
            raise TypeError(f"consumer: expected a callable, got {type(self.consumer).__name__}")
        for name in ("angles", "arrays"):
            if not isinstance(getattr(self, name), (bool, np.bool_)):
                raise TypeError(f"{name}: expected True or False, got {getattr(self, name)!r}")
        if not self.arrays:
            if self.consumer is None:
                raise ValueError("arrays=False keeps no (T, F) arrays: give a consumer that reduces them "
                                 "(e.g. widesky.irradiance.sink.FaceSums)")
            if self.path is not None:
                raise ValueError(f"arrays=False writes no arrays: path={self.path!r} would hold none (leave "
                                 "path unset, or keep arrays=True to stream them there)")
            if self.spectral:
                raise ValueError("arrays=False with spectral=True: the spectral parts are kept only as arrays "
                                 "(keep arrays=True)")
        if self.block_steps is not None and int(self.block_steps) < 1:
            raise ValueError(f"block_steps={self.block_steps} must be >= 1 (steps)")
        if self.compression not in COMPRESSIONS:
            raise ValueError(f"compression={self.compression!r} is not one of {COMPRESSIONS}")
        if self.provenance is not None and not isinstance(self.provenance, dict):
            raise TypeError(f"provenance: expected a dict, got {type(self.provenance).__name__}")


@dataclass(frozen=True, eq=False)
class RunOptions:
    """How the integrator runs.

    Attributes
    ----------
    n_jobs : int, optional
        Ray-casting processes [1] (default all cores), >= 1.
    executor : concurrent.futures.Executor, optional
        Runs the ray-casting tasks (e.g. a Dask client's executor).
    progress : bool
        Progress bars.
    coefficients : Coefficients, optional
        Precomputed for this scene, settings, these states' daylight sun directions and the
        responses' optics.
    optic_nodes : sequence of float
        Incidence-angle class nodes [deg] of angle x wavelength optics (from 0 to 90).
    face_block : int, optional
        Faces per block [faces], >= 1: the rays, products and output of one block of faces at a time, so the
        working memory does not grow with the face count (results identical to one block). Default: one block
        unless its estimated working memory exceeds
        :data:`widesky.irradiance.output_plan.FACE_BLOCK_BYTES` (1 GiB; then blocks of a multiple of 4,096 faces).
        Not with ``coefficients`` (one block); a consumer must take ``faces=`` (see
        :class:`OutputOptions`).
    """

    n_jobs: Optional[int] = None
    executor: Any = None
    progress: bool = False
    coefficients: Any = None
    optic_nodes: Any = DEFAULT_NODES
    face_block: Optional[int] = None

    def __post_init__(self):
        if self.n_jobs is not None and int(self.n_jobs) < 1:
            raise ValueError(f"n_jobs={self.n_jobs} must be >= 1 (processes)")
        if self.face_block is not None and int(self.face_block) < 1:
            raise ValueError(f"face_block={self.face_block} must be >= 1 (faces)")
