"""Per-face spectral plane-of-array irradiance: geometry once, time series as matrix products.

Method (a daylight-coefficient / "3-phase"-style split; Tregenza & Waters 1983, Reinhart & Herkel 2000):

1. :func:`widesky.irradiance.raycast.compute_coefficients` casts rays once per scene (in worker processes,
   while this process evaluates the sky): per analysis point the visibility-weighted projected solid
   angle of every sky patch ``D`` (N, P); reflected-sky coefficients of scene surfaces ``R`` (N, P)
   and of the ground ``A`` (N, P) (each reflecting point's secondary ray samples the sky patch it
   escapes into); the walls' view of the ground ``W`` (N,); the sunlit reflectors per shading cell
   (:func:`widesky.irradiance.raycast.shade_cells`) and orientation bin ``R_sun`` (G, N, B) and ``A_sun`` (G, N); sun visibility per sun-position
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
     a sin(elevation) A_sun[g] / pi)`` with ``g`` the step's shading cell; the ground light walls pass
     on is in ``A`` and ``A_sun`` (the ground point a wall's secondary ray reaches is traced to the sky and
     the sun like the ground the face sees; ``W`` is 0 since issue 39);
   * ``poa_ground_diffuse`` is the sum of the reflected terms (pvlib's name for light reflected from
     the surroundings), ``poa_global = poa_direct + poa_sky_diffuse + poa_ground_diffuse``.

Documented approximations: reflections to a fixed depth (``IntegratorSettings.reflections``, default 3; 1 is
one reflection off the ground or a scene surface plus the ground light a wall passes on), the ground's albedo
applied per step to a path's first ground reflection and a nominal albedo to its later ones; each reflecting
point's sky is a one-sample estimate (unbiased, its noise averages over the many reflecting points a face
sees); the sun on reflectors is one sampled sun position per reflecting point and shading cell (elevation bands
split into azimuth sectors of 30-120 deg), so within a cell the reflected sun follows the cell's mean shading;
reflector normals are quantised to 42 bins (about 22 deg) for the sun's cosine; sun visibility of the analysis
points per sun-position bin (1 deg: annual error per face 1.5e-4 mean, 7.5e-3 max on the benchmark scene); the
sun is a point.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from widesky.core.spectral import in_band_share

from .measured import measured_scale_factors
from .patches import SkyPatches, cosine_weights, orthonormal_frame, reinhart
from .raycast import Coefficients, start_coefficients
from .scene import Scene
from .skies import SkyStates

__all__ = ["IntegratorSettings", "patch_radiance", "circumsolar_quadrature", "PRESETS", "model_irradiance",
           "measured_scaling"]

# poa_irradiance and POAResult live in irradiance.poa and irradiance.result


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
        :func:`widesky.irradiance.raycast.sun_bins`); 0 casts one ray per point and daylight step.
    time_chunk : int
        Steps per block of the time-series product (bounds memory).
    reflections : int
        Reflections per light path (fixed depth, >= 1): 1 is a single reflection off the ground or a scene
        surface (plus the ground light a wall passes on); ``m`` follows each reflected ray that reaches a
        surface to ``m`` reflections (``docs/irradiance-integrator.md``, "Multiple reflections").
    """

    mf: int = 1
    rays_per_patch: int = 2
    radiance_samples: int = 2
    circumsolar_radius: float = 5.0
    circumsolar_rings: int = 12
    circumsolar_sectors: int = 12
    sun_bin: float = 1.0
    time_chunk: int = 256
    reflections: int = 3

    def __post_init__(self):
        for name in ("mf", "rays_per_patch", "radiance_samples", "circumsolar_rings",
                     "circumsolar_sectors", "time_chunk"):
            if int(getattr(self, name)) < 1:
                raise ValueError(f"{name}={getattr(self, name)} must be >= 1")
        if not 0.5 <= self.circumsolar_radius <= 45.0:
            raise ValueError(f"circumsolar_radius={self.circumsolar_radius} deg outside [0.5, 45]")
        if not 0.0 <= self.sun_bin <= 10.0:
            raise ValueError(f"sun_bin={self.sun_bin} deg outside [0, 10]")
        if not (float(self.reflections) == int(self.reflections) and 1 <= int(self.reflections) <= 20):
            raise ValueError(f"reflections={self.reflections} must be an integer in [1, 20]")

    @classmethod
    def for_tolerance(cls, tolerance):
        """The cheapest preset whose measured annual error is below ``tolerance`` [1] (relative).

        The error of a preset is the largest error of a point's annual poa_global on the two
        validation scenes (:func:`widesky.irradiance.reference.validation_scenes`) against the brute-force
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
        # interpolated value relative to the linear blend: L(u) = La (Lb/La)^u (as exp(u log(Lb/La)))
        expo = np.exp(np.log(ratio)[..., None] * u)                       # (T, n_r, S, nodes)
    lin_a, lin_b = 1.0 - u, u
    la = np.where(pos, inner, 1.0)[..., None]
    # exponential profile: int L (1-u) ..., int L u ... (divided by La, Lb) and int L, the three node sums in one
    # product
    sums = np.matmul(expo, np.stack([lin_a * jac, lin_b * jac, jac], axis=-1)[None])   # (T, n_r, S, 3)
    wa_exp = sums[..., 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        wb_exp = sums[..., 1] / np.where(pos, ratio, 1.0)
    wa_lin = np.sum(lin_a * jac, axis=-1)[None, :, None]
    wb_lin = np.sum(lin_b * jac, axis=-1)[None, :, None]
    # an exponential through La, Lb splits as (int L(1-u))/La and (int L u)/Lb; normalise so that
    # wa*La + wb*Lb equals the exponential integral exactly
    total = sums[..., 2] * la[..., 0]
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


def patch_radiance(sky, patches: SkyPatches, states: SkyStates, weights=None, settings=None, *,
                   sun_scale=None, sky_scale=None, profile=None):
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
        See :mod:`widesky.irradiance.skies` (``radiance``, ``direct_normal``, ``n_channels``).
    patches : SkyPatches
        The sky discretisation.
    states : SkyStates
        T sky states.
    weights : array_like, optional
        (C, R) contraction matrix applied to the channels; default none: the channels themselves (R = C).
    settings : IntegratorSettings, optional
        Sample counts.
    sun_scale, sky_scale : array_like, optional
        (T,) or (T, C) factors [1] on the sun's spectral direct normal irradiance and on the
        spectral sky radiance, applied before the channels are contracted.
    profile : array_like, optional
        (C,) channel weights [1 or nm] of the radial profile that sets the circumsolar nodes' solid angles; default
        the first column of ``weights`` (the first channel without weights).

    The sun and the sky are scaled by ``1 / earth_sun_distance**2`` (the states' Earth-Sun
    distance [AU]; the sky model's extraterrestrial spectrum is at 1 AU).

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
    W = None if weights is None else np.asarray(weights, dtype=float)      # None: the channels, uncontracted
    if W is not None and W.shape[0] != C:
        raise ValueError(f"weights has {W.shape[0]} rows for a sky of {C} channels")
    P, T = patches.n_patches, len(states)
    reg_d, reg_w = patches.subsample(settings.radiance_samples)               # (P, n, 3), (P, n)
    n_sub = reg_d.shape[1]
    reg_d = reg_d.reshape(-1, 3)
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
    inside = (s @ reg_d.T) > cos_rad                                         # (T, n_reg)
    r2 = 1.0 / np.asarray(states.earth_sun_distance, dtype=float) ** 2             # (T,)
    f_sky = _step_channel_factor(sky_scale, T, C, "sky_scale") * r2[:, None]       # (T, C)
    f_sun = _step_channel_factor(sun_scale, T, C, "sun_scale") * r2[:, None]
    R = C if W is None else W.shape[1]
    nr = P * n_sub
    wn = reg_w / reg_w.sum(axis=1, keepdims=True)                             # (P, n_sub)
    ti, si = np.nonzero(inside)                                              # samples inside the disc
    if hasattr(sky, "radiance_means"):        # patch means straight from the sky source
        mean = sky.radiance_means(reg_d, np.repeat(np.arange(P), n_sub), wn.reshape(-1), states)   # (T, P, C)
        # the circumsolar nodes and the samples inside the disc in one call: (T, Q + k) directions, the k slots after
        # the nodes holding each step's inside samples (the zenith where a step has fewer)
        Q = qd.shape[1]
        slot = np.arange(ti.size) - np.searchsorted(ti, ti)                  # rank within its step
        k = int(slot.max()) + 1 if ti.size else 0
        if k:
            ext = np.empty((T, Q + k, 3))
            ext[:, :Q] = qd
            ext[:, Q:] = (0.0, 0.0, 1.0)
            ext[ti, Q + slot] = reg_d[si]
            Lx = sky.radiance(ext, states)                                   # (T, Q + k, C)
            Lq_s, Lin_s = Lx[:, :Q], Lx[ti, Q + slot]
        else:
            Lq_s, Lin_s = sky.radiance(qd, states), np.zeros((0, C))          # (T, Q, C)
    else:
        dirs = np.concatenate([np.broadcast_to(reg_d, (T,) + reg_d.shape), qd], axis=1)
        Ls = sky.radiance(dirs, states)                                      # (T, Nd, C)
        Lr = Ls[:, :nr].reshape(T, P, n_sub, C)
        mean = Lr[:, :, 0] * wn[None, :, 0, None]
        for k in range(1, n_sub):
            mean += Lr[:, :, k] * wn[None, :, k, None]
        Lq_s, Lin_s = Ls[:, nr:], Ls[ti, si]
    if hasattr(sky, "radiance_means"):        # the sky's own fresh (T, Q, C) array: scaled in place
        Lq_s *= f_sky[:, None, :]
        Lq = _contract(Lq_s, W)                                              # (T, Q, R)
    else:
        Lq = _contract(Lq_s * f_sky[:, None, :], W)
    Lq[~above] = 0.0
    # node solid angles from the first response column's radial profile (nodes below the horizon
    # carry no sky)
    lq0 = Lq[..., 0] if profile is None else Lq @ np.asarray(profile, dtype=float)
    qwt = _radial_weights(edges, lq0, settings.circumsolar_sectors) * above
    # split the sky inside the disc into min(L, L_edge) (smooth, left to the patches) and the
    # circumsolar excess (to the sun); L_edge is the mean of the outer circle's nodes above the horizon
    ns = settings.circumsolar_sectors
    w_out = above[:, -ns:].astype(float)
    has_edge = (w_out.sum(axis=1) > 0) & (states.sun_elevation > 0)
    with np.errstate(invalid="ignore", divide="ignore"):
        l_edge = np.einsum("tq,tqr->tr", w_out, Lq[:, -ns:]) / w_out.sum(axis=1)[:, None]
    l_edge[~has_edge] = np.inf
    excess = Lq - l_edge[:, None, :]
    np.maximum(excess, 0.0, out=excess)
    circumsolar = np.einsum("tq,tqr->tr", qwt, excess)
    # patch mean of the capped sky from the stratified samples (each patch's n_sub samples are contiguous):
    # the mean of the spectra, contracted, then the few samples inside the disc corrected to their cap
    mean *= f_sky[:, None, :]                                                # a fresh array: scaled in place
    out = _contract(mean, W)                                                 # (T, P, R)
    if ti.size:
        Lin = _contract(Lin_s * f_sky[ti], W)                                # (k, R)
        np.add.at(out, (ti, si // n_sub), wn.reshape(-1)[si][:, None] * (np.minimum(Lin, l_edge[ti]) - Lin))
    dni = _contract(np.asarray(sky.direct_normal(states), dtype=float) * f_sun, W)
    return out, dni, circumsolar


def _contract(X, W):
    """``X @ W`` for (..., C) values and a (C, R) contraction (``W`` None: ``X`` itself); when W ends with the identity
    those columns are copied instead of multiplied (the same values)."""
    if W is None:
        return X
    C, R = W.shape
    if R > C and np.array_equal(W[:, R - C:], np.eye(C)):
        out = np.empty(X.shape[:-1] + (R,))
        out[..., :R - C] = X @ W[:, :R - C]
        out[..., R - C:] = X
        return out
    return X @ W


def _step_channel_factor(value, T, C, name):
    """(T, C) from None (ones), (T,) or (T, C) factors [1], checked finite and >= 0."""
    if value is None:
        return np.ones((T, C))
    v = np.asarray(value, dtype=float)
    if v.ndim == 1:
        v = v[:, None]
    try:
        v = np.broadcast_to(v, (T, C))
    except ValueError:
        raise ValueError(f"{name} has shape {np.shape(value)}, expected ({T},) or ({T}, {C})") from None
    if not np.all(np.isfinite(v)) or np.any(v < 0):
        raise ValueError(f"{name} must be finite and >= 0")
    return v


def horizontal_diffuse(patch_radiance, circumsolar, w_horizontal, sun_elevation):
    """(T,) diffuse horizontal irradiance [W m-2] from (T, P) broadband patch radiance, (T,)
    circumsolar normal irradiance, (P,) horizontal cosine weights [sr] and sun elevations [deg]."""
    return patch_radiance @ w_horizontal + circumsolar * np.sin(np.radians(sun_elevation))


def model_irradiance(sky, states: SkyStates, settings=None, chunk: int = 256):
    """In-band direct normal and diffuse horizontal irradiance of the sky model per step (over its channels).

    Integrated with the integrator's own quadrature (patch means of ``reinhart(settings.mf)`` times
    their exact horizontal cosine weights, plus the circumsolar disc at the sun's cosine), so the
    clear-sky values that :func:`measured_scaling` divides by are the ones
    :func:`poa_irradiance` reproduces on an unobstructed horizontal face.

    Parameters
    ----------
    sky : sky source
        See :mod:`widesky.irradiance.skies`.
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
        dhi[idx] = horizontal_diffuse(Lp[..., 0], cs[:, 0], w_h, st.sun_elevation)
    return dni, dhi


