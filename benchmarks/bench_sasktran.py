"""Cost and cost cuts of the SASKTRAN2 backend (skymodel/generator/sasktran.py), issue 37.

python benchmarks/bench_sasktran.py cost     # CPU s per (sky state x wavelength term): I only / I,Q,U, sun up / low / twilight
python benchmarks/bench_sasktran.py kterms   # DoLP from 1 k-term vs all terms, channel with gas absorption
python benchmarks/bench_sasktran.py albedo   # albedo decomposition I(a) = I0 + a c / (1 - a S) from 3 runs
python benchmarks/bench_sasktran.py correction [-4.2 60 20000]   # twilight: Monte Carlo correction of SASKTRAN2's
                                             # multiple scattering (prototype) against plain Monte Carlo

Single thread (OPENBLAS_NUM_THREADS=1, SASKTRAN2 threads 1); CPU seconds of this process (time.process_time),
so a loaded machine changes them less than wall time. Needs the reference data (AFGL, OPAC) and sasktran2.
"""

import os
import sys
import time

os.environ["OPENBLAS_NUM_THREADS"] = "1"  # before numpy and sasktran2 load their OpenBLAS (idle BLAS threads spin)

import numpy as np  # noqa: E402

from widesky.skymodel.generator.montecarlo import Components, channel_components  # noqa: E402
from widesky.skymodel.generator.sasktran import SasktranConfig, trace_stokes  # noqa: E402
from widesky.skymodel.generator.solver import SkyState, channel_problems  # noqa: E402


def components(channels, visibility_km=40.0, albedo=0.0):
    st = SkyState(30.0, visibility_km=visibility_km, ground_albedo=albedo)
    probs, _, atm = channel_problems(st, channels=channels)
    return channel_components(probs, atm, st.albedo(), "continental_average", 50)


def directions(n_zenith, n_azimuth):
    th, ph = np.meshgrid(np.linspace(0.0, 89.5, n_zenith), np.linspace(0.0, 180.0, n_azimuth), indexing="ij")
    return th.ravel(), ph.ravel()


def subset(cp: Components, keep):
    keep = np.asarray(keep)
    ch = np.asarray(cp.channel)[keep]
    _, new_ch = np.unique(ch, return_inverse=True)
    return Components(levels_km=cp.levels_km, extinction=cp.extinction[:, keep], rayleigh=cp.rayleigh[:, keep],
                      aerosol=cp.aerosol[:, keep], depolarisation=cp.depolarisation[keep],
                      aerosol_table=cp.aerosol_table[keep], aerosol_matrices=cp.aerosol_matrices,
                      albedo=cp.albedo[keep], channel=new_ch.astype(np.int32), weight=cp.weight[keep])


def cost():
    cp = components([5])  # 500 nm: 6 components
    K = cp.n_components
    trace_stokes(cp, 60.0, [10.0], [0.0], SasktranConfig())  # warm-up: imports, Greek coefficients
    rows = []
    for nz, na in ((24, 21), (54, 42)):
        vz, va = directions(nz, na)
        for el in (30.0, 5.0, -2.0, -4.2):
            for pol in (False, True):
                for step, label in ((0.25, "0.25 km to 20 km"), (1.0, "1 km to 20 km")):
                    if nz == 54 and (step != 0.25 or el in (-4.2,)):
                        continue
                    cfg = SasktranConfig(polarised=pol, fine_step_km=step)
                    t = time.process_time()
                    r = trace_stokes(cp, 90.0 - el, vz, va, cfg)
                    c = time.process_time() - t
                    rows.append((len(vz), el, "IQU" if pol else "I", label, r.meta["levels"], r.meta["num_sza"],
                                 c / K))
                    print(f"dirs {len(vz):5d} sun {el:+5.1f} {rows[-1][2]:3s} layers {label:16s} levels "
                          f"{r.meta['levels']:3d} num_sza {r.meta['num_sza']:2d}: {c / K:.3f} CPU s per term",
                          flush=True)


