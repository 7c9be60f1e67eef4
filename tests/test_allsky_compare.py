"""The all-sky model against published references (issue 16): the ASTM G173 state, PVSPEC and SEDES2.

References and tolerances:
* ASTM G173 state (AM1.5, 37 deg tilt, AOD500 0.084, water 1.42 cm, ozone 0.34 atm-cm, albedo 0.2): the
  sky model's diffuse on the plane agrees with SPCTRL2's (Bird & Riordan 1986, pvlib, the same state)
  within 12 % in every channel 380-1060 nm, while G173's own diffuse is 20-30 % below both at 420-540 nm;
  the direct beam agrees with G173's within 5 % there. The a-Si spectral effect of the model's global
  tilted spectrum against G173 (+3.2 %) comes from the diffuse: the model's direct with G173's diffuse
  gives within 0.5 points of 0, G173's direct with the model's diffuse within 0.5 points of the whole;
  SPCTRL2 against G173 gives a-Si > +1.5 % by itself.
* PVSPEC (Pelland et al. 2020, IEEE PVSC 47, 1258; coefficients in pvlib's spectral_factor_pvspec): the
  median spectral mismatch of hourly plane-of-array spectra in clear-sky-index bins 0.2-0.4, 0.4-0.6
  and 0.6-0.8, relative to the 0.9-1.1 bin, is within 0.04 of PVSPEC's kc^a2 at the bin centre for
  a-Si, CdTe, c-Si and CIGS (Amsterdam IWEC, every 10th daylight hour); the plain measured path misses
  a-Si by more than 0.1 (the test can fail).
* Freiburg (Dirnberger et al. 2015, Sol. Energy Mater. Sol. Cells 132, 431; measured annual spectral effects
  against AM1.5G: a-Si +3.4, CdTe +2.4, c-Si +1.4, CIGS +0.6 %): the all-sky default on the Amsterdam IWEC year
  (every daylight hour, a south plane tilted at the latitude, the AOD column, generic EQEs) is within 1.5
  percentage points for each technology, in the measured order, and its a-Si minus CIGS spread within 1.5
  points of 2.8 (the issue's criterion); the grey ground misses a-Si by more than 1.5 points and the vegetated
  ground changes no annual total (docs/validation/all-sky.md, section 4b).
* SEDES2 (Nann & Riordan 1991; cloud cover modifiers as tabulated by Whitaker & Newmiller 1998,
  NREL/SR-520-23942): median hourly APE of global horizontal spectra within 0.02 eV of SEDES2 applied to
  the same clear spectra and GHI, in the clear-sky-index bins 0.4-0.6 and 0.6-0.8 (SEDES2 is bluer below
  0.4: documented in docs/all-sky.md, not claimed). Needs the coefficient table as
  ``validation/sedes2_cloud_cover_modifiers.csv`` in the data directory (not shipped; skips without it).
"""

import numpy as np
import pytest

from widesky.irradiance.allsky_compare import (ape_by_kc, g173_decomposition, generic_eqe, mismatch_by_kc,
                                       pvspec_annual, pvspec_published, sedes2_global_horizontal, spectral_response)

# PVSPEC's a-Si coefficients a1, a2, a3 (Pelland et al. 2020, Table; as in pvlib's spectral_factor_pvspec)
PVSPEC_ASI = (1.051, -0.1033, 0.009838)

needs_data = pytest.mark.reference         # the Amsterdam IWEC year and validation files: reference data


@pytest.fixture(scope="module")
def sky():
    import widesky.irradiance as ir
    return ir.PragueSky()


@pytest.mark.reference
@needs_data
def test_g173_offset_is_g173s_diffuse(sky):
    pytest.importorskip("pvlib")
    wl = np.asarray(sky.wavelengths)
    sr = spectral_response(generic_eqe(wl), wl)
    se, d = g173_decomposition(sky, sr)
    assert se["the model at the G173 state"]["a-Si"] > 2.5
    assert abs(se["model direct + G173 diffuse"]["a-Si"]) < 0.5
    assert abs(se["G173 direct + model diffuse"]["a-Si"] - se["the model at the G173 state"]["a-Si"]) < 0.5
    assert se["SPCTRL2 at the G173 state"]["a-Si"] > 1.5
    band = (wl >= 380) & (wl <= 1060) & ~np.isin(wl, [940.0])          # not the 940 nm water band
    np.testing.assert_allclose(d["model"][band], d["SPCTRL2"][band], rtol=0.12)
    blue = (wl >= 420) & (wl <= 540)
    assert np.all(d["G173"][blue] < 0.8 * d["SPCTRL2"][blue]) and np.all(d["G173"][blue] < 0.8 * d["model"][blue])


