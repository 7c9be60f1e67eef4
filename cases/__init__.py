"""widesky cases: runnable example scenes and the runner that turns one into a report folder.

Each case is a folder holding ``case.toml`` (validated against :data:`widesky.cases.config.SCHEMA`), its
geometry (``geometry.py`` with ``build(parameters)``, or a mesh file) and a ``README.md``.
``widesky run cases/<name>`` (or ``widesky.cases.run_case(folder)``) runs it end to end and writes a report
folder atomically: an offline HTML report, time series (CSV, Parquet), the integrator result
(``poa.h5``, :meth:`widesky.irradiance.POAResult.load` reads it), a spectral EXR of one hour's sky, scene renders coloured by insolation and the coloured
mesh (GLB and PLY); with a ``[thermal]`` section the window gains and loads of a building (``loads.csv``).
"""

from pathlib import Path

from .config import SCHEMA, ConfigError, load_config, validate
from .runner import BANDS, run_case

CASES_DIR = Path(__file__).resolve().parent

__all__ = ["run_case", "load_config", "validate", "ConfigError", "SCHEMA", "BANDS", "CASES_DIR", "list_cases"]


def list_cases():
    """Names of the cases shipped in this folder (sub-folders with a case.toml)."""
    return sorted(p.name for p in CASES_DIR.iterdir() if (p / "case.toml").is_file())
