"""All-sky factors under measured weather (issue 16): conservation, limits of the published model, options.

References and tolerances:
* Energy: the broadband DNI and DHI of the all-sky spectra equal the plain measured scaling's
  (``measured_scale_factors``: the measured values wherever its guards did not act) to 1e-12 relative.
* Ernst et al. (2016, Sol. Energy Mater. Sol. Cells 157, 913), eqs. 5-8: the cloud index is 0 when the
  measured diffuse fraction equals the clear model's and 1 when all light is diffuse; at N = 0 the
  diffuse keeps the clear shape, at N = 1 (no cloud absorption) it has the clear global spectrum's
  shape, exactly (1e-12); the beam keeps the clear shape (spectrally flat extinction of cloud particles).
* Every part off (``CLEAR_SHAPE``) gives the plain measured factors on every channel, exactly.
* On an unobstructed plane (``widesky.irradiance.allsky_plane``) the plain factors reproduce
  ``poa_irradiance(measured=...)`` on a lone panel far above the ground: direct 1e-5, sky diffuse 1 %
  (the integrator samples cut patches with rays), reflected 3 %. For a sky whose angular shape is the
  same in every channel, spectral factors leave the broadband plane-of-array irradiance unchanged
  (1e-10): the all-sky model moves light between channels, not in total.
"""

import numpy as np
import pytest
import trimesh

from widesky.core.spectral import in_band_share
from widesky.irradiance.allsky import CLEAR_SHAPE, AllSkyOptions, allsky_factors, cloud_index
from widesky.irradiance.allsky_plane import ClearPlaneSpectra, clear_plane_spectra, plane_poa
from widesky.irradiance.ground import vegetated_steps, vegetation_albedo_shape
from widesky.irradiance.integrator import IntegratorSettings
from widesky.irradiance.poa import MeasuredSky, OutputOptions, RunOptions, poa_irradiance
from widesky.irradiance.measured import measured_scale_factors
from widesky.irradiance.scene import make_scene
from widesky.irradiance.skies import AnalyticSky, SkyStates


EDGES = np.arange(280.0, 2480.1, 40.0)
LAM = 0.5 * (EDGES[1:] + EDGES[:-1])
W = np.diff(EDGES)


def clear_spectra(T=5):
    """Smooth clear-sky-like spectra: a reddish beam and a Rayleigh-blue diffuse [W m-2 nm-1]."""
    el = np.linspace(10.0, 60.0, T)
    bn = np.exp(-0.5 * ((LAM - 750) / 450) ** 2)[None, :] * (0.5 + el / 100)[:, None]
    dh = 0.25 * bn * (LAM / 500.0)[None, :] ** -3.5
    return el, bn, dh


def measured(el, bn, dh, dni_frac, dhi_frac):
    return (bn @ W) * dni_frac, (dh @ W) * dhi_frac


def test_broadband_is_conserved():
    el, bn, dh = clear_spectra()
    dni, dhi = measured(el, bn, dh, np.array([0.0, 0.2, 0.6, 1.0, 1.1]), np.array([3.5, 3.0, 1.5, 1.0, 0.9]))
    ref = measured_scale_factors(bn @ W, dh @ W, dni, dhi, missing="clear")
    for opt in (AllSkyOptions(cloud_absorption=False, cloud_vapour=False, angular="clear"),
                AllSkyOptions(cloud_absorption=False, cloud_vapour=False)):
        f = allsky_factors(EDGES, bn, dh, el, dni, dhi, options=opt)
        np.testing.assert_allclose((f.dni_scale * bn) @ W, ref.sun_scale * (bn @ W), rtol=1e-12)
        np.testing.assert_allclose((f.diffuse_scale * dh) @ W + (f.overcast_dhi + f.circumsolar_dhi) @ W,
                                   ref.sky_scale * (dh @ W), rtol=1e-12)
        assert not np.any(ref.sun_guarded | ref.sky_guarded)
        np.testing.assert_allclose((f.dni_scale * bn) @ W, dni, rtol=1e-12)
        np.testing.assert_allclose((f.diffuse_scale * dh) @ W + (f.overcast_dhi + f.circumsolar_dhi) @ W, dhi,
                                   rtol=1e-12)


