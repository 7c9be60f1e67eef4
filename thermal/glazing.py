"""Glazing units: layers combined with their inter-reflections, absorbed solar per layer, the
inward-flowing fraction, U-value and solar heat gain coefficient, per wavelength and angle.

A unit is a list of layers (outside first) separated by gas gaps. Each layer's optics per angle of
incidence, wavelength and polarisation come from :mod:`widesky.thermal.optics` (uncoated: Fresnel slab from
n, k; coated: the scaled-substrate rule with the substrate's s and p shapes). Layers are combined,
for s and p light separately and then averaged, by the adding method (net radiation between
parallel specular layers, all at the same angle in air)::

    rho_N = 0,  rho_{j-1} = Rf_j + Tf_j Tb_j rho_j / (1 - Rb_j rho_j)     (stack reflectance seen
                                                                          from gap j-1)
    f_0 = 1,   f_j = Tf_j f_{j-1} / (1 - Rb_j rho_j),   b_j = rho_j f_j     (inward / outward flux)
    A_j = (1 - Tf_j - Rf_j) f_{j-1} + (1 - Tb_j - Rb_j) b_j                 (absorbed in layer j)

The inward-flowing fraction of the heat absorbed in layer j follows from the thermal resistances
between the layer and the outside and inside air (EN 410:2011 section 5.4.3, generalised to N
layers; glass conduction neglected as there): ``N_j = R_out,j / R_total``. The solar heat gain
coefficient is ``g = T + sum_j N_j A_j`` at every angle and wavelength. Gap conductances and the
U-value follow EN 673:2011 (radiation between the facing emissivities, gas conduction/convection
from the Nusselt correlation for vertical gaps, the standard's 10 degC gas properties, 15 K across
each gap).

Units: wavelength [nm], thickness [mm], angles [deg], conductances [W m-2 K-1], optics [1].
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from widesky.core.fresnel import invert_slab, slab
from widesky.core.paths import runtime_file

from .optics import coated_angular, equivalent_slab, hemispherical

__all__ = ["GlazingLayer", "Gap", "GlazingUnit", "GAS_PROPERTIES", "combine_layers",
           "inward_fractions", "gap_conductance", "read_igdb", "read_nk_yml", "layer_from_nk",
           "layer_from_broadband", "read_solar_spectrum", "solar_weighted", "ANGLES",
           "WAVELENGTHS", "SIGMA"]

SIGMA = 5.670374419e-8
"""Stefan-Boltzmann constant [W m-2 K-4]."""

ANGLES = np.array([0, 10, 20, 30, 40, 45, 50, 55, 60, 65, 70, 75, 80, 85, 87.5, 90.0])
"""Default angles of incidence of glazing tables [deg]."""

WAVELENGTHS = np.arange(280.0, 2500.1, 10.0)
"""Default wavelength grid of glazing tables [nm] (the sky model's 280-2480 nm plus the last edge)."""

GAS_PROPERTIES = {
    # EN 673:2011 Table B.1 at 10 degC: density [kg m-3], dynamic viscosity [kg m-1 s-1],
    # conductivity [W m-1 K-1], specific heat [J kg-1 K-1]
    "air": (1.232, 1.761e-5, 2.496e-2, 1.008e3),
    "argon": (1.699, 2.164e-5, 1.684e-2, 0.519e3),
    "krypton": (3.560, 2.400e-5, 0.900e-2, 0.245e3),
}


@dataclass(frozen=True)
class GlazingLayer:
    """One glazing layer's normal-incidence spectra and the model of its angular behaviour.

    Attributes
    ----------
    name : str
    wavelength : numpy.ndarray
        (K,) [nm].
    T, Rf, Rb : numpy.ndarray
        (K,) normal transmittance, front (outside-facing) and back reflectance [1].
    thickness_mm : float
        [mm].
    emissivity_front, emissivity_back : float
        Hemispherical long-wave emissivities [1].
    conductivity : float
        Glass conductivity [W m-1 K-1].
    coated : bool
        True: the angular shape comes from ``n``, ``k`` of the substrate (scaled-substrate rule);
        False: the layer is the uncoated slab with that ``n``, ``k``.
    n, k : numpy.ndarray
        (K,) refractive index and extinction coefficient of the (substrate) glass [1].
    angular_model : {"substrate", "equivalent"}
        For coated layers: the scaled-substrate rule (default) or the equivalent-slab route
        (:func:`widesky.thermal.optics.equivalent_slab`), the second estimate used for the uncertainty.
    """

    name: str
    wavelength: np.ndarray
    T: np.ndarray
    Rf: np.ndarray
    Rb: np.ndarray
    thickness_mm: float
    emissivity_front: float = 0.84
    emissivity_back: float = 0.84
    conductivity: float = 1.0
    coated: bool = False
    n: np.ndarray = None
    k: np.ndarray = None
    angular_model: str = "substrate"

    def __post_init__(self):
        if self.angular_model not in ("substrate", "equivalent"):
            raise ValueError(f"angular_model={self.angular_model!r} not one of "
                             "('substrate', 'equivalent')")
        for name in ("emissivity_front", "emissivity_back"):
            v = getattr(self, name)
            if not 0 < v <= 1:
                raise ValueError(f"{name}={v!r} outside (0, 1]")
        if self.n is None or self.k is None:
            n, k = invert_slab(self.T, 0.5 * (self.Rf + self.Rb), self.thickness_mm, self.wavelength)
            object.__setattr__(self, "n", n)
            object.__setattr__(self, "k", k)

    def optics(self, aoi, wavelength=None, polarised=False):
        """(T, Rf, Rb) per angle and wavelength, each (A, K) [1].

        Parameters
        ----------
        aoi : array_like
            (A,) angles of incidence [deg].
        wavelength : array_like, optional
            (K,) [nm]; default the layer's own grid. Values are interpolated linearly (held at the
            ends) before the angular model is applied.
        polarised : bool
            Return ((T, Rf, Rb) for s light, (T, Rf, Rb) for p light).
        """
        wl = self.wavelength if wavelength is None else np.asarray(wavelength, dtype=float)

        def at(v):
            return np.interp(wl, self.wavelength, v)
        if not self.coated:
            res = slab(at(self.n), at(self.k), self.thickness_mm, wl, aoi, polarised=polarised)
            if polarised:
                return tuple((T, R, R) for T, R in res)
            return res[0], res[1], res[1]
        if self.angular_model == "equivalent":
            return equivalent_slab(at(self.T), at(self.Rf), at(self.Rb), self.thickness_mm, wl,
                                   aoi, polarised)
        return coated_angular(at(self.T), at(self.Rf), at(self.Rb), at(self.n), at(self.k),
                              self.thickness_mm, wl, aoi, polarised)

    def flipped(self):
        """The same layer mounted the other way round (front and back swapped)."""
        return GlazingLayer(self.name + " (flipped)", self.wavelength, self.T, self.Rb, self.Rf,
                            self.thickness_mm, self.emissivity_back, self.emissivity_front,
                            self.conductivity, self.coated, self.n, self.k, self.angular_model)


@dataclass(frozen=True)
class Gap:
    """A gas gap between two layers: ``gas`` one of :data:`GAS_PROPERTIES`, width [mm]."""

    thickness_mm: float
    gas: str = "air"

    def __post_init__(self):
        if self.gas not in GAS_PROPERTIES:
            raise ValueError(f"gas={self.gas!r} not one of {sorted(GAS_PROPERTIES)}")
        if not 0 < self.thickness_mm <= 100:
            raise ValueError(f"thickness_mm={self.thickness_mm!r} outside (0, 100]")


def combine_layers(Tf, Tb, Rf, Rb):
    """System optics of specular layers with all inter-reflections (adding method, module docs).

    Parameters
    ----------
    Tf, Tb, Rf, Rb : array_like
        (N, ...) per-layer front/back transmittance and reflectance [1], outside layer first.

    Returns
    -------
    T, R : numpy.ndarray
        (...) system transmittance and front reflectance for light from outside [1].
    A : numpy.ndarray
        (N, ...) fraction absorbed in each layer [1]; ``T + R + A.sum(0) = 1``.
    """
    Tf, Tb, Rf, Rb = (np.asarray(a, dtype=float) for a in (Tf, Tb, Rf, Rb))
    N = Tf.shape[0]
    rho = [None] * (N + 1)
    rho[N] = np.zeros(Tf.shape[1:])
    def div(a, den):                     # den = 0 only at grazing incidence, where a = 0
        return np.where(den > 1e-12, a / np.where(den > 1e-12, den, 1.0), 0.0)
    for j in range(N, 0, -1):
        i = j - 1
        rho[j - 1] = Rf[i] + div(Tf[i] * Tb[i] * rho[j], 1 - Rb[i] * rho[j])
    f = np.ones(Tf.shape[1:])
    A = np.empty_like(Tf)
    for j in range(1, N + 1):
        i = j - 1
        f_next = div(Tf[i] * f, 1 - Rb[i] * rho[j])
        b_next = rho[j] * f_next
        A[i] = (1 - Tf[i] - Rf[i]) * f + (1 - Tb[i] - Rb[i]) * b_next
        f = f_next
    return f, rho[0], A


def gap_conductance(gap: Gap, emissivity_1, emissivity_2, mean_temperature=283.0, delta_t=15.0):
    """EN 673 conductance of a vertical gas gap [W m-2 K-1]: radiation + gas.

    Parameters
    ----------
    gap : Gap
    emissivity_1, emissivity_2 : float
        Emissivities of the two facing surfaces [1].
    mean_temperature : float
        [K] (EN 673: 283 K).
    delta_t : float
        Temperature difference across the gap [K] (EN 673: 15 K).
    """
    h_r = 4 * SIGMA * mean_temperature ** 3 / (1 / emissivity_1 + 1 / emissivity_2 - 1)
    rho, mu, lam, c = GAS_PROPERTIES[gap.gas]
    s = gap.thickness_mm * 1e-3
    gr = 9.81 * s ** 3 * delta_t * rho ** 2 / (mean_temperature * mu ** 2)
    pr = mu * c / lam
    nu = max(1.0, 0.035 * (gr * pr) ** 0.38)
    return h_r + nu * lam / s


def inward_fractions(h_out, h_in, gap_conductances):
    """Inward-flowing fraction of the heat absorbed in each layer (resistance network) [1].

    Parameters
    ----------
    h_out, h_in : float
        Outside and inside surface coefficients [W m-2 K-1].
    gap_conductances : sequence of float
        (N-1,) gap conductances [W m-2 K-1], outside gap first.

    Returns
    -------
    numpy.ndarray
        (N,) fractions N_j = R(outside air -> layer j) / R(outside air -> inside air).
    """
    if h_out <= 0 or h_in <= 0:
        raise ValueError(f"h_out={h_out!r}, h_in={h_in!r} W m-2 K-1 must be > 0")
    r_gaps = 1.0 / np.asarray(gap_conductances, dtype=float)
    r_out = 1.0 / h_out + np.concatenate([[0.0], np.cumsum(r_gaps)])
    return r_out / (r_out[-1] + 1.0 / h_in)


@dataclass(frozen=True)
class GlazingUnit:
    """Layers (outside first) and the gaps between them.

    Attributes
    ----------
    name : str
    layers : tuple of GlazingLayer
    gaps : tuple of Gap
        ``len(layers) - 1`` gaps.
    h_out : float
        Outside surface coefficient [W m-2 K-1] (EN 410/EN 673: 23).
    h_in : float or None
        Inside surface coefficient [W m-2 K-1]; default EN 673's ``3.6 + 4.4 eps / 0.837`` with the
        room-facing emissivity (8.0 for uncoated glass).
    """

    name: str
    layers: tuple
    gaps: tuple = ()
    h_out: float = 23.0
    h_in: float = None
    _cache: dict = field(default_factory=dict, compare=False, repr=False)

    def __post_init__(self):
        object.__setattr__(self, "layers", tuple(self.layers))
        object.__setattr__(self, "gaps", tuple(self.gaps))
        if not self.layers:
            raise ValueError("layers is empty: a glazing unit needs at least one layer")
        if len(self.gaps) != len(self.layers) - 1:
            raise ValueError(f"gaps has {len(self.gaps)} entries, layers {len(self.layers)}: "
                             f"need {len(self.layers) - 1}")
        if self.h_in is None:
            object.__setattr__(self, "h_in", 3.6 + 4.4 * self.layers[-1].emissivity_back / 0.837)

    def gap_conductances(self):
        """(N-1,) EN 673 gap conductances [W m-2 K-1]."""
        return np.array([gap_conductance(g, a.emissivity_back, b.emissivity_front)
                         for g, a, b in zip(self.gaps, self.layers[:-1], self.layers[1:])])

    def u_value(self):
        """Centre-of-glass thermal transmittance [W m-2 K-1] (EN 673)."""
        r = 1 / self.h_out + 1 / self.h_in + np.sum(1 / self.gap_conductances())
        r += sum(layer.thickness_mm * 1e-3 / layer.conductivity for layer in self.layers)
        return 1.0 / r

    def inward_fractions(self):
        """(N,) inward-flowing fraction of each layer's absorbed solar [1]."""
        return inward_fractions(self.h_out, self.h_in, self.gap_conductances())

    def optics(self, aoi=ANGLES, wavelength=WAVELENGTHS):
        """Optics of the unit for light from outside.

        Parameters
        ----------
        aoi : array_like
            (A,) angles of incidence [deg].
        wavelength : array_like
            (K,) [nm].

        Returns
        -------
        dict
            ``transmittance`` (A, K), ``reflectance`` (A, K), ``absorbed`` (N, A, K) per layer,
            ``inward_fraction`` (N,), ``shgc`` (A, K) = T + sum_j N_j A_j, all [1]; ``aoi`` [deg]
            and ``wavelength`` [nm].
        """
        aoi = np.atleast_1d(np.asarray(aoi, dtype=float))
        wl = np.atleast_1d(np.asarray(wavelength, dtype=float))
        key = (aoi.tobytes(), wl.tobytes())
        if key in self._cache:
            return self._cache[key]
        # s and p light through the whole stack, averaged at the end
        per = np.array([layer.optics(aoi, wl, polarised=True) for layer in self.layers])
        T = R = A = 0.0                                          # per: (N, 2 pol, 3, A, K)
        for p in range(2):
            Tf, Rf, Rb = per[:, p, 0], per[:, p, 1], per[:, p, 2]
            Tp, Rp, Ap = combine_layers(Tf, Tf, Rf, Rb)
            T, R, A = T + 0.5 * Tp, R + 0.5 * Rp, A + 0.5 * Ap
        Nf = self.inward_fractions()
        out = {"aoi": aoi, "wavelength": wl, "transmittance": T, "reflectance": R,
               "absorbed": A, "inward_fraction": Nf,
               "shgc": T + np.tensordot(Nf, A, axes=(0, 0))}
        self._cache[key] = out
        return out

    def rated(self, spectrum_wavelength, spectrum, aoi=0.0):
        """Solar-weighted values at one angle [1]: ``transmittance``, ``shgc``, ``absorbed`` (N,).

        Parameters
        ----------
        spectrum_wavelength, spectrum : array_like
            A solar spectrum [nm], [W m-2 nm-1] (e.g. :func:`read_solar_spectrum`, AM1.5 global).
        aoi : float
            [deg].
        """
        wl = np.asarray(spectrum_wavelength, dtype=float)
        o = self.optics([aoi], wl)
        return {"transmittance": solar_weighted(wl, o["transmittance"][0], spectrum),
                "shgc": solar_weighted(wl, o["shgc"][0], spectrum),
                "absorbed": np.array([solar_weighted(wl, a[0], spectrum) for a in o["absorbed"]])}

    def hemispherical(self, quantity="shgc", wavelength=WAVELENGTHS):
        """Diffuse (hemispherical) value of ``quantity`` per wavelength (K,) [1]."""
        o = self.optics(ANGLES, wavelength)
        return hemispherical(ANGLES, o[quantity])


def solar_weighted(wavelength, values, spectrum):
    """Spectrum-weighted mean ``int v E dl / int E dl`` by the trapezoid rule [unit of values]."""
    wl = np.asarray(wavelength, dtype=float)
    e = np.asarray(spectrum, dtype=float)
    return float(np.trapezoid(np.asarray(values) * e, wl) / np.trapezoid(e, wl))


# --------------------------------------------------------------------------- readers

def read_igdb(path, substrate=None) -> GlazingLayer:
    """Read an IGDB/Optics5 text file (LBNL format: header lines in braces, then columns
    wavelength [um], T, Rfront, Rback).

    A coated layer (``Type: Coated``) takes the angular shape of its substrate: ``substrate``
    (a GlazingLayer) if given, else the file named in ``Substrate Filename`` beside ``path`` when it
    exists, else its own normal values inverted into an n, k slab (equivalent-slab route).

    Raises
    ------
    ValueError
        Naming the file and line of a malformed entry.
    """
    path = Path(path)
    head, rows = {}, []
    for i, line in enumerate(path.read_text(encoding="latin-1").splitlines(), 1):
        s = line.strip()
        if not s:
            continue
        if s.startswith("{"):
            m = re.match(r"\{\s*([^}]*?)\s*\}\s*(.*)$", s)
            if m:
                key, _, val = m.group(1).partition(":")
                head[key.strip()] = (val.strip() or m.group(2).strip())
            continue
        parts = s.split()
        try:
            vals = [float(p) for p in parts[:4]]
        except ValueError:
            raise ValueError(f"{path}:{i}: expected 'wavelength T Rfront Rback' (an IGDB/Optics text file), got "
                             f"{s[:60]!r}") from None
        if len(vals) != 4:
            raise ValueError(f"{path}:{i}: expected 4 columns, got {len(parts)}")
        # a NaN or infinite value would pass every range check below and reach g as nan
        if not all(np.isfinite(vals)):
            raise ValueError(f"{path}:{i}: {s!r} is not finite: wavelength [um], T, Rfront and Rback must be "
                             "numbers, T and R in [0, 1]")
        if not all(0.0 <= v <= 1.0 for v in vals[1:]):
            raise ValueError(f"{path}:{i}: {s!r}: T, Rfront and Rback must lie in [0, 1]")
        # energy conservation: what a layer transmits and reflects cannot exceed what falls on it
        for side, r in (("Rfront", vals[2]), ("Rback", vals[3])):
            if vals[1] + r > 1.0 + 1e-9:
                raise ValueError(f"{path}:{i}: T + {side} = {vals[1] + r:.4g} at {vals[0]:g} um exceeds 1 "
                                 "(T + R + absorptance = 1: T + R must be <= 1)")
        rows.append(vals + [i])
    if len(rows) < 2:
        raise ValueError(f"{path}: no spectral data rows")
    data = np.array(rows)
    lines, data = data[:, 4].astype(int), data[:, :4]
    if data[0, 0] <= 0:
        raise ValueError(f"{path}:{lines[0]}: wavelength {data[0, 0]:g} um must be > 0")
    if np.any(np.diff(data[:, 0]) <= 0):
        k = int(np.flatnonzero(np.diff(data[:, 0]) <= 0)[0]) + 1
        raise ValueError(f"{path}:{lines[k]}: wavelength {data[k, 0]:g} um does not follow "
                         f"{data[k - 1, 0]:g} um: wavelengths must increase")
    try:
        thickness = float(head["Thickness"].split()[0])
        emis = [float(v) for v in re.findall(r"[-+]?\d*\.?\d+(?:[eE][-+]?\d+)?",
                                            head.get("Emissivity, front back", "0.84 0.84"))]
        cond = float(head.get("Conductivity", "1").split()[0])
    except (KeyError, ValueError, IndexError):
        raise ValueError(f"{path}: header needs Thickness, Emissivity and Conductivity") from None
    coated = head.get("Type", "").lower().startswith("coated")
    wl = data[:, 0] * 1000.0
    n = k = None
    if coated:
        sub = substrate
        sub_name = head.get("Substrate Filename", "N/A")
        if sub is None and sub_name not in ("", "N/A") and (path.parent / sub_name).is_file():
            sub = read_igdb(path.parent / sub_name)
        if sub is not None:
            n, k = np.interp(wl, sub.wavelength, sub.n), np.interp(wl, sub.wavelength, sub.k)
    return GlazingLayer(head.get("Product Name", path.stem), wl, data[:, 1], data[:, 2],
                        data[:, 3], thickness, emis[0], emis[1] if len(emis) > 1 else emis[0],
                        cond, coated, n, k)


def read_nk_yml(path):
    """Refractive index and extinction of a refractiveindex.info entry with ``formula 5`` for n
    (``n = c0 + sum c_i lambda^c_{i+1}``, lambda in um) and ``tabulated k``.

    Returns
    -------
    wavelength_nm, n, k : numpy.ndarray
        On the tabulated k grid [nm], [1], [1].
    """
    text = Path(path).read_text()
    m = re.search(r"type:\s*formula 5.*?coefficients:\s*([^\n]+)", text, re.S)
    t = re.search(r"type:\s*tabulated k\s*\n\s*data:\s*\|\s*\n(.*?)(?:\n\S|\Z)", text, re.S)
    if not m or not t:
        raise ValueError(f"{path}: expected a 'formula 5' n and a 'tabulated k' block")
    c = [float(v) for v in m.group(1).split()]
    rows = np.array([[float(v) for v in ln.split()] for ln in t.group(1).strip().splitlines()])
    lam_um = rows[:, 0]
    n = np.full_like(lam_um, c[0])
    for i in range(1, len(c) - 1, 2):
        n += c[i] * lam_um ** c[i + 1]
    return lam_um * 1000.0, n, rows[:, 1]


def layer_from_nk(name, wavelength_nm, n, k, thickness_mm, emissivity=0.84, conductivity=1.0):
    """An uncoated layer of the given glass [nm], [1], [1], [mm]; normal spectra from :func:`slab`."""
    T, R = slab(n, k, thickness_mm, wavelength_nm, [0.0])
    return GlazingLayer(name, np.asarray(wavelength_nm, float), T[0], R[0], R[0], thickness_mm,
                        emissivity, emissivity, conductivity, False, np.asarray(n, float),
                        np.asarray(k, float))


def layer_from_broadband(name, tau, rho_front, rho_back, thickness_mm, emissivity_front=0.84,
                         emissivity_back=0.84, conductivity=1.0, substrate=None):
    """A layer known only by its broadband solar values (e.g. an ASHRAE 140 glass record).

    Flat spectra over 280-2500 nm. Equal front and back reflectance: uncoated slab (n, k inverted
    from tau and rho); different ones: coated. A coated layer takes the angular shape of
    ``substrate`` (an uncoated :class:`GlazingLayer`, its n and k; the scaled-substrate rule) when
    given, else of a slab inverted from its own tau and mean rho (for a reflective coating that
    slab has a high index, whose g rises with angle up to 60 deg: give the substrate).
    """
    wl = np.array([280.0, 2500.0])
    coated = abs(rho_front - rho_back) > 1e-9
    n = k = None
    if substrate is not None:
        if substrate.coated:
            raise ValueError(f"substrate={substrate.name!r} must be an uncoated layer")
        n = np.interp(wl, substrate.wavelength, substrate.n)
        k = np.interp(wl, substrate.wavelength, substrate.k)
    return GlazingLayer(name, wl, np.full(2, tau), np.full(2, rho_front), np.full(2, rho_back),
                        thickness_mm, emissivity_front, emissivity_back, conductivity, coated,
                        n, k)


def read_solar_spectrum(data_dir=None, column="global"):
    """ASTM G173-03 reference spectrum (AM1.5): the copy shipped in the package.

    Parameters
    ----------
    data_dir : path, optional
        Read ``solar/ASTMG173.csv`` from this folder instead of the shipped copy.
    column : {"global", "direct", "extraterrestrial"}

    Returns
    -------
    wavelength_nm, irradiance : numpy.ndarray
        280-4000 nm [nm], [W m-2 nm-1].
    """
    cols = ("extraterrestrial", "global", "direct")
    if column not in cols:
        raise ValueError(f"column={column!r} not one of {cols}")
    a = np.loadtxt(runtime_file("solar/ASTMG173.csv", data_dir), delimiter=",", skiprows=2)
    return a[:, 0], a[:, 1 + cols.index(column)]
