"""The all-sky model's cloudy spectra against radiative transfer with a cloud layer (docs/validation/all-sky.md, 4e).

Reference: the dataset's clear atmosphere (US standard, OPAC continental aerosol AOD550 0.1, 6S k-distribution
gases) with a stratiform water cloud of optical depth 20 (Mie droplets r_eff 10 um, saturated, base 1 km),
fluxes by DISORT (16 streams, delta-M) with a grey ground of albedo 0.2, sun at 40 deg
(``widesky.skymodel.generator.cloud_reference.cloudy_fluxes``). The model gets the reference's broadband DNI and DHI as the
weather and its cloud-free solve as the clear sky. Tolerances at sun 40 deg: average photon energy 340-1060 nm
within 0.01 eV of the reference (the cloud shifts it by +0.044 eV), the mismatch of generic a-Si, CdTe, c-Si and
CIGS responses relative to the clear spectrum within 1.5 points (a-Si: +13 %), band ratios within 0.03; the model
before the Mie droplets and the two-stream vapour path misses a-Si by more than 3 points (the test can fail).
At sun 60 deg APE within 0.01 eV and a-Si within 2.5 points; at sun 20 deg (where the reference's thin-cloud
light is bluer than the model's, docs/validation/all-sky.md 4e) the model is nearer the reference than before in APE and
a-Si.
"""

import numpy as np
import pytest

pytestmark = [pytest.mark.reference, pytest.mark.slow]


@pytest.fixture(scope="module")
def case():
    pytest.importorskip("disortpp")
    from widesky.skymodel.generator.cloud_reference import cloudy_fluxes
    return cloudy_fluxes(0.0, 40.0), cloudy_fluxes(20.0, 40.0)


def _mismatch(g, ref, s, w):
    return ((g * s * w).sum() / (g * w).sum()) / ((ref * s * w).sum() / (ref * w).sum()) - 1.0


def test_reference_cloud_is_physical(case):
    clear, cloudy = case
    w = np.full(clear.ghi.size, 40.0)
    kc = (cloudy.ghi @ w) / (clear.ghi @ w)
    assert 0.25 < kc < 0.45                                   # two-stream with ground reflection: 0.33
    assert cloudy.direct_horizontal @ w < 1e-6 * (clear.direct_horizontal @ w)
    assert cloudy.cloud_top_km == pytest.approx(1.0 + 0.4444, abs=1e-3)
    assert 270.0 < cloudy.cloud_temperature_k < 285.0


def test_model_follows_the_reference_cloud(case):
    from widesky.irradiance.allsky import AllSkyOptions
    from widesky.irradiance.allsky_compare import ape, generic_eqe, spectral_response
    from widesky.skymodel.generator.cloud_reference import allsky_global_horizontal
    clear, cloudy = case
    wl, w = clear.wavelength_nm, np.full(clear.ghi.size, 40.0)
    sr = spectral_response(generic_eqe(wl), wl)
    model = allsky_global_horizontal(clear, cloudy, 40.0)
    before = allsky_global_horizontal(clear, cloudy, 40.0, AllSkyOptions(droplet_optics="adt", vapour_path="diffusion"))
    np.testing.assert_allclose(model @ w, cloudy.ghi @ w, rtol=1e-9)            # broadband kept
    shift = ape(cloudy.ghi, wl, w) - ape(clear.ghi, wl, w)
    assert shift > 0.03
    assert abs(ape(model, wl, w) - ape(cloudy.ghi, wl, w)) < 0.01
    for t, s in sr.items():
        assert abs(_mismatch(model, clear.ghi, s, w) - _mismatch(cloudy.ghi, clear.ghi, s, w)) < 0.015, t
    assert _mismatch(cloudy.ghi, clear.ghi, sr["a-Si"], w) - _mismatch(before, clear.ghi, sr["a-Si"], w) > 0.03
    band = (wl > 380) & (wl < 1300)
    for lo, hi in ((380, 500), (500, 700), (700, 900), (900, 1100), (1100, 1300)):
        sel = (wl > lo) & (wl < hi)
        q = [(g[sel] @ w[sel]) / (clear.ghi[sel] @ w[sel]) / ((g[band] @ w[band]) / (clear.ghi[band] @ w[band]))
             for g in (cloudy.ghi, model)]
        assert q[1] == pytest.approx(q[0], abs=0.03), (lo, hi)


@pytest.mark.parametrize("elevation", [20.0, 60.0])
def test_model_against_the_reference_cloud_at_other_suns(elevation):
    pytest.importorskip("disortpp")
    from widesky.irradiance.allsky import AllSkyOptions
    from widesky.irradiance.allsky_compare import ape, generic_eqe, spectral_response
    from widesky.skymodel.generator.cloud_reference import allsky_global_horizontal, cloudy_fluxes
    clear, cloudy = cloudy_fluxes(0.0, elevation), cloudy_fluxes(20.0, elevation)
    wl, w = clear.wavelength_nm, np.full(clear.ghi.size, 40.0)
    s = spectral_response(generic_eqe(wl), wl)["a-Si"]
    model = allsky_global_horizontal(clear, cloudy, elevation)
    before = allsky_global_horizontal(clear, cloudy, elevation,
                                      AllSkyOptions(droplet_optics="adt", vapour_path="diffusion"))
    d_ape = [abs(ape(g, wl, w) - ape(cloudy.ghi, wl, w)) for g in (model, before)]
    d_asi = [abs(_mismatch(g, clear.ghi, s, w) - _mismatch(cloudy.ghi, clear.ghi, s, w)) for g in (model, before)]
    if elevation >= 60.0:
        assert d_ape[0] < 0.01 and d_asi[0] < 0.025
    assert d_ape[0] < d_ape[1] and d_asi[0] < d_asi[1]
