"""The weather route's Perez et al. (1990) transposition (thermal/surface.py, issue 38).

Against pvlib 0.16 (independent code, test-only dependency): ``pvlib.irradiance.perez(...,
return_components=True)`` with its default coefficients (the 1990 all-sites composite) and the Kasten-Young air
mass, every part (isotropic, circumsolar, horizon band) on planes of several tilts and azimuths, for skies in every
one of the eight clearness bins: to 1e-9 W m-2. Analytic: on a horizontal plane the parts add up to the DHI (sun
above 5 deg). The horizon band's shading on the BESTEST windows: an open wall sees all of it, under the 610 overhang
none of it is hidden, and the 630 fins cut it as two infinitely tall fins do, ``(sqrt(10) - 1) / 3``. And, for the
glazing study (docs/thermal.md), why clear glass passes less of the vegetation ground's light.
"""

import numpy as np
import pytest

from widesky.irradiance.perez_sky import PEREZ_1993_EPSILON_EDGES
from widesky.thermal.surface import PEREZ_1990_COEFFICIENTS, perez_sky_parts, surface_irradiance

pvlib = pytest.importorskip("pvlib")


def _skies():
    """Sun positions and DNI/DHI pairs whose clearness falls in all eight bins, with a spread of brightness."""
    rng = np.random.default_rng(38)
    n = 400
    zen = rng.uniform(5.0, 88.0, n)
    saz = rng.uniform(60.0, 300.0, n)
    dhi = rng.uniform(20.0, 450.0, n)
    target = rng.uniform(1.0, 12.0, n)                     # clearness aimed at, spread over the bins
    z = np.radians(zen)
    k = 1.041 * z ** 3
    dni = np.maximum((target * (1 + k) - k - 1.0) * dhi, 0.0)
    dni = np.minimum(dni, 1100.0)
    dne = rng.uniform(1320.0, 1410.0, n)
    return zen, saz, dni, dhi, dne


PLANES = [(90.0, 180.0), (90.0, 0.0), (90.0, 90.0), (90.0, 270.0), (30.0, 180.0), (60.0, 135.0), (0.0, 180.0)]


def test_perez_parts_against_pvlib():
    zen, saz, dni, dhi, dne = _skies()
    ours = perez_sky_parts([p[0] for p in PLANES], [p[1] for p in PLANES], zen, saz, dni, dhi, dne)
    bins = np.searchsorted(PEREZ_1993_EPSILON_EDGES, ours["epsilon"], side="right")
    assert set(bins) == set(range(8))                      # every bin (and so every coefficient row) exercised
    am = pvlib.atmosphere.get_relative_airmass(zen, model="kastenyoung1989")
    for j, (tilt, az) in enumerate(PLANES):
        ref = pvlib.irradiance.perez(tilt, az, dhi, dni, dne, zen, saz, am, return_components=True)
        for ours_key, ref_key in (("isotropic", "poa_isotropic"), ("circumsolar", "poa_circumsolar"),
                                  ("horizon", "poa_horizon")):
            assert ours[ours_key][:, j] == pytest.approx(np.asarray(ref[ref_key]), abs=1e-9), (tilt, az, ours_key)
    # the horizon band is there and sizeable on a wall (not a trivially zero part)
    assert np.abs(ours["horizon"][:, 0]).max() > 20.0


def test_surface_irradiance_perez_against_pvlib_and_its_split():
    zen, saz, dni, dhi, dne = _skies()
    ghi = dni * np.cos(np.radians(zen)) + dhi
    tilts, azs = [p[0] for p in PLANES], [p[1] for p in PLANES]
    r = surface_irradiance(tilts, azs, zen, saz, dni, dhi, ghi, dne, albedo=0.2)       # Perez: the default
    am = pvlib.atmosphere.get_relative_airmass(zen)
    for j, (tilt, az) in enumerate(PLANES):
        sky = pvlib.irradiance.perez(tilt, az, dhi, dni, dne, zen, saz, am)
        beam = pvlib.irradiance.beam_component(tilt, az, zen, saz, dni)
        gnd = pvlib.irradiance.get_ground_diffuse(tilt, ghi, albedo=0.2)
        assert r["poa_global"][:, j] == pytest.approx(np.asarray(sky + beam + gnd), abs=1e-9)
        assert r["poa_direct"][:, j] - r["poa_circumsolar"][:, j] == pytest.approx(np.asarray(beam), abs=1e-9)
    hd = surface_irradiance(tilts, azs, zen, saz, dni, dhi, ghi, dne, albedo=0.2, transposition="hay-davies")
    assert np.all(hd["poa_horizon"] == 0)
    # the two differ where it matters: Perez puts more on the walls in these skies
    assert abs(r["poa_global"][:, 0].sum() / hd["poa_global"][:, 0].sum() - 1) > 0.01
    with pytest.raises(ValueError, match="transposition='isotropic' not one of perez, hay-davies"):
        surface_irradiance(tilts, azs, zen, saz, dni, dhi, ghi, dne, transposition="isotropic")