def test_clear_shape_is_the_plain_measured_path():
    el, bn, dh = clear_spectra()
    dni, dhi = measured(el, bn, dh, np.array([0.0, 0.2, 0.6, 1.0, np.nan]), np.array([5.0, 3.0, 1.5, 1.0, 1.0]))
    f = allsky_factors(EDGES, bn, dh, el, dni, dhi, options=CLEAR_SHAPE)
    ref = measured_scale_factors(bn @ W, dh @ W, dni, dhi, missing="clear")
    np.testing.assert_allclose(f.dni_scale, np.broadcast_to(ref.sun_scale[:, None], bn.shape), rtol=1e-12)
    np.testing.assert_allclose(f.diffuse_scale, np.broadcast_to(ref.sky_scale[:, None], dh.shape), rtol=1e-12)
    assert np.all(f.overcast_dhi == 0) and np.all(f.circumsolar_dhi == 0) and np.all(f.cloud_index == 0)


def test_ernst_limits():
    el, bn, dh = clear_spectra(3)
    sin_el = np.sin(np.radians(el))
    g = bn * sin_el[:, None] + dh
    # step 0: clear (measured = model, N = 0); step 1: overcast (no beam, N = 1); step 2: halfway
    dni = np.array([bn[0] @ W, 0.0, 0.5 * (bn[2] @ W)])
    dhi = np.array([dh[0] @ W, g[1] @ W * 0.3, dh[2] @ W * 1.4])
    opt = AllSkyOptions(cloud_absorption=False, cloud_vapour=False, cloud_rayleigh=False, angular="clear")
    f = allsky_factors(EDGES, bn, dh, el, dni, dhi, options=opt)
    assert f.cloud_index[0] == pytest.approx(0.0, abs=1e-12) and f.cloud_index[1] == 1.0
    assert 0 < f.cloud_index[2] < 1
    np.testing.assert_allclose(f.diffuse_scale[0], 1.0, rtol=1e-12)            # clear shape kept
    d1 = f.diffuse_scale[1] * dh[1]
    np.testing.assert_allclose(d1 / (d1 @ W), g[1] / (g[1] @ W), rtol=1e-12)   # global's shape
    np.testing.assert_allclose(f.dni_scale[2], f.dni_scale[2, 0], rtol=1e-12)  # neutral beam
    # the same through the CIE overcast part: the overcast light carries the global's shape
    f2 = allsky_factors(EDGES, bn, dh, el, dni, dhi, options=AllSkyOptions(
        cloud_absorption=False, cloud_vapour=False, cloud_rayleigh=False))
    np.testing.assert_allclose(f2.overcast_dhi[1] / (f2.overcast_dhi[1] @ W), g[1] / (g[1] @ W), rtol=1e-12)
    np.testing.assert_allclose(f2.diffuse_scale[1], 0.0, atol=1e-12)
    # overcast light is far less blue than the scaled clear diffuse
    blue, red = np.argmin(np.abs(LAM - 420)), np.argmin(np.abs(LAM - 900))
    assert d1[blue] / d1[red] < 0.5 * dh[1, blue] / dh[1, red]


def test_cloud_index_formula():
    np.testing.assert_allclose(cloud_index([100.0, 500.0, 250.0, 10.0], [500.0, 500.0, 500.0, 0.0],
                                           [0.2, 0.2, 0.2, 0.2]), [0.0, 1.0, 0.375, 0.0])
    assert cloud_index([np.nan], [100.0], [0.1])[0] == 0.0


def test_cloud_water_deepens_the_nir():
    el, bn, dh = clear_spectra(2)
    dni, dhi = np.zeros(2), np.array([0.05, 0.4]) * ((bn * np.sin(np.radians(el))[:, None] + dh) @ W)
    dry = allsky_factors(EDGES, bn, dh, el, dni, dhi, options=AllSkyOptions(cloud_absorption=False,
                                                                             cloud_vapour=False))
    wet = allsky_factors(EDGES, bn, dh, el, dni, dhi, temp_dew=np.array([10.0, 10.0]))
    assert wet.cloud_tau[0] > wet.cloud_tau[1] > 0 and wet.cloud_vapour[0] > 0
    r = wet.overcast_dhi / dry.overcast_dhi
    i1450, i940, i550 = (np.argmin(np.abs(LAM - x)) for x in (1460, 940, 540))
    assert r[0, i1450] < 0.7 * r[0, i550] and r[0, i940] < r[0, i550]        # water bands deeper
    assert r[0, i1450] < r[1, i1450]                                          # thicker cloud, deeper
    np.testing.assert_allclose((wet.overcast_dhi + wet.circumsolar_dhi) @ W, dhi, rtol=1e-12)  # DHI measured


