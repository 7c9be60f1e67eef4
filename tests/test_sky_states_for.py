"""One sky-state path (irradiance.sky_states_for) and the Earth-Sun distance.

References and tolerances:
* the Earth-Sun distance of the states is NREL SPA's (Reda & Andreas 2004), checked against pvlib's
  independent implementation (pvlib.solarposition.nrel_earthsun_distance) within 1e-6 AU;
* a fixed atmosphere (the same sun elevation, visibility, albedo every day) gives a daily clear-sky
  direct normal irradiance proportional to 1 / r**2 (the dataset's extraterrestrial spectrum is at
  1 AU) within float rounding (1e-9), i.e. about +3.4 % in early January and -3.3 % in early July
  relative to 1 AU;
* values outside the dataset's ranges are clamped, counted in a UserWarning and flagged per step.
"""

import numpy as np
import pandas as pd
import pytest

from widesky.irradiance import Site, SkyStates, model_irradiance, sky_states_for
from widesky.irradiance.skies import PragueSky
from widesky.irradiance.weather import write_epw

pvlib = pytest.importorskip("pvlib")

SITE = Site(50.08, 14.42, 200.0, tz="Europe/Prague")


def test_site_period_states_carry_the_spa_earth_sun_distance():
    st = sky_states_for(SITE, "2023-01-01", "2024-01-01", "1D", label="left")
    assert len(st) == 365 and st.times.tz is not None
    mid = st.times + pd.Timedelta("12h")
    want = pvlib.solarposition.nrel_earthsun_distance(mid).to_numpy()
    np.testing.assert_allclose(st.earth_sun_distance, want, atol=1e-6)
    assert st.earth_sun_distance.min() == pytest.approx(0.9833, abs=2e-4)       # perihelion
    assert st.earth_sun_distance.max() == pytest.approx(1.0167, abs=2e-4)       # aphelion
    assert not any(v.any() for v in st.clamped.values())


def test_one_step_period_with_a_given_step():
    st = sky_states_for(SITE, "2023-01-03T11:30", "2023-01-03T12:30", "1h")
    assert len(st) == 1 and st.sun_elevation[0] > 10


def test_daily_direct_normal_follows_the_earth_sun_distance():
    sky = PragueSky()
    days = sky_states_for(SITE, "2023-01-01", "2024-01-01", "1D", label="left")
    r = days.earth_sun_distance
    fixed = SkyStates.create(np.full(r.size, 35.0), np.full(r.size, 180.0), 40.0, 0.2,
                             earth_sun_distance=r)
    at_1au = SkyStates.create(np.full(r.size, 35.0), np.full(r.size, 180.0), 40.0, 0.2)
    dni, dhi = model_irradiance(sky, fixed)
    dni1, dhi1 = model_irradiance(sky, at_1au)
    np.testing.assert_allclose(dni, dni1 / r ** 2, rtol=1e-9)
    np.testing.assert_allclose(dhi, dhi1 / r ** 2, rtol=1e-9)
    jan, jul = dni[2] / dni1[2] - 1, dni[184] / dni1[184] - 1
    assert 0.032 < jan < 0.036 and -0.035 < jul < -0.031


def test_weather_clamps_are_warned_and_flagged(tmp_path):
    site = Site(50.08, 14.42, 200.0, tz=1.0)
    idx = pd.date_range("2021-06-20 01:00", periods=24, freq="1h", tz=site.tz)
    vis = np.where(np.arange(24) < 6, 8.0, 30.0)            # 6 steps below the dataset's 20 km
    data = pd.DataFrame({"ghi": 0.0, "dni": 0.0, "dhi": 0.0, "temp_air": 20.0, "wind_speed": 1.0,
                         "visibility": vis, "albedo": 0.2}, index=idx)
    path = tmp_path / "w.epw"
    write_epw(path, data, site)
    with pytest.warns(UserWarning, match="visibility 6"):
        st = sky_states_for(path, model=PragueSky().model)
    assert st.clamped["visibility"].sum() == 6 and np.all(st.visibility >= 20.0)
    assert st.times.equals(idx)
