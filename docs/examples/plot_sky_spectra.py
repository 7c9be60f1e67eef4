"""
Sky and sun spectra from 280 to 2480 nm
=======================================

The spectral radiance of the zenith sky and the direct normal spectral irradiance of the sun for a sun at
40 deg elevation, at three visibilities. Hazier air (lower visibility) takes light out of the beam and puts
part of it into the sky; the water-vapour bands (940, 1140, 1380, 1870 nm) are deep in both.
"""

import matplotlib.pyplot as plt
import numpy as np

from widesky import skymodel

model = skymodel.load_dataset()
zenith = skymodel.direction_from_zenith([0.0], [0.0])
fig, (a1, a2) = plt.subplots(1, 2, figsize=(9, 3.6))
for vis in (20.0, 50.0, 131.8):
    L = skymodel.sky_radiance(model, zenith, 40.0, 180.0, vis, 0.2)[0]           # [W m-2 sr-1 nm-1]
    E = skymodel.solar_direct_normal(model, 40.0, 180.0, vis, 0.2)               # [W m-2 nm-1]
    a1.plot(model.wavelengths, L, label=f"{vis:g} km")
    a2.plot(model.wavelengths, np.ravel(E), label=f"{vis:g} km")
    broadband = float(np.sum(np.ravel(E) * model.channel_width))
    print(f"visibility {vis:6.1f} km: direct normal 280-2480 nm = {broadband:6.1f} W m-2")
a1.set(xlabel="wavelength [nm]", ylabel="zenith sky radiance [W m-2 sr-1 nm-1]", title="zenith sky")
a2.set(xlabel="wavelength [nm]", ylabel="direct normal irradiance [W m-2 nm-1]", title="sun (direct normal)")
for a in (a1, a2):
    a.legend(title="visibility", fontsize=8)
    a.grid(alpha=0.3)
fig.tight_layout()
plt.show()