def _amsterdam_sample(sky, stride=10):
    import widesky.irradiance as ir
    from widesky.irradiance.allsky_plane import clear_plane_spectra
    from widesky.core.paths import data_file
    wd = ir.read_weather(data_file("weather/NLD_Amsterdam062400_IWEC.epw"))
    sp = wd.site.solar_position(wd.data.index, wd.label, wd.step)
    st = ir.sky_states(sp, wd.data, model=sky.model, prefer="aod")
    d = wd.data
    keep = (st["solar_elevation"].to_numpy() > 5.0) & (d["ghi"].to_numpy() > 20.0)
    keep &= np.isfinite(d["dni"].to_numpy()) & np.isfinite(d["dhi"].to_numpy())
    st, d = st[keep][::stride], d[keep][::stride]
    states = ir.SkyStates.create(st["solar_elevation"].to_numpy(), st["azimuth"].to_numpy(),
                                 st["visibility"].to_numpy(), st["albedo"].to_numpy())
    clear = clear_plane_spectra(sky, states, abs(wd.site.latitude), 180.0)
    return states, d, clear


def _allsky(sky, states, d, clear, options):
    from widesky.irradiance.allsky import allsky_factors
    from widesky.irradiance.allsky_plane import plane_poa
    f = allsky_factors(sky.channel_edges, clear.dni, clear.dhi, states.sun_elevation, d["dni"].to_numpy(),
                       d["dhi"].to_numpy(), ghi=d["ghi"].to_numpy(), temp_dew=d["temp_dew"].to_numpy(),
                       options=options, albedo=states.albedo)
    ground = {}
    if options.ground == "vegetation":             # the default all-sky ground (irradiance.ground)
        from widesky.irradiance.ground import vegetated_steps, vegetation_albedo_shape
        ground = {"albedo_shape": vegetation_albedo_shape(sky.wavelengths), "channel_edges": sky.channel_edges,
                  "vegetated": vegetated_steps(states.albedo)}
    return plane_poa(clear, f.dni_scale, f.diffuse_scale, states.albedo, overcast_dhi=f.overcast_dhi,
                     circumsolar_dhi=f.circumsolar_dhi, **ground)


@pytest.fixture(scope="module")
def amsterdam(sky):
    states, d, clear = _amsterdam_sample(sky)
    w = np.diff(sky.channel_edges)
    sin_el = np.sin(np.radians(states.sun_elevation))
    kc = d["ghi"].to_numpy() / (((clear.dni * sin_el[:, None] + clear.dhi) * w).sum(1))
    return states, d, clear, kc, sin_el


@pytest.mark.reference
@pytest.mark.slow
@needs_data
def test_mismatch_against_pvspec(sky, amsterdam):
    pytest.importorskip("pvlib")
    from widesky.irradiance.allsky import CLEAR_SHAPE, AllSkyOptions
    states, d, clear, kc, _ = amsterdam
    wl = np.asarray(sky.wavelengths)
    sr = spectral_response(generic_eqe(wl), wl)
    pub = pvspec_published()
    mask = (kc > 0.05) & (kc < 1.5)
    allsky = _allsky(sky, states, d, clear, AllSkyOptions())["poa_global"]
    for tech, s in sr.items():
        for (lo, hi), c, v in mismatch_by_kc(allsky, kc, s, mask):
            if 0.2 <= lo < 0.8:
                assert v == pytest.approx(c ** pub[tech][0], abs=0.04), (tech, lo, hi)
    plain = _allsky(sky, states, d, clear, CLEAR_SHAPE)["poa_global"]
    b = {lo: (c, v) for (lo, _), c, v in mismatch_by_kc(plain, kc, sr["a-Si"], mask)}
    assert b[0.2][1] - b[0.2][0] ** pub["a-Si"][0] > 0.1


@pytest.mark.reference
@pytest.mark.slow
@needs_data
def test_ape_against_sedes2(sky, amsterdam):
    from widesky.core.paths import DataNotFoundError, data_file
    try:
        coeffs = data_file("validation/sedes2_cloud_cover_modifiers.csv")
    except DataNotFoundError:
        pytest.skip("SEDES2 coefficient table not in the data directory (validation/sedes2_cloud_cover_modifiers.csv)")
    from widesky.irradiance.allsky import AllSkyOptions
    states, d, clear, kc, sin_el = amsterdam
    wl, w = np.asarray(sky.wavelengths), np.diff(sky.channel_edges)
    ghi = _allsky(sky, states, d, clear, AllSkyOptions())["ghi"]
    sedes = sedes2_global_horizontal(coeffs, sky.channel_edges, clear.dni, clear.dhi, sin_el, d["ghi"].to_numpy())
    ours = dict(ape_by_kc(ghi, kc, wl, w))
    ref = dict(ape_by_kc(sedes, kc, wl, w))
    for b in ((0.4, 0.6), (0.6, 0.8)):
        assert ours[b] == pytest.approx(ref[b], abs=0.02), b


def test_pvspec_annual_weights_hours_and_clips_the_clear_sky_index():
    pytest.importorskip("pvlib")
    a1, a2, a3 = PVSPEC_ASI
    kc = np.array([1.0, 0.3, 0.01])            # the last is clipped to 0.05 (the power law diverges at 0)
    am = np.array([1.5, 3.0, 2.0])
    w = np.array([800.0, 150.0, 20.0])         # W m-2 on the plane
    annual, clear = pvspec_annual(kc, am, w)
    m = a1 * np.array([1.0, 0.3, 0.05]) ** a2 * am ** a3
    assert annual["a-Si"] == pytest.approx((m * w).sum() / w.sum() - 1.0, rel=1e-9)
    assert clear["a-Si"] == pytest.approx(a1 * 1.5 ** a3 - 1.0, rel=1e-9)
    assert set(annual) == {"a-Si", "CdTe", "c-Si", "CIGS"}
    # overcast hours raise the wide-gap technology more than the narrow-gap one (PVSPEC's a2 ordering)
    assert annual["a-Si"] - clear["a-Si"] > annual["CIGS"] - clear["CIGS"] > 0


