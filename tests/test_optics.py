"""Optics per incoming direction.

References and tolerances:
* An unobstructed tilted plane under an isotropic sky (UniformSky) above an open Lambertian ground,
  with the Fresnel-with-absorption cover of pvlib.iam.physical (n = 1.526, K = 4 m-1, L = 2 mm):
  the sky-diffuse and ground-reflected factors equal pvlib.iam.marion_integrate's within 0.2 %
  (Marion 2017, the integrals of the IAM over the sky and ground seen by the plane), and the beam
  factor equals pvlib.iam.physical at the step's angle of incidence (float32 rounding, 1e-5).
* An angle x wavelength table that is separable, f(a, lambda) = g(a) s(lambda) with g piecewise
  linear on the class nodes, gives through the incidence-angle classes the same light as the
  response s with the angle-only optic g applied per ray (classing exact for such tables; 1e-4).
"""

import numpy as np
import pandas as pd
import pytest
import trimesh

pvlib = pytest.importorskip("pvlib")

from widesky.irradiance import (AngularTable, Response, RunOptions, SkyStates, SpectralAngularTable, make_scene,
                                poa_irradiance)
from widesky.irradiance.optics import DEFAULT_NODES
from widesky.irradiance.skies import UniformSky


def plane(tilt, azimuth=180.0, height=1.0):
    t, a = np.radians(tilt), np.radians(azimuth)
    n = np.array([np.sin(t) * np.sin(a), np.sin(t) * np.cos(a), np.cos(t)])
    u = np.cross([0, 0, 1.0], n)
    u /= np.linalg.norm(u)
    v = np.cross(n, u)
    c = np.array([0.0, 0.0, height])
    pts = [c - u / 2 - v / 2, c + u / 2 - v / 2, c + u / 2 + v / 2, c - u / 2 + v / 2]
    return trimesh.Trimesh(pts, [[0, 1, 2], [0, 2, 3]], process=False)


def glass(aoi):
    return pvlib.iam.physical(aoi, n=1.526, K=4.0, L=0.002)


STATES = SkyStates.create([10.0, 35.0, 60.0, 25.0], [100.0, 160.0, 200.0, 260.0], 40.0, 0.3)


@pytest.mark.parametrize("tilt", [20.0, 45.0, 70.0, 90.0])
def test_fresnel_cover_matches_marion_integrals(tilt):
    scene = make_scene(plane(tilt), ground_z=0.0)
    sky = UniformSky(radiance=0.05, dni=0.8)
    r = Response("cover", [280, 2480], [1, 1], angular=glass)
    res = poa_irradiance(scene, sky, STATES, responses=[r], run=RunOptions(n_jobs=1))
    want_sky = pvlib.iam.marion_integrate(glass, tilt, "sky")
    want_ground = pvlib.iam.marion_integrate(glass, tilt, "ground")
    sky_f = res.get("cover", "sky_diffuse")[:, 0] / res.poa_sky_diffuse[:, 0]
    grd_f = res.get("cover", "ground_diffuse")[:, 0] / res.poa_ground_diffuse[:, 0]
    np.testing.assert_allclose(sky_f, want_sky, rtol=2e-3)
    np.testing.assert_allclose(grd_f, want_ground, rtol=2e-3)
    lit = res.poa_direct[:, 0] > 1e-3
    beam_f = res.get("cover", "direct")[lit, 0] / res.poa_direct[lit, 0]
    np.testing.assert_allclose(beam_f, glass(res.aoi[lit, 0]), rtol=1e-5)


def test_separable_spectral_table_through_classes_is_exact():
    nodes = np.asarray(DEFAULT_NODES)
    g = glass(nodes)
    g[-1] = 0.0
    wl = np.array([280.0, 2480.0])
    s = np.array([0.9, 0.3])
    table = SpectralAngularTable(nodes, wl, g[:, None] * s[None, :])
    classed = Response("glazing", [280, 2480], [1, 1], unit="transmittance", angular=table)
    per_ray = Response("ref", wl, s, unit="transmittance", angular=AngularTable(nodes, g))
    scene = make_scene([plane(90.0), plane(35.0, 150.0, 3.0)], ground_z=0.0)
    res = poa_irradiance(scene, UniformSky(radiance=0.05, dni=0.8), STATES, responses=[classed, per_ray],
                         run=RunOptions(n_jobs=1))
    for part in ("direct", "sky_diffuse", "ground_diffuse"):
        np.testing.assert_allclose(res.get("glazing", part), res.get("ref", part), rtol=1e-4,
                                   atol=1e-6, err_msg=part)
