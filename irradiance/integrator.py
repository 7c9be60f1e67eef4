"""Per-face spectral plane-of-array irradiance: geometry once, time series as matrix products.

Method (a daylight-coefficient / "3-phase"-style split; Tregenza & Waters 1983, Reinhart & Herkel 2000):

1. :func:`irradiance.raycast.compute_coefficients` casts rays once per scene (in worker processes,
   while this process evaluates the sky): per analysis point the visibility-weighted projected solid
   angle of every sky patch ``D`` (N, P); reflected-sky coefficients of scene surfaces ``R`` (N, P)
   and of the ground ``A`` (N, P) (each reflecting point's secondary ray samples the sky patch it
   escapes into); the walls' view of the ground ``W`` (N,); the sunlit reflectors per shading cell
   (:func:`irradiance.raycast.shade_cells`) and orientation bin ``R_sun`` (G, N, B) and ``A_sun`` (G, N); sun visibility per sun-position
   bin of about ``sun_bin`` degrees.
2. :func:`patch_radiance` integrates the sky model over each patch per step: a stratified grid of
   directions per patch plus, around the sun, a polar quadrature with logarithmically spaced rings (the
   circumsolar peak), each sample assigned to its patch; the patch radiance is the solid-angle-weighted
   mean. The sun itself is not in any patch: its direct normal irradiance is traced separately.
   Channels are contracted with the response vectors right after each sky evaluation.
3. Per chunk of steps, with ``L`` (P, R) contracted patch radiance, ``E_n`` the contracted direct normal
   irradiance, ``s`` the sun direction and ``a`` the ground albedo:

   * ``poa_direct = E_n * max(0, n . s) * sun_visible``, where ``E_n`` includes the circumsolar excess
     (the sky within ``circumsolar_radius`` of the sun above its value at that radius), as the Perez
     model counts circumsolar light with the beam;
   * ``poa_sky_diffuse = D @ L``;
   * reflected sky ``(R + a A) @ L``; reflected sun ``E_n (R_sun[g] @ max(0, n_b . s) / pi +
     a sin(elevation) A_sun[g] / pi)`` with ``g`` the step's shading cell; ground light passed on
     by walls ``W L_g`` with the unshaded ground radiance ``L_g = a (E_n sin(elevation) + H . L) / pi``;
   * ``poa_ground_diffuse`` is the sum of the reflected terms (pvlib's name for light reflected from
     the surroundings), ``poa_global = poa_direct + poa_sky_diffuse + poa_ground_diffuse``.

Documented approximations: one reflection (off the ground or a scene surface; the ground light a wall
passes on is the unshaded ground's); each reflecting point's sky is a one-sample estimate (unbiased,
its noise averages over the many reflecting points a face sees); the sun on reflectors is one sampled
sun position per reflecting point and shading cell (elevation bands split into azimuth sectors of
30-120 deg), so within a cell the reflected sun follows the cell's mean shading; reflector normals are quantised to 42 bins (about
22 deg) for the sun's cosine; sun visibility of the analysis points per sun-position bin (1 deg:
annual error per face 1.5e-4 mean, 7.5e-3 max on the benchmark scene); the sun is a point.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from .measured import measured_scale_factors
from .patches import SkyPatches, cosine_weights, orthonormal_frame, reinhart
from .raycast import Coefficients, start_coefficients
from .scene import Scene
from .skies import SkyStates

__all__ = ["IntegratorSettings", "patch_radiance", "poa_irradiance", "POAResult",
           "circumsolar_quadrature", "PRESETS", "model_irradiance", "measured_scaling"]


@dataclass(frozen=True)
class IntegratorSettings:
    """Resolution of the integrator.

    Attributes
    ----------
    mf : int
        Reinhart subdivision of the sky (1 = Tregenza 145 patches, 2 = 577, 4 = 2305).
    rays_per_patch : int
        ``k``: k x k rays per patch (and per mirrored ground patch) for occlusion.
    radiance_samples : int
        ``k``: k x k sky-model directions per patch for the patch radiance.
    circumsolar_radius : float
        Radius of the sun-centred polar quadrature [deg].
    circumsolar_rings : int
        Log-spaced circles of nodes of that quadrature (from 0.1 deg to the radius).
    circumsolar_sectors : int
        Azimuth sectors per ring.
    sun_bin : float
        Size of the sun-position bins for sun visibility [deg] (one ray per point and bin, see
        :func:`irradiance.raycast.sun_bins`); 0 casts one ray per point and daylight step.
    time_chunk : int
        Steps per block of the time-series product (bounds memory).
    """

    mf: int = 1
    rays_per_patch: int = 2
    radiance_samples: int = 2
    circumsolar_radius: float = 5.0
    circumsolar_rings: int = 12
    circumsolar_sectors: int = 12
    sun_bin: float = 1.0
    time_chunk: int = 256

    def __post_init__(self):
        for name in ("mf", "rays_per_patch", "radiance_samples", "circumsolar_rings",
                     "circumsolar_sectors", "time_chunk"):
            if int(getattr(self, name)) < 1:
                raise ValueError(f"{name}={getattr(self, name)} must be >= 1")
        if not 0.5 <= self.circumsolar_radius <= 45.0:
            raise ValueError(f"circumsolar_radius={self.circumsolar_radius} deg outside [0.5, 45]")
        if not 0.0 <= self.sun_bin <= 10.0:
            raise ValueError(f"sun_bin={self.sun_bin} deg outside [0, 10]")

    @classmethod
    def for_tolerance(cls, tolerance):
        """The cheapest preset whose measured annual error is below ``tolerance`` [1] (relative).

        The error of a preset is the largest error of a point's annual poa_global on the two
        validation scenes (:func:`irradiance.reference.validation_scenes`) against the brute-force
        reference over an hourly clear-sky year (``docs/irradiance-integrator.md``); other scenes
        can do worse. Valid tolerances are >= the finest preset's bound (0.006).
        """
        tol = float(tolerance)
        for t, s in PRESETS:
            if tol >= t:
                return s
        raise ValueError(f"tolerance={tolerance} below the finest preset's {PRESETS[-1][0]}; "
                         "set IntegratorSettings fields directly")


# (largest annual error of a point measured on the validation scenes, settings), cheapest first:
# the accuracy-vs-speed study of docs/irradiance-integrator.md (benchmarks/bench_poa_accuracy.py,
# hourly clear-sky year, brute-force reference); each bound is the worse of the two skies measured
# (the default dataset; the earlier synthetic placeholder, whose sky was harsher), measured, not
# guaranteed for other scenes.                          default dataset / synthetic placeholder
PRESETS = (
    (0.06, IntegratorSettings(mf=1, rays_per_patch=1)),        # 1.74 % / 5.37 %
    (0.02, IntegratorSettings(mf=1, rays_per_patch=2)),        # 0.94 % / 1.93 % (the default)
    (0.01, IntegratorSettings(mf=1, rays_per_patch=4)),        # 0.37 % / 0.95 %
    (0.0075, IntegratorSettings(mf=2, rays_per_patch=2)),      # 0.46 % / 0.73 %
    (0.006, IntegratorSettings(mf=4, rays_per_patch=2)),       # 0.27 % / 0.53 %
)


def circumsolar_quadrature(radius=10.0, rings=8, sectors=12, inner=0.1):
    """Nodes of the sun-centred polar quadrature: one at the sun, ``sectors`` on each of ``rings``
    log-spaced circles from ``inner`` to ``radius`` [deg] (the outer circle is the disc's edge).

    Returns
    -------
    edges : numpy.ndarray
        (rings + 1,) radii [rad], starting with 0 (the sun).
    r : numpy.ndarray
        (Q,) angular distance of each node from the sun [rad], Q = 1 + rings * sectors.
    theta : numpy.ndarray
        (Q,) position angle [rad].
    """
    edges = np.radians(np.concatenate([[0.0], np.geomspace(min(inner, radius / 4), radius, rings)]))
    t = (np.arange(sectors) + 0.5) * 2 * np.pi / sectors
    r = np.concatenate([[0.0], np.repeat(edges[1:], sectors)])
    th = np.concatenate([[0.0], np.tile(t, rings)])
    return edges, r, th


def _radial_weights(edges, lq, sectors, nodes=6):
    """Node solid angles (T, Q) [sr] of the polar quadrature for radiance profiles ``lq`` (T, Q).

    Between consecutive circles the radiance is interpolated exponentially along each sector (exact
    for an exponential aureole, linear where a value is not positive) and integrated with
    Gauss-Legendre in the angular distance; each interval's integral is split between its two
    nodes in proportion to their interpolation weights, so the weights apply to any channel.
    """
    T = lq.shape[0]
    x, gw = np.polynomial.legendre.leggauss(nodes)
    u = 0.5 * (x + 1.0)
    n_r = edges.size - 1
    centre = lq[:, :1]                                                    # (T, 1)
    ring = lq[:, 1:].reshape(T, n_r, sectors)
    inner = np.concatenate([np.broadcast_to(centre[:, :, None], (T, 1, sectors)), ring[:, :-1]], 1)
    a, b = edges[:-1], edges[1:]                                          # (n_r,)
    g = a[:, None] + (b - a)[:, None] * u[None, :]                        # (n_r, nodes)
    jac = (b - a)[:, None] * 0.5 * gw[None, :] * np.sin(g) * (2 * np.pi / sectors)
    pos = (inner > 0) & (ring > 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(pos, ring / np.where(pos, inner, 1.0), 1.0)
        # interpolated value relative to the linear blend: L(u) = La (Lb/La)^u
        expo = ratio[..., None] ** u                                      # (T, n_r, S, nodes)
    lin_a, lin_b = 1.0 - u, u
    la = np.where(pos, inner, 1.0)[..., None]
    # exponential profile: int L (1-u) ..., int L u ... divided by La, Lb
    wa_exp = np.sum(expo * lin_a * jac[None, :, None, :], axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        wb_exp = np.sum(expo * lin_b * jac[None, :, None, :], axis=-1) / np.where(pos, ratio, 1.0)
    wa_lin = np.sum(lin_a * jac, axis=-1)[None, :, None]
    wb_lin = np.sum(lin_b * jac, axis=-1)[None, :, None]
    # an exponential through La, Lb splits as (int L(1-u))/La and (int L u)/Lb; normalise so that
    # wa*La + wb*Lb equals the exponential integral exactly
    total = np.sum(expo * jac[None, :, None, :], axis=-1) * la[..., 0]
    part = wa_exp * la[..., 0] + wb_exp * ring
    with np.errstate(divide="ignore", invalid="ignore"):
        fix = np.where(part > 0, total / part, 1.0)
    wa = np.where(pos, wa_exp * fix, wa_lin)
    wb = np.where(pos, wb_exp * fix, wb_lin)
    w = np.zeros_like(lq)
    w[:, 0] = wa[:, 0].sum(axis=1)
    wr = wb.copy()
    wr[:, :-1] += wa[:, 1:]
    w[:, 1:] = wr.reshape(T, -1)
    return w


def patch_radiance(sky, patches: SkyPatches, states: SkyStates, weights=None, settings=None):
    """Mean sky radiance over every patch per step, the circumsolar peak split off, channels contracted.

    Inside ``circumsolar_radius`` of the sun the sky is split into ``min(L, L_edge)`` (``L_edge``: the
    radiance on the disc's edge) and the circumsolar excess ``max(L - L_edge, 0)``. The excess is
    integrated with a sun-centred polar quadrature (log-spaced circles, exponential interpolation
    between them) and returned separately, to be traced with the sun, so its steep gradient is not
    smeared over a patch whose cosine weight and visibility can differ from the sun's. The remaining
    smooth sky is averaged over each patch from ``k x k`` stratified directions (equal solid angles).

    Parameters
    ----------
    sky : sky source
        See :mod:`irradiance.skies` (``radiance``, ``direct_normal``, ``n_channels``).
    patches : SkyPatches
        The sky discretisation.
    states : SkyStates
        T sky states.
    weights : array_like, optional
        (C, R) contraction matrix applied to the channels; default identity (R = C).
    settings : IntegratorSettings, optional
        Sample counts.

    Returns
    -------
    radiance : numpy.ndarray
        (T, P, R) patch-mean radiance contracted with ``weights`` [W m-2 sr-1 nm-1 times the weights'
        unit].
    direct_normal : numpy.ndarray
        (T, R) sun direct normal irradiance contracted with ``weights``.
    circumsolar : numpy.ndarray
        (T, R) circumsolar normal irradiance: the sky radiance within ``circumsolar_radius`` of the
        sun in excess of its value at that radius, integrated over the disc (above the horizon), to be
        traced like the sun (as the Perez model treats circumsolar light); zero with the sun below the
        horizon.
    """
    settings = settings or IntegratorSettings()
    C = sky.n_channels
    W = np.eye(C) if weights is None else np.asarray(weights, dtype=float)
    if W.shape[0] != C:
        raise ValueError(f"weights has {W.shape[0]} rows for a sky of {C} channels")
    P, T = patches.n_patches, len(states)
    reg_d, reg_w = patches.subsample(settings.radiance_samples)
    reg_p = np.repeat(np.arange(P), reg_d.shape[1])
    reg_d, reg_w = reg_d.reshape(-1, 3), reg_w.reshape(-1)
    edges, r, th = circumsolar_quadrature(settings.circumsolar_radius, settings.circumsolar_rings,
                                          settings.circumsolar_sectors)
    cos_rad = np.cos(np.radians(settings.circumsolar_radius))
    s = states.sun_direction
    u, v = orthonormal_frame(s)
    qd = (np.cos(r)[None, :, None] * s[:, None, :]
          + (np.sin(r) * np.cos(th))[None, :, None] * u[:, None, :]
          + (np.sin(r) * np.sin(th))[None, :, None] * v[:, None, :])           # (T, Q, 3)
    qp = patches.index(qd)
    above = qp >= 0
    qd[~above] = (0.0, 0.0, 1.0)
    qp = np.maximum(qp, 0)
    inside = (s @ reg_d.T) > cos_rad                                         # (T, n_reg + P)
    dirs = np.concatenate([np.broadcast_to(reg_d, (T,) + reg_d.shape), qd], axis=1)
    L = sky.radiance(dirs, states) @ W                                       # (T, Nd, R)
    R = W.shape[1]
    nr = reg_p.size
    Lq = L[:, nr:]
    Lq[~above] = 0.0
    # node solid angles from the first response column's radial profile (nodes below the horizon
    # carry no sky)
    qwt = _radial_weights(edges, Lq[..., 0], settings.circumsolar_sectors) * above
    # split the sky inside the disc into min(L, L_edge) (smooth, left to the patches) and the
    # circumsolar excess (to the sun); L_edge is the mean of the outer circle's nodes above the horizon
    ns = settings.circumsolar_sectors
    w_out = above[:, -ns:].astype(float)
    has_edge = (w_out.sum(axis=1) > 0) & (states.sun_elevation > 0)
    with np.errstate(invalid="ignore", divide="ignore"):
        l_edge = np.einsum("tq,tqr->tr", w_out, Lq[:, -ns:]) / w_out.sum(axis=1)[:, None]
    l_edge[~has_edge] = np.inf
    circumsolar = np.einsum("tq,tqr->tr", qwt, np.maximum(Lq - l_edge[:, None, :], 0.0))
    Lr = L[:, :nr]
    Lr = np.where(inside[..., None], np.minimum(Lr, l_edge[:, None, :]), Lr)
    # patch mean of the capped sky from the stratified samples
    flat = (np.arange(T)[:, None] * P + reg_p[None, :]).ravel()
    wts = np.broadcast_to(reg_w, (T, nr))
    den = np.bincount(flat, weights=wts.ravel(), minlength=T * P)
    wl = (wts[..., None] * Lr).reshape(-1, R)
    num = np.stack([np.bincount(flat, weights=wl[:, j], minlength=T * P) for j in range(R)], 1)
    out = (num / den[:, None]).reshape(T, P, R)
    dni = np.asarray(sky.direct_normal(states), dtype=float) @ W
    return out, dni, circumsolar


def _horizontal_diffuse(patch_radiance, circumsolar, w_horizontal, sun_elevation):
    """(T,) diffuse horizontal irradiance [W m-2] from (T, P) broadband patch radiance, (T,)
    circumsolar normal irradiance, (P,) horizontal cosine weights [sr] and sun elevations [deg]."""
    return patch_radiance @ w_horizontal + circumsolar * np.sin(np.radians(sun_elevation))


def model_irradiance(sky, states: SkyStates, settings=None, chunk: int = 256):
    """Broadband direct normal and diffuse horizontal irradiance of the sky model per step.

    Integrated with the integrator's own quadrature (patch means of ``reinhart(settings.mf)`` times
    their exact horizontal cosine weights, plus the circumsolar disc at the sun's cosine), so the
    clear-sky values that :func:`measured_scaling` divides by are the ones
    :func:`poa_irradiance` reproduces on an unobstructed horizontal face.

    Parameters
    ----------
    sky : sky source
        See :mod:`irradiance.skies`.
    states : SkyStates
        T sky states.
    settings : IntegratorSettings, optional
        Quadrature; default ``IntegratorSettings()``.
    chunk : int
        Steps per sky evaluation (bounds memory).

    Returns
    -------
    dni, dhi : numpy.ndarray
        (T,) [W m-2], summed over the sky's channels; 0 with the sun at or below the sky's lowest
        elevation.
    """
    settings = settings or IntegratorSettings()
    patches = reinhart(settings.mf)
    w_h = cosine_weights(patches, np.array([[0.0, 0.0, 1.0]]))[0]                # (P,) [sr]
    widths = np.asarray(sky.channel_widths, dtype=float)[:, None]              # (C, 1) [nm]
    T = len(states)
    dni, dhi = np.zeros(T), np.zeros(T)
    lit = np.nonzero(states.sun_elevation > getattr(sky, "min_sun_elevation", 0.0))[0]
    for c0 in range(0, lit.size, max(int(chunk), 1)):
        idx = lit[c0:c0 + chunk]
        st = states.take(idx)
        Lp, dn, cs = patch_radiance(sky, patches, st, widths, settings)
        dni[idx] = dn[:, 0]
        dhi[idx] = _horizontal_diffuse(Lp[..., 0], cs[:, 0], w_h, st.sun_elevation)
    return dni, dhi


def measured_scaling(sky, states: SkyStates, dni, dhi, settings=None, **kwargs):
    """Per-step factors that make the clear-sky model reproduce measured DNI and DHI.

    :func:`model_irradiance` gives the model's values, :func:`irradiance.measured_scale_factors`
    the factors (keyword arguments go to it: floors, cap, ``missing``). Pass ``sun_scale`` and
    ``sky_scale`` to :func:`poa_irradiance` as ``dni_scale`` and ``diffuse_scale``.

    Parameters
    ----------
    dni, dhi : array_like
        (T,) measured direct normal and diffuse horizontal irradiance [W m-2] (NaN = missing).

    Returns
    -------
    scaling : MeasuredScaling
        Factors [1], guard flags and unmatched irradiance [W m-2] per step.
    model : tuple of numpy.ndarray
        (model_dni, model_dhi) [W m-2] the factors divide by.
    """
    mdni, mdhi = model_irradiance(sky, states, settings)
    return measured_scale_factors(mdni, mdhi, dni, dhi, **kwargs), (mdni, mdhi)


@dataclass(eq=False)
class POAResult:
    """Plane-of-array irradiance per analysis face and step (arrays shaped (T, F), time first).

    Attributes
    ----------
    poa_global, poa_direct, poa_sky_diffuse, poa_ground_diffuse : numpy.ndarray
        Broadband (channel-integrated, 280-2480 nm for the PSM) irradiance [W m-2];
        ``poa_ground_diffuse`` holds all reflected light (ground and scene surfaces).
    effective_irradiance : dict of str to numpy.ndarray
        Global irradiance weighted by each response: ``sum_c SR_c E_c dlambda_c`` [W m-2].
    spectral : numpy.ndarray or None
        (T, F, C) spectral global irradiance [W m-2 nm-1] when requested.
    wavelengths : numpy.ndarray
        (C,) channel centres [nm].
    times : pandas.DatetimeIndex or None
        The steps.
    face_area : numpy.ndarray
        (F,) [m2].
    face_group : numpy.ndarray
        (F,) group index.
    group_names : tuple of str
    timings : dict
        Wall seconds per phase and counts: ``rays`` (from submitting the ray-casting tasks until
        their results are in; the sky evaluation of the first chunks runs meanwhile in this
        process, ``sky_during_rays`` seconds of it), ``sky`` (all sky-model evaluation),
        ``product``, ``total``; ``n_rays``, ``sun_bins`` (sun rays per point), ``steps``,
        ``lit_steps``.
    scaling : MeasuredScaling or None
        With ``measured``: per-step factors, guard flags and unmatched irradiance (night steps:
        factor 1).
    """

    poa_global: np.ndarray
    poa_direct: np.ndarray
    poa_sky_diffuse: np.ndarray
    poa_ground_diffuse: np.ndarray
    effective_irradiance: dict
    spectral: object
    wavelengths: np.ndarray
    times: object
    face_area: np.ndarray
    face_group: np.ndarray
    group_names: tuple
    timings: dict = field(default_factory=dict)
    scaling: object = None

    QUANTITIES = ("poa_global", "poa_direct", "poa_sky_diffuse", "poa_ground_diffuse")

    def aggregate(self):
        """Area-weighted means per face group.

        Returns
        -------
        dict
            ``"area"``: (G,) group areas [m2]; each of ``poa_global``, ``poa_direct``,
            ``poa_sky_diffuse``, ``poa_ground_diffuse`` and ``effective_irradiance:<name>``: (T, G)
            area-weighted mean irradiance [W m-2] (multiply by ``area`` for power [W]).
        """
        G = len(self.group_names)
        M = np.zeros((self.face_area.size, G))
        M[np.arange(self.face_area.size), self.face_group] = self.face_area
        area = M.sum(axis=0)
        Mn = M / np.where(area > 0, area, 1.0)
        out = {"area": area}
        for q in self.QUANTITIES:
            out[q] = getattr(self, q) @ Mn
        for k, v in self.effective_irradiance.items():
            out[f"effective_irradiance:{k}"] = v @ Mn
        return out

    def to_dataframe(self, face=0):
        """pandas DataFrame of one face's series with pvlib column names [W m-2]."""
        import pandas as pd
        data = {q: getattr(self, q)[:, face] for q in self.QUANTITIES}
        for k, v in self.effective_irradiance.items():
            data[f"effective_irradiance_{k}"] = v[:, face]
        return pd.DataFrame(data, index=self.times)


def _lazy_zeros(shape, dtype):
    """A zero array; large ones live in anonymous memory mapped page by page on first write.

    numpy asks the kernel for transparent huge pages on large allocations, and on systems with
    ``defrag=madvise`` faulting in gigabytes of them can stall for seconds in memory compaction
    (measured: 0.2 s vs 2.3 s for 350 MB). Night steps of a (T, F) output are never written, so
    their pages are never touched.
    """
    shape = tuple(int(x) for x in shape)
    nbytes = int(np.prod(shape)) * np.dtype(dtype).itemsize
    if nbytes < (64 << 20):
        return np.zeros(shape, dtype=dtype)
    import mmap
    return np.frombuffer(mmap.mmap(-1, nbytes), dtype=dtype).reshape(shape)


def _responses(sky, responses):
    C = sky.n_channels
    names, rows = ["broadband"], [np.ones(C)]
    for name, sr in (responses or {}).items():
        a = np.asarray(sr, dtype=float)
        if a.shape != (C,) or not np.all(np.isfinite(a)):
            raise ValueError(f"response {name!r} must be finite with shape ({C},), got {a.shape}")
        names.append(str(name))
        rows.append(a)
    return names, np.array(rows)


def poa_irradiance(scene: Scene, sky, states: SkyStates, *, responses=None, spectral=False,
                   settings=None, dni_scale=None, diffuse_scale=None, measured=None, times=None,
                   n_jobs=None,
                   executor=None, progress=False, coefficients=None, dtype=np.float32):
    """Plane-of-array irradiance on every analysis face for a series of sky states.

    Parameters
    ----------
    scene : Scene
        From :func:`irradiance.scene.make_scene`.
    sky : sky source
        :class:`irradiance.skies.PragueSky`, :class:`~irradiance.skies.UniformSky` ...
    states : SkyStates
        T per-step sky states (sun elevation/azimuth [deg], visibility [km], albedo [1], altitude [m]).
    responses : dict of str to array_like, optional
        Response vectors (C,) [1] (cell spectral response, glazing transmittance ...) per channel of
        the sky; each gives ``effective_irradiance[name]`` [W m-2]. Channels are contracted with them
        before the large products.
    spectral : bool
        Also return the spectral global irradiance (T, F, C) [W m-2 nm-1] (large: T x F x C).
    settings : IntegratorSettings, optional
        Resolution; default ``IntegratorSettings()`` (annual error measured against the
        brute-force reference with the default dataset: 0.13 % on an unobstructed plane, up to
        0.94 % per point on an obstructed facade; see docs).
    dni_scale, diffuse_scale : array_like, optional
        (T,) factors [1] on the sun's direct normal irradiance and on the sky radiance per step (to
        match measured DNI / DHI); the ground and obstruction light follow.
    measured : tuple of array_like, optional
        (dni, dhi): (T,) measured direct normal and diffuse horizontal irradiance [W m-2] (NaN =
        missing: the clear sky is kept). The factors are computed per step from the model's own
        DNI and DHI with the same quadrature (:func:`model_irradiance`, no second sky
        evaluation) by :func:`irradiance.measured_scale_factors` and kept in ``result.scaling``.
        Not together with ``dni_scale``/``diffuse_scale``.
    times : pandas.DatetimeIndex, optional
        Labels kept on the result.
    n_jobs : int, optional
        Ray-casting processes (default all cores).
    executor : concurrent.futures.Executor, optional
        Runs the ray-casting tasks (e.g. a Dask client's executor).
    progress : bool
        Progress bars.
    coefficients : Coefficients, optional
        Precomputed for this scene, settings and these states' daylight sun directions.
    dtype : numpy dtype
        Output dtype (default float32).

    Returns
    -------
    POAResult
    """
    t_start = time.perf_counter()
    settings = settings or IntegratorSettings()
    T = len(states)
    names, Rmat = _responses(sky, responses)
    R = len(names)
    C = sky.n_channels
    widths = np.diff(np.asarray(sky.channel_edges, dtype=float))
    W = (Rmat * widths[None, :]).T                                          # (C, R): W m-2
    cols = [W]
    if spectral:
        cols.append(np.eye(C))
    ga = scene.ground_albedo
    spectral_ground = ga is not None and np.ndim(ga) == 1
    if spectral_ground:
        if np.shape(ga) != (C,):
            raise ValueError(f"ground_albedo has {np.shape(ga)[0]} channels, the sky {C}")
        cols.append(np.asarray(ga)[:, None] * W)
    Wall = np.concatenate(cols, axis=1)
    scale_d = np.ones(T) if dni_scale is None else np.broadcast_to(np.asarray(dni_scale, float), (T,))
    scale_s = (np.ones(T) if diffuse_scale is None
               else np.broadcast_to(np.asarray(diffuse_scale, float), (T,)))
    for name, v in (("dni_scale", scale_d), ("diffuse_scale", scale_s)):
        if np.any(~np.isfinite(v)) or np.any(v < 0):
            raise ValueError(f"{name} must be finite and >= 0")
    scaling = None
    if measured is not None:
        if dni_scale is not None or diffuse_scale is not None:
            raise ValueError("give measured=(dni, dhi) or dni_scale/diffuse_scale, not both")
        m_dni, m_dhi = (np.broadcast_to(np.asarray(a, dtype=float), (T,)) for a in measured)
        measured_scale_factors(np.ones(T), np.ones(T), m_dni, m_dhi)     # validates the inputs
        scale_d, scale_s = np.ones(T), np.ones(T)
        model_dni, model_dhi = np.zeros(T), np.zeros(T)

    patches = reinhart(settings.mf)
    w_horizontal = cosine_weights(patches, np.array([[0.0, 0.0, 1.0]]))[0]      # (P,) [sr]
    el = states.sun_elevation
    lit = np.nonzero(el > getattr(sky, "min_sun_elevation", 0.0))[0]
    up = el > 0
    sun_rank = np.cumsum(up) - 1
    sun_dirs = states.sun_direction[up]
    pending = None
    if coefficients is None:
        # the ray-casting tasks run in worker processes while this process evaluates the sky
        pending = start_coefficients(scene, mf=settings.mf, rays_per_patch=settings.rays_per_patch,
                                     sun_directions=sun_dirs, sun_bin=settings.sun_bin,
                                     n_jobs=n_jobs, executor=executor, progress=progress)

    # steps sorted by sky state, so that sources that share work between equal states (PragueSky
    # groups equal elevations) see them in the same chunk
    key_el = np.round(el[lit], 1)
    lit = lit[np.lexsort((states.albedo[lit], states.visibility[lit], key_el))]
    chunk_idx = [np.sort(lit[c0:c0 + settings.time_chunk])
                 for c0 in range(0, lit.size, settings.time_chunk)]
    t_sky = 0.0

    def sky_chunk(idx):
        nonlocal t_sky
        t0 = time.perf_counter()
        st = states.take(idx)
        Lp, dni, cs = patch_radiance(sky, patches, st, Wall, settings)     # (Tc,P,R'), (Tc,R')
        if measured is not None:                   # column 0 is broadband: the model's DNI, DHI
            model_dni[idx] = dni[:, 0]
            model_dhi[idx] = _horizontal_diffuse(Lp[..., 0], cs[:, 0], w_horizontal, st.sun_elevation)
            f = measured_scale_factors(model_dni[idx], model_dhi[idx], m_dni[idx], m_dhi[idx],
                                       missing="clear")
            scale_d[idx], scale_s[idx] = f.sun_scale, f.sky_scale
        # circumsolar light travels with the sun but is sky light: it takes the sky's scale
        dni = dni * scale_d[idx][:, None] + cs * scale_s[idx][:, None]
        Lp *= scale_s[idx][:, None, None]
        t_sky += time.perf_counter() - t0
        return Lp, dni

    # evaluate the sky ahead (overlapping the ray casting) while it fits a memory budget
    sky_ahead = []
    budget = 256 << 20
    if pending is not None and pending._futs is not None:
        per_step = patches.n_patches * Wall.shape[1] * 8
        n_ahead = min(len(chunk_idx), max(0, budget // max(per_step * settings.time_chunk, 1)))
        sky_ahead = [sky_chunk(idx) for idx in chunk_idx[:n_ahead]]
    t_sky_ahead = t_sky
    if pending is not None:
        coefficients = pending.result()
    cf: Coefficients = coefficients
    if cf.sky.shape != (scene.n_points, patches.n_patches) or cf.n_sun != sun_dirs.shape[0]:
        raise ValueError("coefficients do not match this scene, settings and states")
    t_rays = time.perf_counter()

    F, k, N = scene.n_faces, scene.samples_per_face, scene.n_points
    P = patches.n_patches
    # sky: D (N, P); reflected sky: scene surfaces R (N, P) and ground A (N, P) (times the albedo:
    # folded into R when it is one value for all steps); reflected ground light off walls (N,);
    # reflected sun per shading cell (G, B+1, N)
    D_T = np.ascontiguousarray(cf.sky.T, dtype=np.float32)                   # (P, N)
    alb_lit = states.albedo[lit]
    if ga is not None and np.ndim(ga) == 0:
        fold = float(ga)
    elif ga is None and (alb_lit.size == 0 or np.all(alb_lit == alb_lit[0])):
        fold = float(alb_lit[0]) if alb_lit.size else 0.0
    else:
        fold = None
    if fold is not None:
        R_T = np.ascontiguousarray((cf.reflect_sky + fold * cf.ground_sky).T, dtype=np.float32)
        A_T = None
    else:
        R_T = np.ascontiguousarray(cf.reflect_sky.T, dtype=np.float32)
        A_T = np.ascontiguousarray(cf.ground_sky.T, dtype=np.float32)
    wall_ground = cf.reflect_ground.astype(np.float32)                      # (N,)
    Ksun_T = np.ascontiguousarray(np.concatenate(
        [cf.reflect_sun / np.pi, cf.ground_sun[:, :, None]], axis=2).transpose(0, 2, 1),
        dtype=np.float32)                                                   # (G, B+1, N)
    normals_T = np.ascontiguousarray(scene.point_normal.T.astype(np.float32))     # (3, N)
    Hb = patches.vector[:, 2]
    sun_vis = cf.sun_visibility_bins()                                      # (S_b, N) bool
    sun_bin_of = (np.arange(cf.n_sun) if cf.sun_index is None else cf.sun_index)

    out = {q: _lazy_zeros((T, F), dtype) for q in POAResult.QUANTITIES}
    eff = {n: _lazy_zeros((T, F), dtype) for n in names[1:]}
    spec = _lazy_zeros((T, F, C), dtype) if spectral else None
    t_prod = 0.0
    chunks = range(len(chunk_idx))
    if progress:
        from tqdm.auto import tqdm
        chunks = tqdm(chunks, unit="chunk", desc="time series")

    def faces(a):                                  # (..., N) -> (..., F) mean over a face's points
        return a if k == 1 else a.reshape(a.shape[:-1] + (F, k)).mean(axis=-1)

    Rp_all = Wall.shape[1] - (R if spectral_ground else 0)
    Tmax = settings.time_chunk
    # work buffers reused by every chunk (fresh multi-MB temporaries per chunk are slow to fault in)
    buf_sky = _lazy_zeros((Tmax * Rp_all, N), np.float32)
    buf_refl = _lazy_zeros((Tmax * Rp_all, N), np.float32)
    buf_aux = _lazy_zeros((Tmax * Rp_all, N), np.float32)
    buf_beam = _lazy_zeros((Tmax, N), np.float32)
    buf_tmp = _lazy_zeros((Tmax, N), np.float32)
    for ci in chunks:
        idx = chunk_idx[ci]
        Lp, dni = sky_ahead[ci] if ci < len(sky_ahead) else sky_chunk(idx)
        if ci < len(sky_ahead):
            sky_ahead[ci] = None
        t1 = time.perf_counter()
        Tc = idx.size
        st = states.take(idx)
        s = st.sun_direction
        sin_el = np.maximum(s[:, 2], 0.0)
        Hs = np.einsum("tpr,p->tr", Lp, Hb)                                  # (Tc, R') sky GHI
        Hd = dni * sin_el[:, None]                                           # sun GHI
        if spectral_ground:                        # the last R columns are albedo-weighted
            g_sky, g_sun = Hs[:, -R:] / np.pi, Hd[:, -R:] / np.pi
            Lp_alb = Lp[..., -R:]
            Lp, dni, Hs, Hd = Lp[..., :-R], dni[:, :-R], Hs[:, :-R], Hd[:, :-R]
            if spectral:
                gac = np.asarray(ga)[None, :]
                g_sky = np.concatenate([g_sky, gac * Hs[:, R:] / np.pi], axis=1)
                g_sun = np.concatenate([g_sun, gac * Hd[:, R:] / np.pi], axis=1)
                Lp_alb = np.concatenate([Lp_alb, gac[:, None, :] * Lp[..., R:]], axis=2)
        else:
            alb = (st.albedo if ga is None else np.full(Tc, float(ga)))[:, None]
            g_sky, g_sun = alb * Hs / np.pi, alb * Hd / np.pi               # (Tc, R')
        Lg = g_sky + g_sun                         # unshaded ground radiance
        Rp = Lp.shape[2]                           # R (+ C spectral)
        cos_b = np.maximum(s @ cf.bins.T, 0.0)                               # (Tc, B)
        Xs = np.ascontiguousarray(Lp.transpose(0, 2, 1).reshape(Tc * Rp, P), dtype=np.float32)
        sky_all = np.matmul(Xs, D_T, out=buf_sky[:Tc * Rp]).reshape(Tc, Rp, N)
        refl_all = np.matmul(Xs, R_T, out=buf_refl[:Tc * Rp]).reshape(Tc, Rp, N)
        if A_T is not None:                        # the ground's albedo changes between steps
            if spectral_ground:
                Xa = Lp_alb
            else:
                Xa = alb[:, :, None] * Lp
            Xa = np.ascontiguousarray(Xa.transpose(0, 2, 1).reshape(Tc * Rp, P), dtype=np.float32)
            refl_all += np.matmul(Xa, A_T, out=buf_aux[:Tc * Rp]).reshape(Tc, Rp, N)
        Lg32 = Lg.astype(np.float32)
        for r in range(Rp):                        # walls pass on the unshaded ground's light
            refl_all[:, r] += np.multiply(Lg32[:, r:r + 1], wall_ground, out=buf_tmp[:Tc])
        # reflected sun, per shading cell with that cell's sunlit reflector coefficients
        band = np.full(Tc, -1)
        band[up[idx]] = cf.step_band(sun_rank[idx[up[idx]]])
        for g in np.unique(band[band >= 0]):
            rows = np.nonzero(band == g)[0]
            Xu = np.concatenate([dni[rows, None, :] * cos_b[rows, :, None],
                                 g_sun[rows, None, :]], axis=1)              # (Tg, B+1, R')
            Xu = np.ascontiguousarray(Xu.transpose(0, 2, 1).reshape(rows.size * Rp, -1),
                                      dtype=np.float32)
            refl_all[rows] += np.matmul(Xu, Ksun_T[g], out=buf_aux[:rows.size * Rp]).reshape(
                rows.size, Rp, N)
        out["poa_sky_diffuse"][idx] = faces(sky_all[:, 0])
        out["poa_ground_diffuse"][idx] = faces(refl_all[:, 0])
        diffuse = sky_all
        diffuse += refl_all                                                  # sky + reflected
        # direct: E_n max(0, n . s) v, v from the step's sun-position bin
        beam = buf_beam[:Tc]
        beam[:] = 0.0
        upc = np.nonzero(up[idx])[0]
        if upc.size:
            cosi = np.matmul(s[upc].astype(np.float32), normals_T, out=buf_tmp[:upc.size])
            np.maximum(cosi, 0.0, out=cosi)
            cosi *= sun_vis[sun_bin_of[sun_rank[idx[upc]]]]
            beam[upc] = cosi
        dni32 = dni.astype(np.float32)
        tmp = buf_tmp[:Tc]
        np.multiply(dni32[:, :1], beam, out=tmp)
        out["poa_direct"][idx] = faces(tmp)
        tmp += diffuse[:, 0]
        out["poa_global"][idx] = faces(tmp)
        for j, n in enumerate(names[1:], start=1):
            np.multiply(dni32[:, j:j + 1], beam, out=tmp)
            tmp += diffuse[:, j]
            eff[n][idx] = faces(tmp)
        if spectral:
            glob = diffuse[:, R:R + C] + dni32[:, R:R + C, None] * beam[:, None, :]
            spec[idx] = faces(glob).transpose(0, 2, 1)
        t_prod += time.perf_counter() - t1
    invalid = ~scene.face_valid
    if np.any(invalid):
        for a in list(out.values()) + list(eff.values()):
            a[:, invalid] = 0
        if spec is not None:
            spec[:, invalid] = 0
    timings = {"rays": (t_rays - t_start) if pending is not None else 0.0,
               "sky_during_rays": t_sky_ahead, "n_rays": cf.n_rays, "sun_bins": cf.n_sun_bins,
               "sky": t_sky, "product": t_prod, "total": time.perf_counter() - t_start,
               "steps": T, "lit_steps": int(lit.size)}
    if measured is not None:
        dark = np.ones(T, dtype=bool)
        dark[lit] = False
        f = measured_scale_factors(model_dni, model_dhi, m_dni, m_dhi, missing="clear")
        scaling = f._replace(sun_scale=scale_d, sky_scale=scale_s, sun_guarded=f.sun_guarded & ~dark,
                             sky_guarded=f.sky_guarded & ~dark)
    return POAResult(scaling=scaling, effective_irradiance=eff, spectral=spec,
                     wavelengths=np.asarray(sky.wavelengths, dtype=float), times=times,
                     face_area=scene.face_area, face_group=scene.face_group,
                     group_names=scene.group_names, timings=timings, **out)