def test_options_and_shapes_are_checked():
    el, bn, dh = clear_spectra(2)
    with pytest.raises(ValueError, match="haze"):
        AllSkyOptions(haze="fog")
    with pytest.raises(ValueError, match="angular"):
        AllSkyOptions(angular="perez1990")
    with pytest.raises(ValueError, match="dni_clear"):
        allsky_factors(EDGES, bn[:, :3], dh, el, [1, 1], [1, 1])
    with pytest.raises(ValueError, match="channel_edges"):
        allsky_factors(EDGES[::-1], bn, dh, el, [1, 1], [1, 1])
    with pytest.raises(ValueError, match="negative"):
        allsky_factors(EDGES, bn, dh, el, [-1.0, 1], [1, 1])


def _panel(tilt, z=200.0, size=0.5):
    h = size / 2
    v = np.array([[-h, -h, 0], [h, -h, 0], [h, h, 0], [-h, h, 0]], dtype=float)
    t = np.radians(tilt)
    rot = np.array([[1, 0, 0], [0, np.cos(t), -np.sin(t)], [0, np.sin(t), np.cos(t)]])  # tilt toward south
    v = v @ rot.T
    v[:, 2] += z
    return trimesh.Trimesh(v, [[0, 1, 2], [0, 2, 3]], process=False)


class RedSunSky(AnalyticSky):
    """AnalyticSky (same angular shape in every channel) with a redder sun than sky."""

    def direct_normal(self, states):
        return super().direct_normal(states) * (self.wavelengths / 500.0) ** 1.5


def test_plane_path_matches_the_integrator_and_conserves_energy():
    sky = RedSunSky()
    states = SkyStates.create([12.0, 30.0, 55.0], [120.0, 180.0, 230.0], 30.0, 0.2)
    settings = IntegratorSettings(rays_per_patch=4)
    scene = make_scene(_panel(40.0), ground_z=0.0, analysis_reflectance=0.0)
    clear = clear_plane_spectra(sky, states, 40.0, 180.0, settings)
    w = np.diff(sky.channel_edges)
    dni, dhi = (clear.dni @ w) * np.array([0.0, 0.5, 0.9]), (clear.dhi @ w) * np.array([3.0, 1.6, 1.0])
    res = poa_irradiance(scene, sky, states, settings=settings, weather=MeasuredSky(measured=(dni, dhi)),
                         run=RunOptions(n_jobs=1))
    share = in_band_share(sky.channel_edges[0], sky.channel_edges[-1])   # measured is broadband (issue 35)
    ref = measured_scale_factors(clear.dni @ w, clear.dhi @ w, dni * share, dhi * share, missing="clear")
    plain = plane_poa(clear, ref.sun_scale, ref.sky_scale, states.albedo)
    np.testing.assert_allclose(plain["poa_direct"] @ w, res.poa_direct[:, 0], rtol=1e-5, atol=1e-3)
    np.testing.assert_allclose(plain["poa_sky_diffuse"] @ w, res.poa_sky_diffuse[:, 0], rtol=1e-2)
    np.testing.assert_allclose(plain["poa_ground_diffuse"] @ w, res.poa_ground_diffuse[:, 0], rtol=3e-2)
    opt = AllSkyOptions(cloud_absorption=False, cloud_vapour=False, angular="clear")
    f = allsky_factors(sky.channel_edges, clear.dni, clear.dhi, states.sun_elevation, dni, dhi, options=opt,
                       in_band_share=share)
    spec = plane_poa(clear, f.dni_scale, f.diffuse_scale, states.albedo)
    np.testing.assert_allclose(spec["poa_global"] @ w, plain["poa_global"] @ w, rtol=1e-10)
    assert not np.allclose(spec["poa_global"], plain["poa_global"], rtol=1e-3)     # the shape moved


