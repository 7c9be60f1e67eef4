"""Responses: band averaging onto the sky's channels, units, CSV errors and angular factors.

References: analytic integrals of piecewise-linear curves (a step edge inside a band averages to the
covered fraction; QE = 1 gives SR = lambda q / (h c), whose band mean is the band's centre
wavelength / 1239.84198 nm W A-1, CODATA 2018 exact constants); tolerances are float rounding.
"""

import numpy as np
import pytest

from widesky.irradiance import AngularTable, Response, SpectralAngularTable
from widesky.irradiance.response import HC_OVER_Q, band_average

EDGES = np.arange(280.0, 2480.0 + 1e-9, 40.0)
LO, HI = EDGES[:-1], EDGES[1:]


def test_edge_inside_a_band_is_averaged_not_sampled():
    # a cut-on edge at 1010 nm: the band 1000-1040 is 3/4 covered; its centre sample would say 1
    r = Response("edge", [280, 1010, 1010.000001, 2480], [0, 0, 1, 1], unit="transmittance")
    w = r.channel_weights(LO, HI)
    c = np.searchsorted(LO, 1000.0)
    assert LO[c] == 1000.0
    assert w[c] == pytest.approx(0.75, abs=1e-6)
    assert np.all(w[:c] == 0) and np.allclose(w[c + 1:], 1.0)
    assert r.output_unit == "W m-2"


def test_quantum_efficiency_converts_to_spectral_response():
    r = Response("qe1", [280, 2480], [1, 1], unit="qe")
    w = r.channel_weights(LO, HI)
    np.testing.assert_allclose(w, 0.5 * (LO + HI) / HC_OVER_Q, rtol=1e-12)
    assert HC_OVER_Q == pytest.approx(1239.84198, abs=1e-5)
    assert r.output_unit == "A m-2"


def test_outside_the_curve_is_zero_and_a_missed_range_is_an_error():
    r = Response("si", [300, 1200], [0.2, 0.2], unit="sr")      # below h c / (q lambda) = 0.242 A W-1 at 300 nm
    w = r.channel_weights(LO, HI)
    assert w[0] == pytest.approx(0.2 * 20 / 40)             # 280-320 half covered
    assert w[np.searchsorted(LO, 1200)] == 0.0
    with pytest.raises(ValueError, match="misses the channels"):
        Response("ir", [2500, 3000], [1, 1]).channel_weights(LO, HI)


def test_band_average_of_a_ramp():
    x = np.array([0.0, 10.0])
    np.testing.assert_allclose(band_average(x, x, [2.0, -5.0], [4.0, 5.0]), [3.0, 1.25])


@pytest.mark.parametrize("text, msg", [
    ("wavelength_nm,value\n400,0.1\n390,0.2\n", "strictly ascending"),
    ("wavelength_nm,value\n400,0.1\n500,-0.2\n", "negative"),
    ("wavelength_nm,value\n400,0.1\n500,nan\n", "value is nan"),
    ("wavelength_nm,value\n400,0.1\n", "fewer than two"),
    ("wavelength_nm,value\n400,0.1\n500,abc\n", "line 3"),
])
def test_csv_errors_name_the_problem(tmp_path, text, msg):
    p = tmp_path / "r.csv"
    p.write_text(text)
    with pytest.raises(ValueError, match=msg):
        Response.from_csv(p)


def test_csv_reads_with_header_and_comments(tmp_path):
    p = tmp_path / "csi.csv"
    p.write_text("# a cell\nwavelength_nm,value\n300,0.1 # start\n1200;0.6\n")
    r = Response.from_csv(p)
    assert r.name == "csi" and r.unit == "sr"
    np.testing.assert_allclose(r.values, [0.1, 0.6])


def test_angular_factor_kinds():
    aoi = np.array([0.0, 45.0, 90.0, 120.0, np.nan])
    plain = Response("a", [280, 2480], [1, 1])
    np.testing.assert_allclose(plain.angular_factor(aoi, LO, HI)[:4], 1.0)
    assert np.all(plain.angular_factor(aoi, LO, HI)[4] == 0)
    tab = Response("b", [280, 2480], [1, 1], angular=AngularTable([0, 60, 90], [1.0, 0.9, 0.0]))
    f = tab.angular_factor(aoi, LO, HI)
    np.testing.assert_allclose(f[:4, 0], [1.0, 0.925, 0.0, 0.0])
    sat = SpectralAngularTable([0, 90], [280, 2480], [[0.8, 0.4], [0.0, 0.0]])
    g = Response("c", [280, 2480], [1, 1], unit="transmittance", angular=sat).angular_factor(
        [0.0, 45.0], LO, HI)
    centre = 0.5 * (LO + HI)
    np.testing.assert_allclose(g[0], 0.8 - 0.4 * (centre - 280) / 2200, rtol=1e-12)
    np.testing.assert_allclose(g[1], 0.5 * g[0], rtol=1e-12)
    with pytest.raises(ValueError, match="outside"):
        AngularTable([0, 100], [1, 0])
    with pytest.raises(TypeError):
        Response("d", [280, 2480], [1, 1], angular=3.0)
    with pytest.raises(ValueError, match="unit"):
        Response("e", [280, 2480], [1, 1], unit="A/W")


@pytest.mark.parametrize("rows, unit, msg", [
    ("400,52\n800,90\n", "qe", r"EQE 52 at 400 nm is above 1, the physical limit \(a table in percent\? divide by 100\)"),
    ("400,0.5\n800,1.5\n", "qe", "EQE 1.5 at 800 nm is above 1"),
    ("400,0.4\n800,0.6\n", "sr", r"spectral response 0.4 A W-1 at 400 nm is above the physical limit 0.3226 A W-1"),
    ("400,0.5\n800,1.2\n", "transmittance", "transmittance 1.2 at 800 nm is above 1"),
])
def test_a_response_above_its_physical_limit_is_refused(tmp_path, rows, unit, msg):
    """Issue 34: an EQE in percent, an EQE above 1, an SR above q lambda / (h c) (h c / q = 1239.84 eV nm, CODATA
    2018 exact constants) or a transmittance above 1 is an error naming the file, wavelength and limit, on every path
    (the CSV reader and the constructor)."""
    f = tmp_path / "r.csv"
    f.write_text("wavelength_nm,value\n" + rows)
    with pytest.raises(ValueError, match=msg) as e:
        Response.from_csv(f, unit=unit)
    assert str(f) in str(e.value)
    w, v = np.loadtxt(f, delimiter=",", skiprows=1).T
    with pytest.raises(ValueError, match=msg):
        Response("x", w, v, unit=unit)


def test_semicolon_tables_with_decimal_commas(tmp_path):
    """A ';'-separated table written with decimal commas reads as numbers (it read as all zeros before)."""
    f = tmp_path / "eu.csv"
    f.write_text("wavelength_nm;value\n400;0,52\n800,5;0,9\n")
    r = Response.from_csv(f, unit="qe")
    np.testing.assert_allclose(r.wavelength, [400.0, 800.5])
    np.testing.assert_allclose(r.values, [0.52, 0.9])
