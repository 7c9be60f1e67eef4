"""Where the generator finds its input data and caches expensive products: a re-export of the one resolver,
:mod:`widesky.core.paths`.

The generator's inputs (AFGL profiles, ozone cross-sections, OPAC optical constants, solar spectra, validation
spectra) are reference data, read from a folder the user names (``data_dir`` argument, ``WIDESKY_DATA_DIR``,
or ``../shared/data`` beside a source checkout); nothing from it is copied into the package. Expensive products
computed from it (Mie tables, band-model fits) are cached under ``WIDESKY_CACHE_DIR`` (default
``~/.cache/widesky``).
"""

from widesky.core.paths import DataNotFoundError, cache_dir, data_dir, data_file, has_data

__all__ = ["DataNotFoundError", "cache_dir", "data_dir", "data_file", "has_data"]