@pytest.mark.parametrize("angular", ["clear", "cie_overcast", "perez"])
def test_integrator_allsky_matches_the_plane_path(angular):
    from widesky.irradiance.allsky_sky import AllSkyWeather
    sky = RedSunSky()
    states = SkyStates.create([12.0, 30.0, 55.0], [120.0, 180.0, 230.0], 30.0, 0.2)
    settings = IntegratorSettings(rays_per_patch=4)
    clear = clear_plane_spectra(sky, states, 40.0, 180.0, settings)
    w = np.diff(sky.channel_edges)
    dni, dhi = (clear.dni @ w) * np.array([0.0, 0.5, 0.9]), (clear.dhi @ w) * np.array([3.0, 1.6, 1.0])
    opt = AllSkyOptions(cloud_absorption=False, cloud_vapour=False, angular=angular)
    f = allsky_factors(sky.channel_edges, clear.dni, clear.dhi, states.sun_elevation, dni, dhi, options=opt,
                       in_band_share=in_band_share(sky.channel_edges[0], sky.channel_edges[-1]))  # broadband
    ratio = None
    if angular == "perez":                 # the cloud light completes the Perez sky: the clear sky's patches
        from widesky.irradiance.allsky_plane import clear_patch_broadband, cloud_poa_ratio
        ratio = cloud_poa_ratio(f, states.sun_direction, 40.0, 180.0, settings,
                                clear=(*clear_patch_broadband(sky, states, settings), clear.dhi, sky.channel_edges))
    # the default all-sky ground is vegetated (albedo 0.2, no snow): the same rule on both paths
    ref = plane_poa(clear, f.dni_scale, f.diffuse_scale, states.albedo, overcast_dhi=f.overcast_dhi,
                    circumsolar_dhi=f.circumsolar_dhi, albedo_shape=vegetation_albedo_shape(sky.wavelengths),
                    channel_edges=sky.channel_edges, vegetated=vegetated_steps(states.albedo), overcast_ratio=ratio)
    assert (angular == "cie_overcast") == np.any(f.circumsolar_dhi > 0)
    scene = make_scene([_panel(40.0), _panel(0.0, z=150.0)], ground_z=0.0, analysis_reflectance=0.0)
    res = poa_irradiance(scene, sky, states, settings=settings,
                         weather=MeasuredSky(measured=AllSkyWeather(dni, dhi), spectral_model="allsky",
                                             allsky_options=opt),
                         run=RunOptions(n_jobs=1), output=OutputOptions(spectral=True))
    np.testing.assert_allclose(res.poa_direct[:, 0], ref["poa_direct"] @ w, rtol=1e-4, atol=1e-3)
    np.testing.assert_allclose(res.poa_sky_diffuse[:, 0], ref["poa_sky_diffuse"] @ w, rtol=1e-2)
    np.testing.assert_allclose(res.poa_ground_diffuse[:, 0], ref["poa_ground_diffuse"] @ w, rtol=3e-2)
    # the horizontal face (2 mesh faces per panel: face 2) receives exactly the measured DNI and DHI (in-band share)
    el = np.radians(states.sun_elevation)
    share = in_band_share(sky.channel_edges[0], sky.channel_edges[-1])
    np.testing.assert_allclose(res.poa_direct[:, 2] + res.poa_sky_diffuse[:, 2], (dni * np.sin(el) + dhi) * share,
                               rtol=2e-3)
    np.testing.assert_allclose(res.scaling.sun_scale, dni * share / (clear.dni @ w), rtol=1e-9)
    # spectral global on the tilted face follows the all-sky shape
    g = res.spectral["global"][:, 0, :]
    np.testing.assert_allclose(g / (g @ w)[:, None], ref["poa_global"] / (ref["poa_global"] @ w)[:, None],
                               rtol=0.03, atol=1e-6)
    gr = res.spectral["ground_diffuse"][:, 0, :]             # the vegetated ground's reflected spectrum
    np.testing.assert_allclose(gr, ref["poa_ground_diffuse"], rtol=0.03, atol=1e-6)
    with pytest.raises(ValueError, match="spectral_model"):
        poa_irradiance(scene, sky, states, weather=MeasuredSky(spectral_model="cloudy"))
    with pytest.raises(ValueError, match="needs measured"):
        poa_irradiance(scene, sky, states, weather=MeasuredSky(spectral_model="allsky"))


