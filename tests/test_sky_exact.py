"""Exactness of the evaluator against an independent port of the published algorithm.

The reference here is a deliberately plain, per-(direction, channel) Python port of the rules in
shared/spec/psm-dataset-format.md section 5 (parameter computation with the 50 m safety altitude,
clamped knot lookup, per-configuration clamp, 4-level nested interpolation with the 1e-6 skip,
transmittance mapping), with its own struct-based file parser. It shares no code with skymodel.
Tolerance: 1e-12 relative (both compute in double from the same float32 coefficients; the only
differences are the order of floating-point operations).
"""

import struct
from pathlib import Path
import warnings

import numpy as np
import pytest

from widesky import skymodel
from widesky.skymodel.synthetic import write_synthetic_dataset

R_PLANET = 6378000.0


# ------------------------------------------------------------------ independent parser and evaluator
class SpecModel:
    def __init__(self, path):
        self.b = Path(path).read_bytes()
        self.pos = 0
        rd = self._arr
        self.vis, self.alb, self.alt, self.ele = rd(), rd(), rd(), rd()
        self.nch = self._i()
        self.start, self.width = self._d(), self._d()
        self.rank = self._i()
        self.sb, self.zb, self.eb = rd(), rd(), rd()
        ncfg = len(self.vis) * len(self.alb) * len(self.alt) * len(self.ele) * self.nch
        self.cfg = []
        for _ in range(ncfg):
            sun, zen = [], []
            for _ in range(self.rank):
                s = self._halves(len(self.sb))
                scale = self._d()
                z = self._halves(len(self.zb))
                sun.append([float(np.float32(x)) for x in s])
                zen.append([float(np.float32(x / scale)) for x in z])
            emph = [float(np.float32(x)) for x in self._halves(len(self.eb))]
            self.cfg.append((sun, zen, emph))
        self.ddim, self.adim, nvt, nat, self.rt = (self._i() for _ in range(5))
        self.alt_t = [self._f() for _ in range(nat)]
        self.vis_t = [self._f() for _ in range(nvt)]
        self.U = [self._f() for _ in range(nat * self.ddim * self.adim * self.rt)]
        self.V = [self._f() for _ in range(nvt * nat * self.nch * self.rt)]
        self.pol = None
        if self.pos < len(self.b):
            rp = self._i()
            psb, pzb = rd(), rd()
            blocks = []
            for _ in range(ncfg):
                ps, pz = [], []
                for _ in range(rp):
                    ps.append([self._f() for _ in range(len(psb))])
                    pz.append([self._f() for _ in range(len(pzb))])
                blocks.append((ps, pz))
            self.pol = (psb, pzb, blocks)

    def _i(self):
        v = struct.unpack_from("<i", self.b, self.pos)[0]
        self.pos += 4
        return v

    def _d(self):
        v = struct.unpack_from("<d", self.b, self.pos)[0]
        self.pos += 8
        return v

    def _f(self):
        v = struct.unpack_from("<f", self.b, self.pos)[0]
        self.pos += 4
        return v

    def _arr(self):
        n = self._i()
        return [self._d() for _ in range(n)]

    def _halves(self, n):
        v = struct.unpack_from(f"<{n}e", self.b, self.pos)
        self.pos += 2 * n
        return v


def lookup(q, b):
    q = min(max(q, b[0]), b[-1])
    for k in range(1, len(b)):
        if b[k] > q:
            return k - 1, (q - b[k - 1]) / (b[k] - b[k - 1])
    return len(b) - 1, 0.0


def pl(c, ip):
    i, f = ip
    return c[i] if f == 0 else (c[i + 1] - c[i]) * f + c[i]


def angle(a, b):
    return float(np.arccos(np.clip(np.dot(a, b), -1.0, 1.0)))