def kterms():
    """Channel 940 nm (index 16, water band): DoLP of the channel from all terms vs from the single term of largest
    weight (Q/I of that term times the channel's full I)."""
    for ch in (16, 24, 1):
        cp = components([ch])
        vz, va = directions(12, 13)
        full = trace_stokes(cp, 60.0, vz, va, SasktranConfig())
        k = int(np.argmax(cp.weight))
        one = trace_stokes(subset(cp, [k]), 60.0, vz, va, SasktranConfig())
        d_full = full.degree_of_polarisation()[:, 0]
        d_one = one.degree_of_polarisation()[:, 0]
        # the term that carries most of the channel's radiance (scalar run, one output per term)
        per = Components(**{**cp.__dict__, "channel": np.arange(cp.n_components, dtype=np.int32)})
        contrib = trace_stokes(per, 60.0, vz, va, SasktranConfig(polarised=False)).stokes[:, :, 0].mean(axis=0)
        kr = int(np.argmax(contrib))
        d_r = trace_stokes(subset(cp, [kr]), 60.0, vz, va, SasktranConfig()).degree_of_polarisation()[:, 0]
        print(f"channel {ch}: radiance shares of the terms {np.round(contrib / contrib.sum(), 3)}; DoLP from the "
              f"dominant term: max |dDoLP| = {np.abs(d_r - d_full).max():.4f} (mean {np.abs(d_r - d_full).mean():.4f})")
        # and the three largest-weight terms, weights renormalised
        top = np.argsort(cp.weight)[::-1][:3]
        three = trace_stokes(subset(cp, top), 60.0, vz, va, SasktranConfig())
        d_three = three.degree_of_polarisation()[:, 0]
        print(f"channel {ch}: {cp.n_components} terms; weight of the largest {cp.weight[k]:.3f}; "
              f"max |DoLP_1 - DoLP_all| = {np.abs(d_one - d_full).max():.4f} (mean {np.abs(d_one - d_full).mean():.4f}); "
              f"3 terms: max {np.abs(d_three - d_full).max():.4f}; DoLP range {d_full.min():.3f}-{d_full.max():.3f}")


def albedo():
    """Runs at albedo 0, 0.5, 1 give per direction c and S of I(a) = I0 + a c / (1 - a S); S should not depend on
    the direction (it is the atmosphere's spherical albedo); predict a = 0.2 and 0.8 from a = 0 and 1 with the
    median S and compare with direct runs."""
    vz, va = directions(12, 13)
    for el in (30.0, -2.0):
        res = {}
        for a in (0.0, 0.2, 0.5, 0.8, 1.0):
            res[a] = trace_stokes(components([5], albedo=a), 90.0 - el, vz, va, SasktranConfig()).stokes[:, :, 0]
        d1 = res[1.0] - res[0.0]
        dh = res[0.5] - res[0.0]
        r = d1 / dh
        s = (r - 2.0) / (r - 1.0)
        sm = float(np.median(s))
        c = d1 * (1 - sm)
        worst = 0.0
        for a in (0.2, 0.8):
            pred = res[0.0] + a * c / (1 - a * sm)
            worst = max(worst, float(np.abs(pred / res[a] - 1).max()))
        print(f"sun {el:+.1f}: S per direction {s.min():.4f}..{s.max():.4f} (median {sm:.4f}); albedo 0.2, 0.8 "
              f"from the runs at 0 and 1 with the median S: max |dI/I| = {worst:.2e}")


def rayleigh_components(wavelength_nm=450.0, albedo=0.2):
    """US standard atmosphere, Rayleigh only, the generator's 31 layers (as tests/generator/test_sasktran.py)."""
    from widesky.core.rayleigh import depolarization_ratio, rayleigh_cross_section
    from widesky.skymodel.generator.atmosphere import standard_atmosphere
    from widesky.skymodel.generator.montecarlo import _isotropic_table

    atm = standard_atmosphere("us")
    e = (atm.air * float(rayleigh_cross_section(np.array([wavelength_nm]))[0]) / np.diff(atm.levels_km))[:, None]
    return Components(levels_km=atm.levels_km, extinction=e, rayleigh=e.copy(), aerosol=np.zeros_like(e),
                      depolarisation=np.array([float(depolarization_ratio(wavelength_nm))]),
                      aerosol_table=np.zeros(1, np.int32), aerosol_matrices=_isotropic_table(),
                      albedo=np.array([float(albedo)]), channel=np.zeros(1, np.int32), weight=np.ones(1))