def test_horizontal_plane_gets_the_dhi():
    """On a horizontal plane the horizon band vanishes (sin 0) and circumsolar + isotropic = DHI (F1 cos Z / cos Z
    + (1 - F1)) while the sun is above 5 deg (the published cos 85 deg floor)."""
    zen, saz, dni, dhi, dne = _skies()
    p = perez_sky_parts([0.0], [180.0], zen, saz, dni, dhi, dne)
    up = zen < 85
    total = p["isotropic"][:, 0] + p["circumsolar"][:, 0] + p["horizon"][:, 0]
    assert total[up] == pytest.approx(dhi[up], rel=1e-12)
    assert np.all(p["horizon"][:, 0] == 0)


def test_sun_down_is_isotropic_and_coefficients_shape():
    p = perez_sky_parts([90.0], [180.0], np.array([95.0, 40.0]), np.array([200.0, 200.0]),
                        np.array([0.0, 500.0]), np.array([30.0, 0.0]), np.array([1361.0, 1361.0]))
    assert p["F1"][0] == 0 and p["F2"][0] == 0
    assert p["isotropic"][0, 0] == pytest.approx(15.0)                  # DHI (1 + cos 90) / 2
    assert p["isotropic"][1, 0] == 0 and p["circumsolar"][1, 0] == 0    # no diffuse, nothing
    assert PEREZ_1990_COEFFICIENTS.shape == (len(PEREZ_1993_EPSILON_EDGES) + 1, 6)


def test_horizon_band_shading_of_the_bestest_windows():
    """Open wall: the whole band. 610 overhang (1 m deep, 0.5 m above the heads): its edge stands above 26 deg
    straight out, above 6.5 deg until the band's light is at 82 deg from the normal: nothing of the band hidden.
    630 fins (1 m deep, flush with both sides of a 3 m window, ground to roof): a point x from one fin sees the
    band's cosine-weighted azimuths up to atan(x / 1 m) on that side, so the window sees
    ``mean over x of (sin atan(x) + sin atan(3 - x)) / 2 = (sqrt(10) - 1) / 3 = 0.721``."""
    from widesky.thermal.bestest_geometry import bestest_building, window_shading
    zen, saz = np.array([50.0]), np.array([180.0])
    assert window_shading(bestest_building("south"), zen, saz)["horizon_view"] == pytest.approx(1.0)
    f = window_shading(bestest_building("south", "overhang"), zen, saz)
    assert f["horizon_view"] == pytest.approx(1.0, abs=1e-3) and f["sky_view"][0] < 0.9
    f = window_shading(bestest_building("eastwest", "overhang_fins"), zen, saz, samples_per_face=256)
    assert f["horizon_view"] == pytest.approx((np.sqrt(10) - 1) / 3, abs=0.01)


def test_horizon_g_by_hand():
    """A flat g(theta) passes the horizon band at that g; g falling linearly to 0 at 90 deg: int (1 - t / (pi/2))
    cos t dt / int cos t dt = 1 - (pi/2 - 1) / (pi/2) = 2 / pi."""
    from widesky.thermal.bestest import horizon_g
    ang = np.linspace(0.0, 90.0, 19)
    assert horizon_g(ang, np.full(19, 0.7)) == pytest.approx(0.7, rel=1e-12)
    assert horizon_g(ang, 1 - ang / 90.0) == pytest.approx(2 / np.pi, rel=1e-5)


def test_vegetation_ground_light_lowers_clear_glass_g():
    """The glazing study's clear unit sits 0.88 % under its rating in Denver because of the ground-reflected light
    (docs/thermal.md, "The spectral treatment"): light reflected by the default vegetation ground (reflectance 0.05
    visible, 0.45 near infrared) is 25 % visible against AM1.5G's 54 %, and clear glass passes the near infrared
    less (iron absorption), so its normal g under AM1.5G x vegetation is 4.5 % under its AM1.5G g; a grey ground
    changes nothing. By hand from the unit's spectral g (NFRC 102 twice) and ASTM G173-03 over 280-2480 nm."""
    from widesky.irradiance.ground import vegetation_albedo_shape
    from widesky.thermal.glazing import read_solar_spectrum
    from widesky.thermal.study import standard_units
    sw, se = read_solar_spectrum()
    band = sw <= 2480.0
    sw, se = sw[band], se[band]
    g = standard_units()["clear"].optics(np.array([0.0]), sw)["shgc"][0]
    veg = vegetation_albedo_shape(sw)

    def mean_g(w):
        return np.trapezoid(g * se * w, sw) / np.trapezoid(se * w, sw)

    assert mean_g(veg) / mean_g(np.ones_like(sw)) - 1 == pytest.approx(-0.0455, abs=0.003)
    assert mean_g(np.full_like(sw, 0.2)) == pytest.approx(mean_g(np.ones_like(sw)), rel=1e-12)
    vis = (sw >= 380) & (sw <= 780)
    assert np.trapezoid(se * veg * vis, sw) / np.trapezoid(se * veg, sw) == pytest.approx(0.247, abs=0.005)