@pytest.mark.reference
def test_aod_column_keeps_amsterdam_inside_the_dataset():
    import warnings

    from widesky.irradiance.skystate import sky_states_for
    from widesky.irradiance.weather import read_weather
    from widesky.core.paths import data_file
    wd = read_weather(data_file("weather/NLD_Amsterdam062400_IWEC.epw"))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        st_v = sky_states_for(wd, prefer="visibility")
        st_a = sky_states_for(wd, prefer="aod")
    up = st_v.sun_elevation > 0
    # docs/all-sky.md: station visibility clamps 58.6 % of daylight hours (with GHI > 0), the AOD column none
    assert 0.55 < st_v.clamped["visibility"][up].mean() < 0.62
    assert st_a.clamped["visibility"][up].mean() < 0.005


def test_sky_fraction_partition():
    """The clear sky's own diffuse is kept only on the cloud-free share (1 - N) of the sky: the clear part
    is min(DHI, (1 - N) D_clear) [W m-2], the rest of the DHI is cloud light; Ernst's partition keeps
    (1 - N) DHI. Overcast (N = 1) and a sky as clear as the model (N = 0, DHI = D_clear) agree."""
    el, bn, dh = clear_spectra(4)
    sin_el = np.sin(np.radians(el))
    g = bn * sin_el[:, None] + dh
    d0 = dh @ W
    # steps: as clear as the model; overcast; broken cloud (half the beam, DHI 2.5 x clear); bright
    # broken cloud (1.6 x the clear beam, DHI 1.5 x clear: N = 0, more diffuse than the clear sky)
    dni = np.array([bn[0] @ W, 0.0, 0.5 * (bn[2] @ W), 1.6 * (bn[3] @ W)])
    dhi = np.array([d0[0], 0.3 * (g[1] @ W), 2.5 * d0[2], 1.5 * d0[3]])
    base = dict(cloud_absorption=False, cloud_vapour=False, cloud_rayleigh=False)
    sky = allsky_factors(EDGES, bn, dh, el, dni, dhi, options=AllSkyOptions(**base))
    ern = allsky_factors(EDGES, bn, dh, el, dni, dhi, options=AllSkyOptions(partition="ernst", **base))
    n = sky.cloud_index
    np.testing.assert_allclose(n, ern.cloud_index, rtol=1e-12)
    clear_sky = (sky.diffuse_scale * dh) @ W
    clear_ern = (ern.diffuse_scale * dh) @ W
    np.testing.assert_allclose(clear_sky, np.minimum(dhi, (1 - n) * d0), rtol=1e-12)
    np.testing.assert_allclose(clear_ern, (1 - n) * dhi, rtol=1e-12)
    np.testing.assert_allclose(clear_sky[:2], clear_ern[:2], rtol=1e-12, atol=1e-12)
    assert 0 < n[2] < 1 and clear_sky[2] < clear_ern[2]
    assert n[3] == 0 and clear_sky[3] == pytest.approx(d0[3]) and clear_ern[3] == pytest.approx(dhi[3])
    np.testing.assert_allclose(clear_sky + (sky.overcast_dhi + sky.circumsolar_dhi) @ W, dhi, rtol=1e-12)
    with pytest.raises(ValueError, match="partition"):
        AllSkyOptions(partition="half")


def test_perez_circumsolar_fraction_matches_pvlib():
    """F1 of Perez et al. (1990) against pvlib's implementation of the same published model (its circumsolar
    component on a horizontal plane is DHI F1 a / b): the same numbers to rounding."""
    pvlib = pytest.importorskip("pvlib")
    from widesky.irradiance.overcast_sky import perez_circumsolar_fraction
    rng = np.random.default_rng(7)
    el, dhi, dni = rng.uniform(2, 89, 300), rng.uniform(10, 450, 300), rng.uniform(0, 950, 300)
    am = pvlib.atmosphere.get_relative_airmass(90 - el, "kastenyoung1989")
    f1 = perez_circumsolar_fraction(dhi, dni, el, 1361.0)
    out = pvlib.irradiance.perez(0.0, 180.0, dhi, dni, 1361.0, 90 - el, 180.0, am, return_components=True)
    z = np.radians(90 - el)
    f1_pvlib = np.asarray(out["poa_circumsolar"]) * np.maximum(np.cos(np.radians(85)), np.cos(z)) / (dhi * np.cos(z))
    np.testing.assert_allclose(f1, f1_pvlib, rtol=1e-9, atol=1e-12)
    assert 0.1 < f1.mean() < 0.9 and np.all(f1 >= 0)
    np.testing.assert_array_equal(perez_circumsolar_fraction([0.0, np.nan, 100.0], [500.0, 0.0, 300.0],
                                                             [30.0, 30.0, -1.0]), 0.0)