def measured_scaling(sky, states: SkyStates, dni, dhi, settings=None, **kwargs):
    """Per-step factors that make the clear-sky model reproduce measured DNI and DHI.

    :func:`model_irradiance` gives the model's in-band values, :func:`widesky.irradiance.measured_scale_factors`
    the factors (keyword arguments go to it: floors, cap, ``missing``). Pass ``sun_scale`` and
    ``sky_scale`` to :func:`poa_irradiance` as ``MeasuredSky(dni_scale=..., diffuse_scale=...)``.
    The measured values are broadband (the whole solar spectrum): the sky's channels are matched to them
    times :func:`widesky.core.spectral.in_band_share` of the channels' range (0.99248 for 280-2480 nm), as
    ``MeasuredSky(measured=...)`` does.

    Parameters
    ----------
    dni, dhi : array_like
        (T,) measured (broadband) direct normal and diffuse horizontal irradiance [W m-2] (NaN = missing).

    Returns
    -------
    scaling : MeasuredScaling
        Factors [1], guard flags and unmatched broadband irradiance [W m-2] per step.
    model : tuple of numpy.ndarray
        (model_dni, model_dhi) in-band [W m-2] the factors divide by.
    """
    mdni, mdhi = model_irradiance(sky, states, settings)
    edges = np.asarray(sky.channel_edges, dtype=float)
    share = in_band_share(edges[0], edges[-1])
    f = measured_scale_factors(mdni, mdhi, np.asarray(dni, dtype=float) * share,
                               np.asarray(dhi, dtype=float) * share, **kwargs)
    return f._replace(unmatched_dni=f.unmatched_dni / share, unmatched_dhi=f.unmatched_dhi / share), (mdni, mdhi)


def lazy_zeros(shape, dtype):
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

