"""
A clear-sky day at a site
=========================

Global, direct normal and diffuse horizontal irradiance of the clear-sky model through a summer and a
winter day in Prague, hourly, from the solar position (NREL SPA) and the embedded dataset, integrated with
the per-face integrator's own sky quadrature (:func:`widesky.irradiance.model_irradiance`).
"""

import matplotlib.pyplot as plt
import numpy as np

import widesky.irradiance as ir

site = ir.Site(50.08, 14.42, altitude=200.0, tz="Europe/Prague", name="Prague")
sky = ir.PragueSky()
fig, axes = plt.subplots(1, 2, figsize=(9, 3.6), sharey=True)
for ax, day in zip(axes, ("2024-06-21", "2024-12-21")):
    times = ir.time_range(day, (np.datetime64(day) + np.timedelta64(1, "D")).astype(str), "1h",
                          tz=site.tz, label="left")
    sp = site.solar_position(times, label="left")
    el = sp["apparent_elevation"].to_numpy()
    states = ir.SkyStates.create(np.maximum(el, -90.0), sp["azimuth"].to_numpy(), visibility=40.0, albedo=0.2)
    dni, dhi = ir.model_irradiance(sky, states)
    ghi = dni * np.sin(np.radians(np.maximum(el, 0.0))) + dhi
    hours = times.hour + 0.5
    ax.plot(hours, ghi, label="ghi")
    ax.plot(hours, dni, label="dni")
    ax.plot(hours, dhi, label="dhi")
    ax.set(title=f"{site.name}, {day}", xlabel="local time [h]", xlim=(0, 24))
    ax.grid(alpha=0.3)
    print(f"{day}: daily global horizontal {ghi.sum() / 1000:.2f} kWh m-2 (clear sky, visibility 40 km)")
axes[0].set_ylabel("irradiance [W m-2]")
axes[0].legend()
fig.tight_layout()
plt.show()