def test_cloud_circumsolar_share():
    """With ``angular="cie_overcast", circumsolar="perez"`` the share F1 of the cloud light (tapered below 5 deg of sun) moves from the CIE
    overcast part to the sun; the DHI and the spectral shape of the cloud light stay; "none" keeps it all CIE."""
    from widesky.irradiance.overcast_sky import perez_circumsolar_fraction
    el, bn, dh = clear_spectra(3)
    el = np.array([3.0, 35.0, 60.0])
    dni = np.array([0.2, 0.4, 0.0]) * (bn @ W)
    dhi = np.array([2.0, 2.5, 1.2]) * (dh @ W)
    base = dict(cloud_absorption=False, cloud_vapour=False, cloud_rayleigh=False, angular="cie_overcast")
    on = allsky_factors(EDGES, bn, dh, el, dni, dhi, options=AllSkyOptions(**base), earth_sun_distance=0.99)
    off = allsky_factors(EDGES, bn, dh, el, dni, dhi, options=AllSkyOptions(circumsolar="none", **base))
    np.testing.assert_allclose(off.circumsolar_dhi, 0.0)
    np.testing.assert_allclose(on.overcast_dhi + on.circumsolar_dhi, off.overcast_dhi, rtol=1e-12)
    f1 = perez_circumsolar_fraction(dhi, dni, el, 1361.0 / 0.99 ** 2)
    f1 = np.minimum(f1, 1.0) * np.minimum(1.0, np.sin(np.radians(el)) / np.sin(np.radians(5.0)))   # at most all
    np.testing.assert_allclose(on.circumsolar_dhi @ W, f1 * (off.overcast_dhi @ W), rtol=1e-12)
    assert np.all(on.circumsolar_dhi[1:] @ W > 0)
    np.testing.assert_allclose(on.diffuse_scale, off.diffuse_scale, rtol=1e-12)
    with pytest.raises(ValueError, match="circumsolar"):
        AllSkyOptions(circumsolar="ring")


def test_spectral_ground_keeps_the_broadband_albedo():
    """An albedo shape changes the reflected spectrum, not the reflected broadband irradiance (the weather
    file's albedometer value); a vegetation shape sends more NIR than visible light to the plane."""
    edges = np.arange(280.0, 2481.0, 40.0)
    wl, C, T = 0.5 * (edges[1:] + edges[:-1]), 55, 3
    rng = np.random.default_rng(4)
    clear = ClearPlaneSpectra(dni=rng.uniform(0.2, 1.5, (T, C)), dhi=rng.uniform(0.05, 0.4, (T, C)),
                              circumsolar=np.zeros((T, C)), poa_sky=rng.uniform(0.05, 0.4, (T, C)),
                              cos_aoi=np.array([0.9, 0.6, 0.3]), sin_elevation=np.array([0.8, 0.5, 0.2]),
                              overcast_ratio=0.9, view_ground=0.19)
    albedo = np.array([0.2, 0.25, 0.6])
    grey = plane_poa(clear, np.ones(T), np.ones(T), albedo)
    shape = vegetation_albedo_shape(wl)
    veg = plane_poa(clear, np.ones(T), np.ones(T), albedo, albedo_shape=shape, channel_edges=edges)
    w = np.diff(edges)
    np.testing.assert_allclose(veg["poa_ground_diffuse"] @ w, grey["poa_ground_diffuse"] @ w, rtol=1e-12)
    np.testing.assert_array_equal(veg["poa_sky_diffuse"], grey["poa_sky_diffuse"])
    ratio = veg["poa_ground_diffuse"] / grey["poa_ground_diffuse"]
    vis, nir = (wl > 420) & (wl < 680), (wl > 780) & (wl < 1250)
    assert np.all(ratio[:, vis].max(1) < 0.35) and np.all(ratio[:, nir].min(1) > 1.5)
    assert shape[wl < 650].max() < 0.06 and shape[(wl > 780) & (wl < 1250)].min() > 0.4
    with pytest.raises(ValueError, match="channel_edges"):
        plane_poa(clear, np.ones(T), np.ones(T), albedo, albedo_shape=shape)
    with pytest.raises(ValueError, match="albedo_shape"):
        plane_poa(clear, np.ones(T), np.ones(T), albedo, albedo_shape=shape[:10], channel_edges=edges)