def params(view, alt, el, az):
    """Reference computeParameters for view point (0, 0, alt); el, az in radians (az from +x to +y)."""
    C = np.array([0.0, 0.0, -R_PLANET])
    p = np.array([0.0, 0.0, alt])
    n = (p - C) / np.linalg.norm(p - C)
    d = np.linalg.norm(p - C) + 50.0
    S = C + n * d
    altitude = max(d - R_PLANET, 0.0)
    s = np.array([np.cos(az) * np.cos(el), np.sin(az) * np.cos(el), np.sin(el)])
    elevation = np.pi / 2 - angle(n, s)
    v = np.asarray(view, float) / np.linalg.norm(view)
    look = S + v
    c = np.sqrt(d * d - R_PLANET * R_PLANET) / d
    O = C + n * (d - c)
    cv = (look - O) / np.linalg.norm(look - O)
    sig = el + np.pi / 2
    h = np.array([np.cos(sig) * np.cos(az), np.cos(sig) * np.sin(az), np.sin(sig)])
    return dict(theta=angle(v, n), gamma=angle(v, s), shadow=angle(cv, h), zero=angle(cv, n),
                elevation=elevation, altitude=altitude)


def spec_component(m, P, vis, alb, ch, pol=False):
    if pol:
        sb, zb, blocks = m.pol
    else:
        sb, zb, blocks = m.sb, m.zb, m.cfg
    g = lookup(P["gamma"], sb)
    if pol:
        a = lookup(P["zero"], zb)
    else:
        a = lookup(P["shadow"] if P["elevation"] < 0 else P["zero"], zb)
        z = lookup(P["zero"], m.eb)
    lv = [lookup(vis, m.vis), lookup(alb, m.alb), lookup(P["altitude"], m.alt),
          lookup(np.degrees(P["elevation"]), m.ele)]
    sizes = [len(m.vis), len(m.alb), len(m.alt), len(m.ele)]

    def config(idx):
        cfg = (((idx[0] * sizes[1] + idx[1]) * sizes[2] + idx[2]) * sizes[3] + idx[3]) * m.nch + ch
        if pol:
            ps, pz = blocks[cfg]
            return sum(pl(ps[r], g) * pl(pz[r], a) for r in range(len(ps)))
        sun, zen, emph = blocks[cfg]
        res = sum(pl(sun[r], g) * pl(zen[r], a) for r in range(m.rank))
        return max(res * pl(emph, z), 0.0)

    def rec(level, idx):
        if level == 4:
            return config(idx)
        i, f = lv[level]
        lo = rec(level + 1, idx + [i])
        if f < 1e-6:
            return lo
        hi = rec(level + 1, idx + [min(i + 1, sizes[level] - 1)])
        return (1 - f) * lo + f * hi

    v = rec(0, [])
    return -v if pol else v


def spec_transmittance(m, P, vis, ch, distance=np.inf):
    theta, h = P["theta"], P["altitude"]
    top = R_PLANET + 100000.0
    dx, dy, y0 = np.sin(theta), np.cos(theta), R_PLANET + h

    def circle(rc):
        qa, qb, qc = dx * dx + dy * dy, 2 * y0 * dy, y0 * y0 - rc * rc
        disc = qb * qb - 4 * qa * qc
        if disc <= 0:
            return -1.0
        disc = np.sqrt(disc)
        d1, d2 = (-qb + disc) / (2 * qa), (-qb - disc) / (2 * qa)
        return min(d1, d2) if d1 > 0 and d2 > 0 else max(d1, d2)

    if h < 0.3:
        t = circle(top) if theta <= np.pi / 2 else 0.0
    else:
        t = circle(R_PLANET)
        if t < 0:
            t = circle(top)
    t = min(t, distance)
    px, py = dx * t, dy * t + y0
    rho = np.sqrt(px * px + py * py)  # as the reference (hypot rounds differently; rho - R cancels)
    ap = (min(max(rho - R_PLANET, 0), 100000.0) / 100000.0) ** (1 / 3)
    dp = min(1.0, (np.arccos(np.clip(py / rho, -1, 1)) * R_PLANET / 1571524.413613) ** 0.25)

    def grid(v, n, p):
        i = min(int(v * n), n - 1)
        if i < n - 1:
            return i, min(max((v ** p - (i / n) ** p) / (((i + 1) / n) ** p - (i / n) ** p), 0), 1)
        return i, 0.0

    ai, af = grid(ap, m.adim, 3)
    di, df = grid(dp, m.ddim, 4)
    nat = len(m.alt_t)

    def uv(iv, ia, a, d):
        if a >= m.adim or d >= m.ddim:
            return 0.0
        return sum(m.U[((ia * m.ddim + d) * m.adim + a) * m.rt + r] * m.V[((iv * nat + ia) * m.nch + ch) * m.rt + r]
                   for r in range(m.rt))

    def rec_alt(iv, ia):
        lo = uv(iv, ia, ai, di)
        hi = uv(iv, ia, ai + 1, di)
        if df > 0:
            lo = (1 - df) * lo + df * uv(iv, ia, ai, di + 1)
            hi = (1 - df) * hi + df * uv(iv, ia, ai + 1, di + 1)
        lo, hi = max(lo, 0), max(hi, 0)
        return (1 - af) * lo + af * hi if af > 0 else lo

    def over_alt(iv):
        ia, fa = lookup(h, m.alt_t)
        v = rec_alt(iv, ia)
        return (1 - fa) * v + fa * rec_alt(iv, ia + 1) if fa > 0 else v

    iv, fv = lookup(vis, m.vis_t)
    v = over_alt(iv)
    if fv > 0:
        v = (1 - fv) * v + fv * over_alt(iv + 1)
    return v * v