@pytest.mark.reference
@needs_data
def test_clear_sky_airmass_trend_of_an_independent_code(sky):
    """SPCTRL2 (Bird & Riordan 1986, through pvlib) on a 52 deg south plane: a-Si loses and CIGS gains against
    G173 as the air mass grows (the direct beam reddens), the trend that docs/validation/all-sky.md section 4d sets
    beside PVSPEC's. Monotone in both, and a-Si below -3 % by AM 2.9."""
    pytest.importorskip("pvlib")
    from widesky.irradiance.allsky_compare import spctrl2_airmass_trend
    wl = np.asarray(sky.wavelengths)
    sr = spectral_response(generic_eqe(wl), wl)
    trend = spctrl2_airmass_trend(sky, sr, 52.3)
    asi = [d["a-Si"] for _, _, d in trend]
    cigs = [d["CIGS"] for _, _, d in trend]
    assert np.all(np.diff(asi) < 0) and np.all(np.diff(cigs) > 0)
    assert trend[3][1] == pytest.approx(2.9, abs=0.05) and asi[3] < -3.0


@pytest.mark.reference
@pytest.mark.slow
@needs_data
def test_amsterdam_year_against_freiburg(sky):
    import widesky.irradiance as ir
    from widesky.irradiance.allsky import AllSkyOptions, allsky_factors
    from widesky.irradiance.allsky_compare import g173_channels, spectral_effects
    from widesky.irradiance.allsky_plane import clear_plane_spectra, plane_poa
    from widesky.irradiance.ground import vegetated_steps, vegetation_albedo_shape
    from widesky.core.paths import data_file
    wd = ir.read_weather(data_file("weather/NLD_Amsterdam062400_IWEC.epw"))
    d = wd.data
    sp = wd.site.solar_position(d.index, wd.label, wd.step)
    st = ir.sky_states(sp, d, model=sky.model, prefer="aod")
    keep = (st["solar_elevation"].to_numpy() > sky.min_sun_elevation) & (d["ghi"].to_numpy() > 0)
    keep &= np.isfinite(d["dni"].to_numpy()) & np.isfinite(d["dhi"].to_numpy())
    st, d = st[keep], d[keep]
    states = ir.SkyStates.create(st["solar_elevation"].to_numpy(), st["azimuth"].to_numpy(),
                                 st["visibility"].to_numpy(), st["albedo"].to_numpy())
    clear = clear_plane_spectra(sky, states, abs(wd.site.latitude), 180.0)
    edges, wl = np.asarray(sky.channel_edges), np.asarray(sky.wavelengths)
    w = np.diff(edges)
    sr = spectral_response(generic_eqe(wl), wl)
    g173 = g173_channels(edges)
    f = allsky_factors(edges, clear.dni, clear.dhi, states.sun_elevation, d["dni"].to_numpy(), d["dhi"].to_numpy(),
                       ghi=d["ghi"].to_numpy(), visibility=st["visibility"].to_numpy(),
                       temp_dew=d["temp_dew"].to_numpy(), min_visibility=float(np.min(sky.model.visibility_range)),
                       options=AllSkyOptions(), albedo=states.albedo, earth_sun_distance=states.earth_sun_distance)
    common = dict(overcast_dhi=f.overcast_dhi, circumsolar_dhi=f.circumsolar_dhi)
    veg = plane_poa(clear, f.dni_scale, f.diffuse_scale, states.albedo, albedo_shape=vegetation_albedo_shape(wl),
                    channel_edges=edges, vegetated=vegetated_steps(states.albedo, d["snow_depth"].to_numpy()),
                    **common)["poa_global"]
    grey = plane_poa(clear, f.dni_scale, f.diffuse_scale, states.albedo, **common)["poa_global"]
    freiburg = {"a-Si": 3.4, "CdTe": 2.4, "c-Si": 1.4, "CIGS": 0.6}
    se = spectral_effects(veg.sum(0), g173, sr, w)
    se_grey = spectral_effects(grey.sum(0), g173, sr, w)
    for tech, measured in freiburg.items():
        assert abs(se[tech] - measured) <= 1.5, (tech, se[tech])
    assert se["a-Si"] > se["CdTe"] > se["c-Si"] > se["CIGS"]
    assert abs((se["a-Si"] - se["CIGS"]) - 2.8) <= 1.5
    assert se_grey["a-Si"] - freiburg["a-Si"] > 1.5                 # the grey ground: a-Si 1.9 points high
    assert (veg @ w).sum() == pytest.approx((grey @ w).sum(), rel=1e-9)
