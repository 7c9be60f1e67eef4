"""widesky: spectral solar simulation on 3D scenes with the wide-spectral-range Prague Sky Model.

Packages (each imports as ``widesky.<name>``):

- :mod:`widesky.skymodel`: the sky (dataset reader, C evaluator, renderer; the dataset generator in
  :mod:`widesky.skymodel.generator`, build time only);
- :mod:`widesky.irradiance`: sun, weather, sky states, scenes, ray casting, per-face spectral irradiance;
- :mod:`widesky.pvsim`: cell spectral responses, module and yield models;
- :mod:`widesky.thermal`: glazing, facade solar gains, zone loads;
- :mod:`widesky.cases`: runnable example cases and their reports;
- :mod:`widesky.core`: units, data paths, atomic writes and spectral helpers shared by all.

The pipeline (:class:`widesky.Simulation`, :class:`widesky.SkyOptions`) is importable from here; it is loaded
on first use (PEP 562 module ``__getattr__``), so ``import widesky`` and the command line start fast.
"""

__all__ = ["Simulation", "SkyOptions", "SKY_DEFAULTS", "sky_input", "__version__"]

_LAZY = {"Simulation": "widesky.irradiance.simulation", "SkyOptions": "widesky.irradiance.simulation",
         "SKY_DEFAULTS": "widesky.irradiance.simulation", "sky_input": "widesky.irradiance.simulation"}


def __getattr__(name):
    if name in _LAZY:
        import importlib
        return getattr(importlib.import_module(_LAZY[name]), name)
    if name == "__version__":
        from importlib.metadata import PackageNotFoundError, version
        try:
            return version("widesky")
        except PackageNotFoundError:  # pragma: no cover - a source tree that is not installed
            return "unknown"
    raise AttributeError(f"module 'widesky' has no attribute {name!r}")


def __dir__():
    return sorted(list(globals()) + __all__)
