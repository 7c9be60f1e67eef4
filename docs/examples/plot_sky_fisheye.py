"""
Fisheye renders of the clear sky
================================

Up-facing stereographic fisheyes (north at the top, east on the left, as a sky chart seen from below)
of the embedded dataset's sky radiance at three solar elevations, as sRGB composites of the visible
channels. The exposure is set per image (99th percentile of the disc), so the images show the sky's
shape and colour, not its absolute brightness.
"""

import matplotlib.pyplot as plt
import numpy as np

from widesky import skymodel
from widesky.skymodel.colour import srgb_encode
from widesky.skymodel.render import render_sky

model = skymodel.load_dataset()
fig, axes = plt.subplots(1, 3, figsize=(9, 3.3))
for ax, elevation in zip(axes, (60.0, 20.0, 4.0)):
    r = render_sky(model, sun_elevation=elevation, sun_azimuth=135.0, visibility=40.0, albedo=0.2,
                   resolution=160)
    rgb = r.rgb_linear()                                     # linear sRGB of the visible channels
    scale = 1.0 / np.percentile(r.luminance_like()[r.mask], 99.0)
    img = srgb_encode(rgb * scale)
    img[~r.mask] = 0.0
    ax.imshow(img)
    ax.set_title(f"sun {elevation:g} deg, azimuth 135 deg", fontsize=9)
    ax.set_axis_off()
fig.suptitle("sky radiance, visibility 40 km, albedo 0.2 (sRGB composite)", fontsize=10)
fig.tight_layout()
plt.show()