def test_ground_scales_keep_the_broadband_albedo_and_fall_back_to_grey():
    """widesky.irradiance.ground: vegetated steps (albedo <= 0.3, no snow reported) reflect the vegetation shape
    scaled so that the reflected broadband irradiance is albedo x GHI, as for a grey ground; snow, a bright
    ground and a spectrum the scaled shape could not reflect (albedo > 1 in a channel) stay grey."""
    from widesky.irradiance.ground import VEGETATION_MAX_ALBEDO, ground_scales, step_spectral_albedo
    edges = np.arange(280.0, 2481.0, 40.0)
    wl, w = 0.5 * (edges[1:] + edges[:-1]), np.diff(edges)
    shape = vegetation_albedo_shape(wl)
    rng = np.random.default_rng(7)
    G = rng.uniform(0.1, 1.5, (6, wl.size))
    G[4] = np.where((wl > 400) & (wl < 650), 1.0, 0.0)       # visible light only: n = 0.05
    G[5] = 0.0                                               # no light
    albedo = np.array([0.2, 0.25, 0.6, 0.2, 0.3, 0.2])
    snow = np.array([np.nan, 0.0, np.nan, 5.0, np.nan, np.nan])
    veg = vegetated_steps(albedo, snow)
    np.testing.assert_array_equal(veg, [True, True, False, False, True, True])
    assert VEGETATION_MAX_ALBEDO == 0.30
    a1, a0 = ground_scales(shape, G, w, albedo, veg)
    np.testing.assert_array_equal(a1 > 0, [True, True, False, False, False, False])
    np.testing.assert_array_equal(a0, np.where(a1 > 0, 0.0, albedo))
    alb = step_spectral_albedo(shape, a1, a0)
    assert alb.max() <= 1.0 and alb.min() >= 0.0
    np.testing.assert_allclose((alb * G * w).sum(1), albedo * (G * w).sum(1), rtol=1e-12)
    assert np.all(alb[:2, (wl > 420) & (wl < 680)] < 0.06) and np.all(alb[:2, (wl > 780) & (wl < 1250)] > 0.3)
    np.testing.assert_array_equal(vegetated_steps([0.2, np.nan, 0.31]), [True, False, False])


def test_integrator_vegetated_ground_conserves_the_reflected_broadband():
    """AllSkyOptions(ground=...): the vegetated ground changes the reflected spectrum, not the reflected
    broadband irradiance of each step (nor the sky or the beam); on a step with snow it is grey."""
    from widesky.irradiance.allsky_sky import AllSkyWeather
    sky = RedSunSky()
    states = SkyStates.create([12.0, 30.0, 55.0], [120.0, 180.0, 230.0], 30.0, 0.2)
    settings = IntegratorSettings(rays_per_patch=4)
    scene = make_scene(_panel(40.0), ground_z=0.0, analysis_reflectance=0.0)
    dni, dhi = np.array([0.0, 300.0, 700.0]), np.array([250.0, 200.0, 110.0])
    runs = {}
    for ground in ("vegetation", "grey"):
        opt = AllSkyOptions(cloud_absorption=False, cloud_vapour=False, ground=ground)
        runs[ground] = poa_irradiance(scene, sky, states, settings=settings, run=RunOptions(n_jobs=1),
                                      weather=MeasuredSky(measured=AllSkyWeather(
                                          dni, dhi, snow_depth=np.array([np.nan, 0.0, 3.0])),
                                          spectral_model="allsky", allsky_options=opt),
                                      output=OutputOptions(spectral=True))
    veg, grey = runs["vegetation"], runs["grey"]
    # exact for the unshaded ground's light; the panel's own shadow on the ground removes more beam (redder
    # than the sky light, so reflected more by vegetation) than sky light: 4e-4 here
    np.testing.assert_allclose(veg.poa_ground_diffuse, grey.poa_ground_diffuse, rtol=2e-3)
    np.testing.assert_allclose(veg.poa_sky_diffuse, grey.poa_sky_diffuse, rtol=1e-6)
    np.testing.assert_allclose(veg.poa_direct, grey.poa_direct, rtol=1e-6)
    wl = sky.wavelengths
    ratio = veg.spectral["ground_diffuse"][:, 0, :] / grey.spectral["ground_diffuse"][:, 0, :]
    vis, nir = (wl > 420) & (wl < 680), (wl > 780) & (wl < 1250)
    assert np.all(ratio[:2][:, vis] < 0.35) and np.all(ratio[:2][:, nir] > 1.5)
    np.testing.assert_allclose(ratio[2], 1.0, rtol=1e-5)                  # snow: grey
    with pytest.raises(ValueError, match="ground"):
        AllSkyOptions(ground="sand")