def correction(el=-4.2, n_fit=60, spp=20000):
    """The Monte Carlo estimates only f = I_ms(MC) / I_ms(SASKTRAN2) on n_fit directions (its first order is the same
    deterministic quadrature); f is fitted by weighted least squares on 8 smooth functions of cos(zenith) and
    cos(azimuth) and applied to SASKTRAN2's multiple scattering everywhere. Compared at 11 held-out directions with a
    400000-path reference, and with plain Monte Carlo of spp paths per direction."""
    from widesky.skymodel.generator.montecarlo import MonteCarloConfig, trace

    comps = rayleigh_components()
    rng = np.random.default_rng(5)
    u = (np.arange(n_fit) + rng.random(n_fit)) / n_fit
    vz_f, va_f = np.degrees(np.arccos(1 - u)), rng.permutation(np.linspace(0, 180, n_fit))
    vz_t = np.array([0.0, 30, 60, 80, 60, 85, 45, 89.5, 89.5, 70, 20])
    va_t = np.array([0.0, 0, 90, 180, 45, 120, 170, 0, 180, 30, 150])

    def basis(vz, va):
        x, y = np.cos(np.radians(vz)), np.cos(np.radians(va))
        h = 1 - x
        return np.stack([np.ones_like(x), x, y, x * y, x ** 2, y ** 2, h ** 4, h ** 4 * y], axis=1)

    sk_f = trace_stokes(comps, 90 - el, vz_f, va_f, SasktranConfig())
    sk_t = trace_stokes(comps, 90 - el, vz_t, va_t, SasktranConfig())
    t = time.process_time()
    m_f = trace(comps, 90 - el, vz_f, va_f, MonteCarloConfig(samples=spp, seed=21))
    t_mc = time.process_time() - t
    ratio = (m_f.stokes[:, 0, 0] - sk_f.single[:, 0, 0]) / sk_f.multiple[:, 0, 0]
    w = 1.0 / (m_f.stderr[:, 0, 0] / sk_f.multiple[:, 0, 0]) ** 2
    a = basis(vz_f, va_f)
    coef = np.linalg.lstsq(a * np.sqrt(w)[:, None], ratio * np.sqrt(w), rcond=None)[0]
    cov = np.linalg.inv((a * w[:, None]).T @ a)
    bt = basis(vz_t, va_t)
    f_t, f_se = bt @ coef, np.sqrt(np.einsum("ij,jk,ik->i", bt, cov, bt))
    i_corr = sk_t.single[:, 0, 0] + f_t * sk_t.multiple[:, 0, 0]
    ref = trace(comps, 90 - el, vz_t, va_t, MonteCarloConfig(samples=400000, seed=99))
    plain = trace(comps, 90 - el, vz_t, va_t, MonteCarloConfig(samples=spp, seed=7))
    i_ref = ref.stokes[:, 0, 0]
    print(f"sun {el} deg, {n_fit} fit directions x {spp} paths ({t_mc:.1f} CPU s); view zenith {vz_t}, azimuth {va_t}")
    print("reference se      ", np.round(ref.stderr[:, 0, 0] / i_ref, 4))
    print("SASKTRAN2 dI/I    ", np.round(sk_t.stokes[:, 0, 0] / i_ref - 1, 4))
    print("corrected dI/I    ", np.round(i_corr / i_ref - 1, 4))
    print("  its noise       ", np.round(f_se * sk_t.multiple[:, 0, 0] / i_corr, 4))
    print("plain MC dI/I     ", np.round(plain.stokes[:, 0, 0] / i_ref - 1, 4))
    print("  its noise       ", np.round(plain.stderr[:, 0, 0] / plain.stokes[:, 0, 0], 4))


if __name__ == "__main__":
    cmd = sys.argv[1] if len(sys.argv) > 1 else "cost"
    if cmd == "correction":
        correction(*(float(x) if i == 0 else int(x) for i, x in enumerate(sys.argv[2:5])))
    else:
        {"cost": cost, "kterms": kterms, "albedo": albedo}[cmd]()
