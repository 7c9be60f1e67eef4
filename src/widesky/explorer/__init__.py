"""The sky explorer: a local web application showing the sky model in the browser.

``widesky gui`` (alias ``widesky explore``) serves a self-contained page on 127.0.0.1: fisheye images of
sky radiance, sun radiance, polarisation or transmittance (an sRGB composite or one channel, up- or
side-facing) driven by sliders or by a site and a date-time, the spectrum of a clicked direction, the
horizontal and tilted-plane irradiance spectra with their integrals against a response (broadband,
illuminance, a user's cell response or glazing curve), two sky states side by side, zoom (1-64x) and panning,
datasets opened at run time from folders allowed at start-up, and PNG / spectral EXR export up to 10,000 pixels
under a chosen name. Everything it needs ships with the package: no network access, no CDN. Only its own page
can drive it (same-origin checks and a per-session token on every state-changing request; see
:mod:`widesky.explorer.server`).

From Python::

    from widesky.explorer import Explorer, make_server
    srv = make_server(Explorer(output_dir="out", dataset_dirs=["datasets"]), port=0)   # a free port on 127.0.0.1
    srv.serve_forever()
"""

from .compute import direction_at, plane_irradiance, render_view, spectrum_at
from .params import ParameterError, View, parse_view
from .server import Explorer, make_server, serve

__all__ = ["Explorer", "make_server", "serve", "View", "parse_view", "ParameterError", "render_view",
           "spectrum_at", "direction_at", "plane_irradiance"]