def test_allsky_chunk_in_blocks_is_the_whole_chunk(monkeypatch):
    """allsky_patch_radiance evaluates a chunk in cache-sized blocks of steps (issue 36): every output, the
    factors' fields included, is the one-block result in the same step order (1e-12 relative: the same
    arithmetic per step); clear_plane_spectra's chunks (64 by default) do not change its values; and the
    vectorised spectral cloud transmittance is the per-channel slab's, exactly."""
    from widesky.irradiance import allsky_sky
    from widesky.irradiance.allsky_sky import AllSkyWeather, allsky_patch_radiance
    from widesky.irradiance.cloud_optics import cloud_spectral_transmittance, mie_droplet_optics, slab_transmittance
    from widesky.irradiance.patches import reinhart
    sky = RedSunSky()
    T = 37
    rng = np.random.default_rng(3)
    states = SkyStates.create(rng.uniform(3.0, 70.0, T), rng.uniform(60.0, 300.0, T), 30.0, 0.2)
    settings = IntegratorSettings()
    patches = reinhart(settings.mf)
    dni, dhi = rng.uniform(0.0, 800.0, T), rng.uniform(20.0, 400.0, T)
    weather = AllSkyWeather(dni, dhi, visibility=np.full(T, 12.0), temp_dew=np.full(T, 5.0),
                            snow_depth=np.where(np.arange(T) % 5 == 0, 3.0, 0.0))
    Wc = np.stack([np.diff(sky.channel_edges), np.linspace(0.0, 1.0, sky.n_channels)], axis=1)
    shape = vegetation_albedo_shape(sky.wavelengths)
    whole = allsky_patch_radiance(sky, patches, states, Wc, settings, weather, ground_shape=shape)
    monkeypatch.setattr(allsky_sky, "_BLOCK_BYTES", 1)                  # blocks of 16 steps: 16, 16, 5
    blocks = allsky_patch_radiance(sky, patches, states, Wc, settings, weather, ground_shape=shape)

    def leaves(x, name="out"):
        if isinstance(x, tuple):
            for k, v in zip(getattr(x, "_fields", range(len(x))), x):
                yield from leaves(v, f"{name}.{k}")
        elif x is not None:
            yield name, np.asarray(x)

    a, b = dict(leaves(whole)), dict(leaves(blocks))
    assert a.keys() == b.keys() and len(a) > 20
    for k in a:
        assert a[k].shape == b[k].shape, k
        if a[k].dtype == bool:
            assert np.array_equal(a[k], b[k]), k
        else:
            np.testing.assert_allclose(b[k], a[k], rtol=1e-12, atol=1e-12 * np.nanmax(np.abs(a[k]), initial=0.0),
                                       err_msg=k)
    assert a["out.2.cloud_index"].max() > 0.2                          # cloudy steps are in the sample
    one, parts = (clear_plane_spectra(sky, states, 30.0, 180.0, settings, chunk=n) for n in (64, 16))
    for x, y in zip(one, parts):
        np.testing.assert_array_equal(np.asarray(x), np.asarray(y))
    ext, co, g = mie_droplet_optics(sky.wavelengths)
    tau = np.array([0.0, 2.0, 15.0, 80.0])
    per_channel = np.stack([slab_transmittance(tau * ext[j], co[j], g[j]) for j in range(ext.size)], axis=1)
    np.testing.assert_array_equal(cloud_spectral_transmittance(tau, ext, co, g),
                                  per_channel / slab_transmittance(tau, 0.0, 0.86)[:, None])