# ------------------------------------------------------------------ fixtures
@pytest.fixture(scope="module")
def datasets(tmp_path_factory):
    d = tmp_path_factory.mktemp("exact")
    out = {}
    # every level of the interpolation: 3 visibilities, 2 albedos, 3 altitudes, elevations incl. negative
    out["full"] = write_synthetic_dataset(d / "full.dat", visibilities=(20, 45.5, 131.8), albedos=(0, 1),
                                          altitudes=(0, 1000, 6000), n_channels=4, channel_start=300,
                                          rank=3, n_sun=9, n_zen=11, n_emph=7, polarisation=True, pol_rank=2,
                                          n_pol_sun=6, n_pol_zen=5, roughness=0.4, seed=11)
    # large random terms: configurations change sign inside cells, results are often clamped to 0
    out["rough"] = write_synthetic_dataset(d / "rough.dat", visibilities=(20, 131.8), albedos=(0, 1),
                                           n_channels=2, rank=4, n_sun=8, n_zen=9, n_emph=6, roughness=3.0, seed=9)
    # rank 1, few knots, no polarisation, one altitude (like the ground-level dataset)
    out["ground"] = write_synthetic_dataset(d / "ground.dat", visibilities=(30, 80), albedos=(0.2,),
                                            altitudes=(0,), n_channels=3, rank=1, n_sun=4, n_zen=3, n_emph=2,
                                            roughness=0.2, seed=5)
    return out


