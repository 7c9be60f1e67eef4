"""The cell-technology library: named presets of parametric EQE, STC efficiency, temperature and
low-irradiance behaviour, and perovskite/silicon tandems.

Every preset is a cell EQE (the cover glass's optics enter separately, see ``widesky.pvsim.optics``) plus
module-level electrical numbers. Where a measured curve is in ``shared/data/pv`` the edge and window
parameters were fitted to it (least squares, 10 nm grid); elsewhere they follow the materials'
band gaps and the window layers named in the ``sources``. The electrical numbers (STC module
efficiency, power temperature coefficient, relative efficiency at 200 W m-2) are representative of
current products of each kind, not of one product: use a datasheet's values for a given module
(``CellTechnology.replace``). docs/pvsim.md lists the measured deviations of each shape.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from .eqe import EQEParameters, parametric_eqe, transmittance_below_gap
from .spectra import qe_to_sr

__all__ = ["CellTechnology", "TandemTechnology", "TECHNOLOGIES", "get_technology", "technology_names",
           "perovskite", "perovskite_silicon_tandem", "PEROVSKITE_BANDGAP_RANGE"]

PEROVSKITE_BANDGAP_RANGE = (1.5, 1.8)   # eV, the lead-halide compositions the preset represents


def _check_range(name, value, lo, hi, unit):
    if not (np.isfinite(value) and lo <= value <= hi):
        raise ValueError(f"{name}={value!r} outside the valid range [{lo:g}, {hi:g}] {unit}")


@dataclass(frozen=True)
class CellTechnology:
    """A single-junction cell technology.

    Attributes
    ----------
    name : str
        Preset key.
    label : str
        Name for plots and tables.
    eqe : EQEParameters or pvsim.curves.TabulatedEQE
        Cell EQE model (anything with ``evaluate(wavelength_nm) -> EQE``).
    eta_stc : float
        Module efficiency at STC (1000 W m-2 AM1.5G, 25 degC) [1], (0, 0.5].
    gamma_pdc : float
        Power temperature coefficient [1/K] (pvlib's name), [-0.01, 0].
    low_irradiance_200 : float
        Efficiency at 200 W m-2 relative to STC, 25 degC [1] (the datasheet figure), [0.8, 1.1].
    bifaciality : float
        Rear-to-front efficiency ratio [1], 0 for a monofacial module, [0, 1].
    sources : dict
        Parameter group -> citation.
    """

    name: str
    label: str
    eqe: EQEParameters
    eta_stc: float
    gamma_pdc: float
    low_irradiance_200: float = 0.97
    bifaciality: float = 0.0
    sources: dict = field(default_factory=dict, compare=False)

    def __post_init__(self):
        _check_range("eta_stc", self.eta_stc, 1e-3, 0.5, "[1]")
        _check_range("gamma_pdc", self.gamma_pdc, -0.01, 0.0, "[1/K]")
        _check_range("low_irradiance_200", self.low_irradiance_200, 0.8, 1.1, "[1]")
        _check_range("bifaciality", self.bifaciality, 0.0, 1.0, "[1]")

    terminals = 1

    @property
    def subcells(self):
        """Sub-cell names (one for a single junction)."""
        return (self.name,)

    def qe(self, wavelength):
        """EQE [1] at ``wavelength`` [nm] (any shape)."""
        return self.eqe.evaluate(wavelength)

    def sr(self, wavelength):
        """Spectral response [A W-1] at ``wavelength`` [nm] (1-D)."""
        w = np.asarray(wavelength, dtype=float)
        return qe_to_sr(self.qe(w), w)

    def subcell_qe(self, wavelength):
        """dict sub-cell name -> EQE [1] (one entry for a single junction)."""
        return {self.name: self.qe(wavelength)}

    def replace(self, **changes):
        """A copy with some attributes changed (validated), e.g. a datasheet's ``eta_stc``."""
        return replace(self, **changes)


@dataclass(frozen=True)
class TandemTechnology:
    """A perovskite-on-silicon (or any) two-junction stack.

    The top cell's EQE is its parametric model; the bottom cell sees what the top absorber passes,
    ``bottom_qe = standalone_bottom_qe * interlayer_transmittance * exp(-alpha L)_top``.
    The electrical model keeps each sub-cell at an effective voltage ``V_i = ff * (E_g,i - w_oc,i)``
    (the band-gap-voltage offset w_oc [V] and fill factor ff), so a sub-cell's power is ``J_i V_i``:
    2T (series) delivers ``min(J_top, J_bottom) (V_top + V_bottom)``, 4T ``J_top V_top + J_bottom V_bottom``,
    both times ``module_factor`` (cell-to-module ratio). The STC efficiency therefore follows from the
    reference spectrum (:func:`widesky.pvsim.module.tandem_stc_efficiency`).

    Attributes
    ----------
    name, label : str
    top, bottom : EQEParameters
        Top-cell model; the bottom cell's standalone model.
    terminals : int
        2 (current-matched series connection) or 4 (independent sub-cells).
    interlayer_transmittance : float
        Fraction of the sub-gap light reaching the bottom cell [1] (recombination layer / TCO losses).
    w_oc_top, w_oc_bottom : float
        Band-gap-voltage offsets E_g/q - V_oc [V].
    ff : float
        Fill factor [1].
    module_factor : float
        Module-to-cell efficiency ratio [1].
    gamma_pdc, low_irradiance_200, bifaciality, sources : as :class:`CellTechnology`.
    """

    name: str
    label: str
    top: EQEParameters
    bottom: EQEParameters
    terminals: int = 2
    interlayer_transmittance: float = 0.95
    w_oc_top: float = 0.45
    w_oc_bottom: float = 0.42
    ff: float = 0.80
    module_factor: float = 0.90
    gamma_pdc: float = -0.0027
    low_irradiance_200: float = 0.98
    bifaciality: float = 0.0
    sources: dict = field(default_factory=dict, compare=False)

    def __post_init__(self):
        if self.terminals not in (2, 4):
            raise ValueError(f"terminals={self.terminals!r} must be 2 or 4")
        _check_range("interlayer_transmittance", self.interlayer_transmittance, 0.0, 1.0, "[1]")
        _check_range("w_oc_top", self.w_oc_top, 0.0, self.top.bandgap_ev, "[V]")
        _check_range("w_oc_bottom", self.w_oc_bottom, 0.0, self.bottom.bandgap_ev, "[V]")
        _check_range("ff", self.ff, 0.3, 0.92, "[1]")
        _check_range("module_factor", self.module_factor, 0.5, 1.0, "[1]")
        _check_range("gamma_pdc", self.gamma_pdc, -0.01, 0.0, "[1/K]")
        _check_range("low_irradiance_200", self.low_irradiance_200, 0.8, 1.1, "[1]")
        _check_range("bifaciality", self.bifaciality, 0.0, 1.0, "[1]")
        if self.top.bandgap_ev <= self.bottom.bandgap_ev:
            raise ValueError(f"top bandgap_ev={self.top.bandgap_ev!r} must exceed the bottom's "
                             f"{self.bottom.bandgap_ev!r} eV")

    @property
    def subcells(self):
        """Sub-cell names: ``<name>:top``, ``<name>:bottom``."""
        return (f"{self.name}:top", f"{self.name}:bottom")

    @property
    def voltages(self):
        """Effective sub-cell voltages (V_top, V_bottom) [V]: ff * (E_g - w_oc)."""
        return (self.ff * (self.top.bandgap_ev - self.w_oc_top),
                self.ff * (self.bottom.bandgap_ev - self.w_oc_bottom))

    def top_qe(self, wavelength):
        """Top-cell EQE [1] at ``wavelength`` [nm]."""
        return parametric_eqe(wavelength, self.top)

    def bottom_qe(self, wavelength):
        """Bottom-cell EQE [1] under the top cell at ``wavelength`` [nm]."""
        return (parametric_eqe(wavelength, self.bottom) * self.interlayer_transmittance
                * transmittance_below_gap(wavelength, self.top))

    def subcell_qe(self, wavelength):
        """dict sub-cell name -> EQE [1]."""
        t, b = self.subcells
        return {t: self.top_qe(wavelength), b: self.bottom_qe(wavelength)}

    def qe(self, wavelength):
        """Sum of the sub-cells' EQE [1] (the stack's total collection, for plots)."""
        return self.top_qe(wavelength) + self.bottom_qe(wavelength)

    def with_top_bandgap(self, bandgap_ev):
        """The same stack with another top-cell band gap [eV] (within PEROVSKITE_BANDGAP_RANGE)."""
        _check_range("bandgap_ev", bandgap_ev, *PEROVSKITE_BANDGAP_RANGE, "eV")
        return replace(self, top=self.top.replace(bandgap_ev=float(bandgap_ev)))

    def replace(self, **changes):
        """A copy with some attributes changed (validated)."""
        return replace(self, **changes)


# --- presets -----------------------------------------------------------------------------------
# Shared citations (short keys; full references in docs/pvsim.md).
_GREEN_TABLES = "Green et al., Solar cell efficiency tables (Version 64), Prog. Photovolt. 32 (2024) 425"
_ITRPV = "ITRPV 15th edition (2024): mass-production module efficiencies and bifaciality by cell type"
_SI_EDGE = ("edge fitted to the c-Si absorber EQE in NREL PVcircuit notebook_data/PVcircuit_Si_EQE.csv "
            "(160 um c-Si, Sch15): rms 1.2 % EQE over 800-1300 nm")
_PSC_FIT = ("fitted to NREL PVcircuit notebook_data/PVcircuit_PSC_EQE.csv (1.62 eV CsFAPbIBr, Wer18): "
            "rms 3.2 % EQE over 300-900 nm")
_TEMPCO = ("representative datasheet power temperature coefficients of current products (c-Si PERC -0.34, TOPCon -0.30, "
           "SHJ -0.26, mc-Si -0.40, CdTe -0.32, CIGS -0.36, a-Si -0.20 %/K); the trend with band gap and Voc: Dupre, Vaillon & Green, "
           "Thermal Behavior of Photovoltaic Devices, Springer 2017")
_LOWLIGHT = ("relative efficiency at 200 W m-2 as datasheets quote it (EN 50380): c-Si about -3 %, "
             "thin films about -1 to 0 %")

# c-Si absorber edge (fitted, see _SI_EDGE)
_SI = dict(bandgap_ev=1.12, tail_ev=0.105, edge_width_ev=0.159)

_PRESETS = [
    CellTechnology(
        "perc", "mono c-Si PERC",
        EQEParameters(**_SI, plateau=0.975, plateau_tilt=0.02, window_nm=360.0, window_width_nm=20.0,
                      uv_cutoff_nm=300.0),
        eta_stc=0.212, gamma_pdc=-0.0034, low_irradiance_200=0.97, bifaciality=0.70,
        sources={"edge": _SI_EDGE, "window": "SiNx/emitter blue loss: EQE ~0.6 at 350 nm, ~0.9 at 450 nm "
                 "(Blakers, IEEE J. Photovolt. 9 (2019) 629)", "efficiency": _ITRPV, "bifaciality": _ITRPV,
                 "temperature": _TEMPCO, "low_irradiance": _LOWLIGHT}),
    CellTechnology(
        "topcon", "mono c-Si TOPCon",
        EQEParameters(**_SI, plateau=0.98, plateau_tilt=0.015, window_nm=340.0,
                      window_width_nm=20.0, uv_cutoff_nm=300.0),
        eta_stc=0.223, gamma_pdc=-0.0030, low_irradiance_200=0.975, bifaciality=0.80,
        sources={"edge": _SI_EDGE + "; poly-Si free-carrier absorption: slightly softer edge",
                 "window": "boron emitter with Al2O3/SiNx: blue better than PERC", "efficiency": _ITRPV,
                 "bifaciality": _ITRPV, "temperature": _TEMPCO, "low_irradiance": _LOWLIGHT}),
    CellTechnology(
        "shj", "silicon heterojunction",
        EQEParameters(**_SI, plateau=0.985, plateau_tilt=0.015, window_nm=420.0, window_width_nm=28.0,
                      window_floor=0.45, uv_cutoff_nm=300.0),
        eta_stc=0.226, gamma_pdc=-0.0026, low_irradiance_200=0.985, bifaciality=0.90,
        sources={"edge": _SI_EDGE, "window": "parasitic absorption of the front a-Si:H and ITO below "
                 "~450 nm (Holman et al., IEEE J. Photovolt. 2 (2012) 7)", "efficiency": _ITRPV,
                 "bifaciality": _ITRPV, "temperature": _TEMPCO, "low_irradiance": _LOWLIGHT}),
    CellTechnology(
        "multi_si", "multicrystalline Si",
        EQEParameters(**{**_SI, "edge_width_ev": 0.17}, plateau=0.95, plateau_tilt=0.06, window_nm=370.0,
                      window_width_nm=25.0, uv_cutoff_nm=300.0),
        eta_stc=0.180, gamma_pdc=-0.0040, low_irradiance_200=0.96,
        sources={"edge": _SI_EDGE + "; shorter diffusion length: weaker red response, larger tilt",
                 "efficiency": _GREEN_TABLES + " (mc-Si module 20.4 %; products 17-19 %)",
                 "temperature": _TEMPCO, "low_irradiance": _LOWLIGHT}),
    CellTechnology(
        "cdte", "CdTe",
        EQEParameters(bandgap_ev=1.45, tail_ev=0.04, edge_width_ev=0.05, plateau=0.94, window_nm=515.0,
                      window_width_nm=10.0, window_floor=0.6, uv_cutoff_nm=340.0, uv_width_nm=12.0),
        eta_stc=0.190, gamma_pdc=-0.0032, low_irradiance_200=0.99,
        sources={"edge": "CdTe band gap 1.45 eV (Romeo & Artegiani, Energies 14 (2021) 1684)",
                 "window": "CdS buffer, band gap 2.42 eV (512 nm), partly transmitting; SnO2 TCO on the "
                 "superstrate glass cuts below ~350 nm", "efficiency": _GREEN_TABLES + " (CdTe module 19.5 %)",
                 "temperature": _TEMPCO, "low_irradiance": _LOWLIGHT}),
    CellTechnology(
        "cigs", "CIGS",
        EQEParameters(bandgap_ev=1.15, tail_ev=0.05, edge_width_ev=0.10, plateau=0.93, plateau_tilt=0.02,
                      window_nm=515.0, window_width_nm=12.0, window_floor=0.8, uv_cutoff_nm=375.0,
                      uv_width_nm=10.0),
        eta_stc=0.175, gamma_pdc=-0.0036, low_irradiance_200=0.97,
        sources={"edge": "Cu(In,Ga)Se2 with Ga/(In+Ga) ~0.3: band gap ~1.15 eV; the Ga grading broadens the "
                 "edge (Jackson et al., Phys. Status Solidi RRL 10 (2016) 583)",
                 "window": "thin CdS buffer (2.42 eV) and ZnO:Al window (3.3 eV, ~375 nm)",
                 "efficiency": _GREEN_TABLES + " (CIGS modules 17-20 %)", "temperature": _TEMPCO,
                 "low_irradiance": _LOWLIGHT}),
    CellTechnology(
        "a_si", "amorphous Si",
        EQEParameters(bandgap_ev=1.75, tail_ev=0.12, edge_width_ev=0.22, plateau=0.90, plateau_tilt=0.0,
                      window_nm=410.0, window_width_nm=30.0, uv_cutoff_nm=330.0),
        eta_stc=0.085, gamma_pdc=-0.0020, low_irradiance_200=1.00,
        sources={"edge": "a-Si:H optical (Tauc) gap 1.7-1.8 eV, thin (~300 nm) absorber with a broad "
                 "Urbach tail (Shah et al., Prog. Photovolt. 12 (2004) 113)",
                 "window": "p-type a-SiC:H window and TCO absorb below ~420 nm",
                 "efficiency": _GREEN_TABLES + " (stabilised a-Si modules 8-10 %)", "temperature": _TEMPCO,
                 "low_irradiance": _LOWLIGHT}),
    CellTechnology(
        "perovskite", "perovskite (1.55 eV)",
        EQEParameters(bandgap_ev=1.55, tail_ev=0.05, edge_width_ev=0.089, plateau=0.93, window_nm=380.0,
                      window_width_nm=35.0, uv_cutoff_nm=300.0),
        eta_stc=0.180, gamma_pdc=-0.0025, low_irradiance_200=0.98,
        sources={"shape": _PSC_FIT + "; band gap set to 1.55 eV (FAPbI3-rich single junction), plateau 0.90 "
                 "for an opaque cell with a rear electrode", "efficiency": _GREEN_TABLES + " (perovskite "
                 "modules around 18 %)", "temperature": "reported -0.1 to -0.3 %/K (Jost et al., Adv. Energy "
                 "Mater. 10 (2020) 2000454)", "low_irradiance": _LOWLIGHT}),
    CellTechnology(
        "gaas", "GaAs (thin film)",
        EQEParameters(bandgap_ev=1.42, tail_ev=0.034, edge_width_ev=0.041, plateau=0.93, window_nm=390.0,
                      window_width_nm=25.0, uv_cutoff_nm=300.0),
        eta_stc=0.250, gamma_pdc=-0.0010, low_irradiance_200=0.99,
        sources={"edge": "fitted to the GaAs sub-cell of NREL PVcircuit PVcircuit_WB417n6_C_EQE.csv "
                 "(measured GaInP/GaAs, 700-1000 nm): rms 1.4 % EQE", "window": "AlInP/GaInP window below "
                 "~400 nm", "efficiency": _GREEN_TABLES + " (GaAs thin-film module 25.1 %)",
                 "temperature": "low for a wide gap, high-Voc cell (~-0.1 %/K)", "low_irradiance": _LOWLIGHT}),
]

_TANDEM_SOURCES = {
    "top": _PSC_FIT + "; band gap 1.68 eV (near the 2T optimum, Hoerantner et al., ACS Energy Lett. 2 (2017) "
           "2506)",
    "bottom": "SHJ preset under the top cell's sub-gap transmittance exp(-alpha L); checked against "
              "PVcircuit_Si_EQE.csv (the Si cell under a 1.62 eV perovskite)",
    "voltage": "Voc offsets E_g/q - Voc of 0.45 V (wide-gap perovskite) and 0.42 V (filtered SHJ), FF 0.80: "
               "records of 33-34 % cells (" + _GREEN_TABLES + ")",
    "module": "module-to-cell ratio 0.90 (perovskite/Si modules 26-27 %, " + _GREEN_TABLES + ")",
}


def perovskite(bandgap_ev=1.55):
    """The perovskite preset with another band gap [eV] in PEROVSKITE_BANDGAP_RANGE (1.5-1.8)."""
    _check_range("bandgap_ev", bandgap_ev, *PEROVSKITE_BANDGAP_RANGE, "eV")
    base = _BY_NAME["perovskite"]
    return base.replace(name=f"perovskite_{bandgap_ev:.2f}", label=f"perovskite ({bandgap_ev:.2f} eV)",
                        eqe=base.eqe.replace(bandgap_ev=float(bandgap_ev)))


def perovskite_silicon_tandem(terminals=2, top_bandgap_ev=1.68):
    """Perovskite/SHJ tandem: ``terminals`` 2 (current-matched) or 4, top band gap [eV] in 1.5-1.8."""
    _check_range("top_bandgap_ev", top_bandgap_ev, *PEROVSKITE_BANDGAP_RANGE, "eV")
    top = EQEParameters(bandgap_ev=float(top_bandgap_ev), tail_ev=0.05, edge_width_ev=0.10, plateau=0.92,
                        window_nm=380.0, window_width_nm=35.0, uv_cutoff_nm=300.0)
    bottom = _BY_NAME["shj"].eqe
    if terminals == 2:
        return TandemTechnology("tandem_2t", "perovskite/Si tandem 2T", top, bottom, terminals=2,
                                sources=_TANDEM_SOURCES)
    if terminals == 4:
        return TandemTechnology("tandem_4t", "perovskite/Si tandem 4T", top, bottom, terminals=4,
                                interlayer_transmittance=0.90, module_factor=0.88,
                                sources={**_TANDEM_SOURCES, "interlayer": "two extra TCO layers: 0.90"})
    raise ValueError(f"terminals={terminals!r} must be 2 or 4")


_BY_NAME = {t.name: t for t in _PRESETS}
TECHNOLOGIES = dict(_BY_NAME)
TECHNOLOGIES["tandem_2t"] = perovskite_silicon_tandem(2)
TECHNOLOGIES["tandem_4t"] = perovskite_silicon_tandem(4)


def technology_names():
    """The preset names, in library order."""
    return tuple(TECHNOLOGIES)


def get_technology(name):
    """A preset by name (``CellTechnology`` or ``TandemTechnology``); a wrong name lists the valid ones.

    ``perovskite_<Eg>`` (e.g. ``perovskite_1.68``) gives the perovskite at that band gap [eV].
    """
    if isinstance(name, (CellTechnology, TandemTechnology)):
        return name
    key = str(name).strip().lower().replace("-", "_")
    if key in TECHNOLOGIES:
        return TECHNOLOGIES[key]
    if key.startswith("perovskite_"):
        try:
            eg = float(key.split("_", 1)[1])
        except ValueError:
            pass
        else:
            return perovskite(eg)
    raise KeyError(f"technology {name!r} is not a preset; valid: {', '.join(TECHNOLOGIES)} "
                   "(or perovskite_<bandgap eV> in 1.5-1.8)")
