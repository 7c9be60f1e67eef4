"""What a case run computed (:class:`CaseRun`), read by the report: kept apart from the runner so that the report
and the runner import it, not each other."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

__all__ = ["BANDS", "CaseRun", "dump_json"]

# broad spectral bands of the report's spectral split [nm]
BANDS = {"UV 280-400 nm": (280.0, 400.0), "visible 400-700 nm": (400.0, 700.0),
         "NIR 700-1100 nm": (700.0, 1100.0), "SWIR 1100-2480 nm": (1100.0, 2480.0)}


@dataclass
class CaseRun:
    """Everything a case run computed (what the report shows)."""

    folder: Path
    config: dict
    scene: object
    result: object                 # irradiance.POAResult of the period
    hour: object                   # irradiance.POAResult of report.sky_time with spectral parts
    hour_index: int
    hour_sun: tuple                # (apparent elevation, azimuth) [deg] of that hour (mid-interval)
    labels: list                   # per analysis face: its group label ("roof", "row1 back" ...)
    step_hours: float
    dataset: object
    settings: object
    timings: dict = field(default_factory=dict)
    pv: object = None              # pvsim.YieldResult when the case has a [pv] section
    pv_groups: tuple = ()          # the analysis groups that are PV modules
    thermal: object = None         # cases.building_loads.ThermalRun when the case has a [thermal] section
    weather: str = "clear sky"     # how the sky was driven (a phrase for the report)
    site: object = None            # irradiance.Site used (the weather file's with a weather file)
    label: str = "left"            # what the step times label: "left" (interval start), "right" (end: EPW, TMY3)


def dump_json(path, obj):
    """Write JSON (numpy scalars converted)."""
    def conv(o):
        if isinstance(o, (np.integer, np.floating)):
            return o.item()
        if isinstance(o, np.ndarray):
            return o.tolist()
        return str(o)
    Path(path).write_text(json.dumps(obj, indent=2, default=conv), encoding="utf-8")