def _random_dirs(rng, n):
    v = rng.normal(size=(n, 3))
    v[: n // 2, 2] = np.abs(v[: n // 2, 2])  # half upward, half anywhere
    v[0] = (0, 0, 1)  # zenith exactly
    v[1] = (1, 0, 0)  # horizon exactly
    return v


STATES = [  # (elevation deg, azimuth deg compass, visibility km, albedo, altitude m)
    (30.0, 200.0, 35.0, 0.3, 0.0),
    (0.0, 90.0, 131.8, 1.0, 0.0),       # elevation on a grid point, top visibility
    (-3.1, 10.0, 25.0, 0.7, 700.0),     # sun below the horizon: shadow angle
    (73.0, 300.0, 45.5, 0.0, 5000.0),
    (88.0, 45.0, 20.0, 0.5, 6000.0),    # top altitude
    (10.0, 77.0, 20.0, 0.0, 0.0),       # every factor on a grid point: a single configuration
]


@pytest.mark.parametrize("state", STATES)
@pytest.mark.parametrize("method", ["direct", "table"])
@pytest.mark.parametrize("which", ["full", "rough"])
def test_radiance_matches_spec_port(datasets, state, method, which):
    path = datasets[which]
    m = skymodel.load_dataset(path)
    spec = SpecModel(path)
    rng = np.random.default_rng(1)
    dirs = _random_dirs(rng, 40)
    el, az, vis, alb, alt = state
    with warnings.catch_warnings():  # out-of-range states are clamped as the reference does: part of the check
        warnings.simplefilter("ignore", skymodel.SkyStateClampedWarning)
        ours = skymodel.sky_radiance(m, dirs, el, az, vis, alb, alt, method=method)
    ref = np.array([[spec_component(spec, params(v, alt, np.radians(el), np.radians(90 - az)), vis, alb, ch)
                     for ch in range(spec.nch)] for v in dirs])
    if which == "rough" and state == STATES[-1]:
        assert (ref == 0).any()  # the clamp at zero is exercised
    np.testing.assert_allclose(ours, ref, rtol=1e-12, atol=1e-12 * np.abs(ref).max())


@pytest.mark.parametrize("state", STATES)
def test_polarisation_and_transmittance_match_spec_port(datasets, state):
    path = datasets["full"]
    m = skymodel.load_dataset(path)
    spec = SpecModel(path)
    dirs = _random_dirs(np.random.default_rng(2), 25)
    el, az, vis, alb, alt = state
    P = [params(v, alt, np.radians(el), np.radians(90 - az)) for v in dirs]
    pol = skymodel.polarisation(m, dirs, el, az, vis, alb, alt)
    ref = np.array([[spec_component(spec, p, vis, alb, ch, pol=True) for ch in range(spec.nch)] for p in P])
    np.testing.assert_allclose(pol, ref, rtol=1e-12, atol=1e-13)
    for dist in (np.inf, 1500.0):
        tr = skymodel.transmittance(m, dirs, el, az, vis, alb, alt, distance=dist)
        ref = np.array([[spec_transmittance(spec, p, vis, ch, dist) for ch in range(spec.nch)] for p in P])
        np.testing.assert_allclose(tr, ref, rtol=1e-12, atol=1e-14)


def test_ground_level_variant(datasets):
    """Rank 1, two-knot factors, single albedo/altitude, no polarisation section."""
    path = datasets["ground"]
    m = skymodel.load_dataset(path)
    spec = SpecModel(path)
    assert not m.has_polarisation and spec.pol is None
    dirs = _random_dirs(np.random.default_rng(3), 30)
    for el, az, vis in ((12.0, 180.0, 50.0), (-1.0, 0.0, 30.0), (45.0, 270.0, 80.0)):
        ours = skymodel.sky_radiance(m, dirs, el, az, vis, 0.2)
        ref = np.array([[spec_component(spec, params(v, 0.0, np.radians(el), np.radians(90 - az)), vis, 0.2, ch)
                         for ch in range(spec.nch)] for v in dirs])
        np.testing.assert_allclose(ours, ref, rtol=1e-12, atol=1e-12 * np.abs(ref).max())
    with pytest.raises(ValueError, match="no polarisation"):
        skymodel.polarisation(m, dirs, 10, 180, 50, 0.2)


def test_table_equals_direct_on_dense_image(datasets):
    """The piecewise-polynomial table path gives the direct path's values on a dense fisheye, including
    cells where configurations change sign (rough dataset)."""
    from widesky.skymodel.render import fisheye_directions

    m = skymodel.load_dataset(datasets["rough"])
    d, mask = fisheye_directions(120)
    dirs = d[mask]
    for state in ((41.0, 123.0, 60.0, 0.4), (10.0, 77.0, 20.0, 0.0)):
        a = skymodel.sky_radiance(m, dirs, *state, method="direct")
        b = skymodel.sky_radiance(m, dirs, *state, method="table")
        np.testing.assert_allclose(b, a, rtol=1e-11, atol=1e-12 * np.abs(a).max())
    assert (a == 0).mean() > 0.01  # the clamp is exercised
    c = skymodel.sky_radiance(m, dirs, *state, method="table", dtype=np.float32)
    np.testing.assert_allclose(c, a, rtol=2e-7, atol=1e-7 * np.abs(a).max())


@pytest.mark.parametrize("which", ["rough", "full"])
def test_twilight_table_equals_direct_on_dense_image(datasets, which):
    """Sun below the horizon (the shadow angle replaces the zero angle in the zenith factor): the twilight
    table path gives the direct path's values on dense up- and side-facing fisheyes, to the daytime table's
    tolerance, with the clamp exercised (rough dataset) and every interpolation level (full dataset)."""
    from widesky.skymodel.evaluate import KERNEL_INFO
    from widesky.skymodel.render import fisheye_disc

    m = skymodel.load_dataset(datasets[which])
    for view, state in (("up", (-2.2, 123.0, 60.0, 0.4)), ("side", (-0.6, 200.0, 30.0, 0.9)),
                        ("up", (-4.2, 10.0, 131.8, 1.0))):
        dirs, _ = fisheye_disc(110, view, 150.0)
        for alt in (0.0, 2500.0) if which == "full" else (0.0,):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", skymodel.SkyStateClampedWarning)
                a = skymodel.sky_radiance(m, dirs, *state, alt, method="direct")
                b = skymodel.sky_radiance(m, dirs, *state, alt, method="table")
            assert KERNEL_INFO["path"] == 3 and KERNEL_INFO["cells_built"] > 10
            np.testing.assert_allclose(b, a, rtol=1e-11, atol=1e-12 * np.abs(a).max())
    if which == "rough":
        assert (a == 0).mean() > 0.01 and KERNEL_INFO["mixed_terms"] > 0  # the clamp is exercised
    # rows scattered into an image (the renderer's call) give the same values
    from widesky.skymodel.evaluate import _evaluate_component

    img = np.zeros((dirs.shape[0] + 7, m.n_channels))
    rows = np.arange(dirs.shape[0], dtype=np.int64)[::-1] + 7
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", skymodel.SkyStateClampedWarning)
        _evaluate_component(m, "radiance", dirs, *state, alt, None, None, np.float64, img, "table", 0, False,
                            rows=rows)
    np.testing.assert_array_equal(img[rows], b)
    assert np.all(img[:7] == 0)


def test_broadcasting_shapes_channels_and_wavelengths(datasets):
    m = skymodel.load_dataset(datasets["full"])
    dirs = _random_dirs(np.random.default_rng(4), 12).reshape(3, 4, 3)
    el = np.array([10.0, 50.0])[:, None]
    vis = np.array([30.0, 60.0, 100.0])
    L = skymodel.sky_radiance(m, dirs, el, 180.0, vis, 0.5)
    assert L.shape == (2, 3, 3, 4, m.n_channels)
    single = skymodel.sky_radiance(m, dirs[1, 2], 50.0, 180.0, 100.0, 0.5)
    np.testing.assert_array_equal(L[1, 2, 1, 2], single)
    # point wavelengths: evaluated in their channel, no interpolation (as the reference)
    w = skymodel.sky_radiance(m, dirs, 50.0, 180.0, 100.0, 0.5, wavelengths=[301.0, 339.9, 340.0])
    np.testing.assert_array_equal(w[..., 0], w[..., 1])
    np.testing.assert_array_equal(w[..., 2], L[1, 2, ..., 1])
    with pytest.raises(ValueError, match="outside the dataset's range"):
        skymodel.sky_radiance(m, dirs, 50.0, 180.0, 100.0, 0.5, wavelengths=[299.0])
    with pytest.raises(ValueError, match="outside the dataset's range"):
        skymodel.transmittance(m, dirs, 50.0, 180.0, 100.0, 0.5, wavelengths=[460.0])


def test_clamping_is_reported(datasets):
    m = skymodel.load_dataset(datasets["full"])
    dirs = _random_dirs(np.random.default_rng(5), 5)
    with pytest.warns(skymodel.SkyStateClampedWarning, match=r"visibility=5 km outside the dataset's range \[20, 131.8\]"):
        low = skymodel.sky_radiance(m, dirs, 30.0, 180.0, 5.0, 0.5)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        edge = skymodel.sky_radiance(m, dirs, 30.0, 180.0, 20.0, 0.5)
    np.testing.assert_array_equal(low, edge)  # clamped exactly as the reference does
    vals, flags = skymodel.sky_radiance(m, dirs, [30.0, -10.0], 180.0, 50.0, 0.5, return_clamped=True)
    assert flags.tolist() == [False, True]


def test_bad_arguments(datasets):
    m = skymodel.load_dataset(datasets["full"])
    with pytest.raises(ValueError, match="shape"):
        skymodel.sky_radiance(m, np.zeros((4, 2)), 30, 180, 50, 0.5)
    with pytest.raises(ValueError, match="zero vector"):
        skymodel.sky_radiance(m, np.zeros((4, 3)), 30, 180, 50, 0.5)
    with pytest.raises(ValueError, match="visibility must be > 0"):
        skymodel.sky_radiance(m, [0, 0, 1], 30, 180, 0.0, 0.5)
    with pytest.raises(ValueError, match="non-finite"):
        skymodel.sky_radiance(m, [0, 0, 1], np.nan, 180, 50, 0.5)
    with pytest.raises(ValueError, match="channels"):
        skymodel.sky_radiance(m, [0, 0, 1], 30, 180, 50, 0.5, channels=[7])


def test_sun_radiance_and_direct_normal(datasets):
    """Sun radiance is the extraterrestrial radiance times the transmittance inside the solar disc
    (radius 0.2667 deg, as the reference) and 0 outside; DNI is the extraterrestrial band irradiance times
    the same transmittance."""
    m = skymodel.load_dataset(datasets["full"])
    s = skymodel.sun_direction(35.0, 150.0)
    off = skymodel.sun_direction(35.0 + np.degrees(skymodel.SUN_RADIUS) * 1.5, 150.0)
    L = skymodel.sun_radiance(m, np.stack([s, off]), 35.0, 150.0, 50.0, 0.3)
    assert np.all(L[1] == 0) and np.all(L[0] > 0)
    T = skymodel.transmittance(m, s, 35.0, 150.0, 50.0, 0.3)
    dni = skymodel.solar_direct_normal(m, 35.0, 150.0, 50.0, 0.3)
    np.testing.assert_allclose(L[0] * skymodel.SUN_SOLID_ANGLE, dni, rtol=1e-12)
    wl, e = skymodel.extraterrestrial_spectrum()
    # band mean of the piecewise-linear 1 nm table, by brute force on a 0.01 nm grid
    band = [np.interp(np.linspace(lo, lo + 40, 4001), wl, e).mean() for lo in m.channel_lower]
    np.testing.assert_allclose(dni / T, band, rtol=1e-4)


def test_reference_loop_baseline_agrees(datasets):
    """The benchmark's baseline (a straight per-direction, per-channel port in C) gives the same values."""
    from widesky.skymodel import _core

    m = skymodel.load_dataset(datasets["full"])
    sun, zen, emph = m.radiance_coefficients()
    dirs = np.ascontiguousarray(_random_dirs(np.random.default_rng(6), 30))
    for el, az, vis, alb, alt in STATES:
        out = np.empty((30, m.n_channels))
        _core.reference_loop(sun, zen, emph, m.sun_breaks, m.zenith_breaks, m.emph_breaks, m.rank, m.n_channels,
                             m.visibilities, m.albedos, m.altitudes, m.elevations, dirs,
                             (alt, np.radians(el), np.radians(90 - az), vis, alb), np.arange(m.n_channels), out)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", skymodel.SkyStateClampedWarning)
            ours = skymodel.sky_radiance(m, dirs, el, az, vis, alb, alt)
        np.testing.assert_allclose(out, ours, rtol=1e-12, atol=1e-12 * np.abs(ours).max())


def test_reference_angles_match_the_spec_port():
    dirs = _random_dirs(np.random.default_rng(8), 20)
    for el, az, alt in ((30.0, 200.0, 0.0), (-2.0, 10.0, 1500.0)):
        a = skymodel.reference_angles(dirs, el, az, alt)
        for k, v in enumerate(dirs):
            p = params(v, alt, np.radians(el), np.radians(90 - az))
            for name in ("theta", "gamma", "shadow", "zero"):
                assert a[name][k] == pytest.approx(p[name], abs=1e-12), name
        assert a["elevation"] == pytest.approx(p["elevation"], abs=1e-15)
        assert a["altitude"] == pytest.approx(p["altitude"], abs=1e-9)


def test_exact_sun_and_antisolar_directions_are_the_limits(datasets):
    """The reference takes acos of an unclamped dot product, which rounding can push past 1 exactly at the
    sun and the antisolar point (NaN there); widesky clamps it, so the value there is the limit of nearby
    directions (1e-6 rad off: the model is piecewise linear in the angle, so the values differ by the slope
    times 1e-6 at most; checked loosely at 1e-4 relative)."""
    m = skymodel.load_dataset(datasets["full"])
    for el, az in ((30.0, 200.0), (73.3, 41.0), (-2.0, 10.0)):
        s = skymodel.sun_direction(el, az)
        side = np.cross(s, [0.0, 0.0, 1.0])
        side /= np.linalg.norm(side)
        for centre in (s, -s):
            d = np.stack([centre, np.cos(1e-6) * centre + np.sin(1e-6) * side])
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", skymodel.SkyStateClampedWarning)
                for method in ("direct", "table"):
                    v = skymodel.sky_radiance(m, d, el, az, 40.0, 0.5, 1000.0, method=method)
                    assert np.isfinite(v).all()
                    np.testing.assert_allclose(v[0], v[1], rtol=1e-4, atol=1e-12)


def test_vertical_ray_to_a_finite_distance_is_the_limit_of_tilted_rays(datasets):
    """Transmittance to a finite distance along a vertical ray: the distance factor is 0 there, where the
    reference interpolates toward the wrong altitude entry; widesky's value is the limit as the ray tilts
    (the distance factor grows linearly with the tilt, so 1e-9 rad off vertical is within 1e-6 of it)."""
    m = skymodel.load_dataset(datasets["full"])
    for dist in (800.0, 5000.0, 40000.0):
        for up in (1.0, -1.0):
            rays = [[0.0, 0.0, up], [1e-9, 0.0, up], [1e-3, 0.0, up]]
            t = skymodel.transmittance(m, rays, 30.0, 180.0, 45.5, 0.5, 1000.0, distance=dist)
            np.testing.assert_allclose(t[0], t[1], rtol=1e-6)
            assert np.all(t[0] != t[2])  # the tilt matters at all: the check above is not vacuous


def test_direct_normal_reports_altitude_clamp(datasets):
    """An altitude above the dataset's highest (6000 m here) is clamped in the transmittance's coefficient
    lookup, so solar_direct_normal (and sun_radiance) warn and flag it as sky_radiance does; at the
    highest altitude itself nothing warns."""
    m = skymodel.load_dataset(datasets["full"])
    with pytest.warns(skymodel.SkyStateClampedWarning, match=r"altitude=9000 m above the dataset's highest "):
        skymodel.sky_radiance(m, [0, 0, 1], 35.0, 150.0, 50.0, 0.3, 9000.0)
    with pytest.warns(skymodel.SkyStateClampedWarning,
                      match=r"solar_direct_normal: altitude=9000 m above the dataset's highest transmittance "
                            r"altitude 6000 m; clamped"):
        skymodel.solar_direct_normal(m, 35.0, 150.0, 50.0, 0.3, 9000.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        skymodel.solar_direct_normal(m, 35.0, 150.0, 50.0, 0.3, 6000.0)
    _, flags = skymodel.solar_direct_normal(m, 35.0, 150.0, 50.0, 0.3, [0.0, 9000.0], return_clamped=True)
    assert flags.tolist() == [False, True]
    s = skymodel.sun_direction(35.0, 150.0)
    with pytest.warns(skymodel.SkyStateClampedWarning, match=r"sun radiance: altitude=9000 m"):
        skymodel.sun_radiance(m, s, 35.0, 150.0, 50.0, 0.3, 9000.0)
