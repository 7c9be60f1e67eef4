/*
 * thermal._iso52016: the step loop of the ISO 52016-1 zone balance (thermal/zone_iso52016.py).
 *
 * Array in, array out: simulate_iso52016 builds every array (the constant conductance matrix, the per-step
 * right-hand sides and outside coefficients, the node layout) and checks the matrix's pattern; this kernel
 * runs the steps. Each step is the Python loop's: the outside coefficients and the ventilation on the
 * diagonal, a window's gaps at the mean of its two surface temperatures of the previous step, the inside
 * convective coefficients at the previous step's temperatures (fixed, Walton's TARP, ISO 15099 8.3.2.2 on
 * windows, or Table 25 by the heat flow's direction), then one implicit-Euler solve for the free-floating
 * temperatures and one for a unit heat at the air, and the ideal heating or cooling that holds the air at its
 * set-point.
 *
 * The solve uses the matrix's structure rather than a dense factorisation: each element's nodes form a chain
 * (outside surface to inside surface) coupled to nothing else, so a forward sweep along each chain leaves a
 * dense system on the air node and the inside surfaces only (E + 1 unknowns, Gaussian elimination with partial
 * pivoting), and a backward sweep recovers the chain nodes. Same equations as numpy.linalg.solve on the full
 * matrix; the results agree to rounding (tests/test_thermal_zone_kernel.py).
 *
 * Units: temperatures [degC], conductances [W K-1], heat [W], pressure [Pa], lengths [m], angles [deg].
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define SIGMA 5.670374419e-8
#define AIR_MOLAR_MASS 28.97
#define GAS_CONSTANT 8314.462
#define H_CI_UP 5.0
#define H_CI_DOWN 0.7
#define DEG (3.14159265358979323846 / 180.0)

enum { CONV_FIXED = 0, CONV_TARP = 1, CONV_ISO15099 = 2, CONV_DIR_ROOF = 3, CONV_DIR_FLOOR = 4 };

/* Walton's natural convection, zone_iso52016._tarp_cos */
static double tarp_cos(double dt, double cos_s)
{
    double a = pow(fabs(dt), 1.0 / 3.0), h;
    if (fabs(cos_s) < 1e-6) {
        h = 1.31 * a;
    } else if ((dt > 0) == (cos_s > 0)) {
        h = 9.482 * a / (7.238 - fabs(cos_s));
    } else {
        h = 1.810 * a / (1.382 + fabs(cos_s));
    }
    return h > 0.1 ? h : 0.1;
}

/* ISO 15099:2003 8.3.2.2, zone_iso52016.iso15099_window_convection */
static double iso15099(double dt, double tilt, double height, double temp_air, double pressure)
{
    const double g = 9.81;
    double t_f = temp_air + 273.15 + 0.25 * dt;
    double k = 2.873e-3 + 7.76e-5 * t_f;
    double mu = 3.723e-6 + 4.94e-8 * t_f;
    double cp = 1002.7376 + 1.2324e-2 * t_f;
    double rho = pressure * AIR_MOLAR_MASS / (GAS_CONSTANT * t_f);
    double ra = rho * rho * height * height * height * g * cp * fabs(dt) / (t_f * mu * k);
    double theta = dt > 0 ? 180.0 - tilt : tilt;
    double s = sin(tilt * DEG), nu;
    if (theta < 15.0) {
        nu = 0.13 * pow(ra, 1.0 / 3.0);
    } else if (theta <= 90.0) {
        double ra_cv = 2.5e5 * pow(exp(0.72 * theta) / s, 0.2);
        nu = ra <= ra_cv ? 0.56 * pow(ra * s, 0.25)
                         : 0.13 * (pow(ra, 1.0 / 3.0) - pow(ra_cv, 1.0 / 3.0)) + 0.56 * pow(ra_cv * s, 0.25);
    } else if (theta <= 179.0) {
        double v = ra * s;
        v = v < 1e5 ? 1e5 : (v > 1e11 ? 1e11 : v);
        nu = 0.56 * pow(v, 0.25);
    } else {
        nu = 0.58 * pow(ra < 1e11 ? ra : 1e11, 0.2);
    }
    double h = nu * k / height;
    return h > 0.1 ? h : 0.1;
}

/* buffers: check size in doubles (or int64) */
static int need(Py_buffer *b, Py_ssize_t n, const char *name, Py_ssize_t item)
{
    if (b->len != n * item) {
        PyErr_Format(PyExc_ValueError, "_iso52016.run: %s has %zd bytes, expected %zd", name, b->len, n * item);
        return -1;
    }
    return 0;
}

static PyObject *run(PyObject *self, PyObject *args)
{
    Py_ssize_t N, E, T, n_warm, W;
    double temp_start;
    Py_buffer b_base, b_cdt, b_hout, b_hve, b_rhs, b_hs, b_cs, b_out, b_in, b_area, b_hbase, b_mode, b_cos,
        b_tilt, b_height, b_pres, b_widx, b_wres, b_wrw, b_gstart, b_ghg, b_geps, b_ta, b_tsurf, b_need;
    if (!PyArg_ParseTuple(args, "nnnnnd" "y*y*y*y*y*y*y*" "y*y*y*y*y*y*y*y*y*" "y*y*y*y*y*y*" "w*w*w*",
                          &N, &E, &T, &n_warm, &W, &temp_start,
                          &b_base, &b_cdt, &b_hout, &b_hve, &b_rhs, &b_hs, &b_cs,
                          &b_out, &b_in, &b_area, &b_hbase, &b_mode, &b_cos, &b_tilt, &b_height, &b_pres,
                          &b_widx, &b_wres, &b_wrw, &b_gstart, &b_ghg, &b_geps,
                          &b_ta, &b_tsurf, &b_need))
        return NULL;
    Py_buffer *all[] = {&b_base, &b_cdt, &b_hout, &b_hve, &b_rhs, &b_hs, &b_cs, &b_out, &b_in, &b_area,
                        &b_hbase, &b_mode, &b_cos, &b_tilt, &b_height, &b_pres, &b_widx, &b_wres, &b_wrw,
                        &b_gstart, &b_ghg, &b_geps, &b_ta, &b_tsurf, &b_need};
    const int n_all = (int)(sizeof(all) / sizeof(all[0]));
    PyObject *result = NULL;
    double *work = NULL;
    Py_ssize_t n_gaps = b_ghg.len / (Py_ssize_t)sizeof(double);
    if (N < 2 || E < 1 || T < 1 || n_warm < 0 || W < 0 || n_warm > T ||
        need(&b_base, N * N, "base", 8) || need(&b_cdt, N, "cdt", 8) || need(&b_hout, T * E, "h_out", 8) ||
        need(&b_hve, T, "h_ve", 8) || need(&b_rhs, T * N, "rhs", 8) || need(&b_hs, T, "heating", 8) ||
        need(&b_cs, T, "cooling", 8) || need(&b_out, E, "outside", 8) || need(&b_in, E, "inside", 8) ||
        need(&b_area, E, "area", 8) || need(&b_hbase, E, "h_base", 8) || need(&b_mode, E, "mode", 8) ||
        need(&b_cos, E, "cos_in", 8) || need(&b_tilt, E, "tilt", 8) || need(&b_height, E, "height", 8) ||
        need(&b_pres, T, "pressure", 8) || need(&b_widx, W, "window index", 8) ||
        need(&b_wres, W, "window resistance", 8) || need(&b_wrw, W, "window rated resistance", 8) ||
        need(&b_gstart, W + 1, "gap start", 8) || need(&b_geps, n_gaps, "gap emissivity", 8) ||
        need(&b_ta, T, "temp_air", 8) || need(&b_tsurf, T, "temp_surface", 8) || need(&b_need, T, "need", 8)) {
        if (!PyErr_Occurred())
            PyErr_SetString(PyExc_ValueError, "_iso52016.run: sizes out of range");
        goto done;
    }
    {
        const double *base = b_base.buf, *cdt = b_cdt.buf, *hout = b_hout.buf, *hve = b_hve.buf, *rhs = b_rhs.buf;
        const double *hs = b_hs.buf, *cs = b_cs.buf, *area = b_area.buf, *hbase = b_hbase.buf;
        const double *cos_in = b_cos.buf, *tilt = b_tilt.buf, *height = b_height.buf, *pres = b_pres.buf;
        const double *wres = b_wres.buf, *wrw = b_wrw.buf, *ghg = b_ghg.buf, *geps = b_geps.buf;
        const long long *outside = b_out.buf, *inside = b_in.buf, *mode = b_mode.buf, *widx = b_widx.buf;
        const long long *gstart = b_gstart.buf;
        double *ta = b_ta.buf, *tsurf = b_tsurf.buf, *need_out = b_need.buf;
        Py_ssize_t S = E + 1;
        for (Py_ssize_t i = 0; i < E; i++) {
            if (outside[i] < 1 || inside[i] < outside[i] || inside[i] >= N ||
                (i + 1 < E && outside[i + 1] != inside[i] + 1) || (i == 0 && outside[0] != 1) ||
                (i == E - 1 && inside[i] != N - 1)) {
                PyErr_SetString(PyExc_ValueError, "_iso52016.run: elements' nodes must be consecutive chains");
                goto done;
            }
        }
        for (Py_ssize_t w = 0; w < W; w++) {
            Py_ssize_t j = (Py_ssize_t)widx[w];
            if (j < 0 || j >= E || inside[j] != outside[j] + 1 || gstart[w] < 0 || gstart[w + 1] < gstart[w] ||
                gstart[w + 1] > n_gaps) {
                PyErr_SetString(PyExc_ValueError, "_iso52016.run: bad window gap layout");
                goto done;
            }
        }
        /* work: x (N), diag (N), off (N: chain coupling k -> k+1), d (N), r (2N), h (E), R (S S), q (2S) */
        work = malloc(sizeof(double) * (size_t)(N * 6 + E + S * S + 2 * S));
        if (!work) {
            PyErr_NoMemory();
            goto done;
        }
        double *x = work, *diag = x + N, *off = diag + N, *d = off + N, *r = d + N, *h = r + 2 * N;
        double *R = h + E, *q = R + S * S;
        double a_tot = 0.0;
        for (Py_ssize_t i = 0; i < E; i++)
            a_tot += area[i];
        for (Py_ssize_t k = 0; k < N; k++)
            x[k] = temp_start;
        Py_BEGIN_ALLOW_THREADS
        for (Py_ssize_t step = 0; step < n_warm + T; step++) {
            Py_ssize_t t = step < n_warm ? step : step - n_warm;
            const double *rt = rhs + t * N;
            /* the inside convective coefficients at the previous step's temperatures */
            for (Py_ssize_t i = 0; i < E; i++) {
                double dt = x[inside[i]] - x[0];
                switch (mode[i]) {
                case CONV_TARP: h[i] = tarp_cos(dt, cos_in[i]); break;
                case CONV_ISO15099: h[i] = iso15099(dt, tilt[i], height[i], x[0], pres[t]); break;
                case CONV_DIR_ROOF: h[i] = (x[inside[i]] > x[0]) ? H_CI_DOWN : H_CI_UP; break;
                case CONV_DIR_FLOOR: h[i] = (x[inside[i]] > x[0]) ? H_CI_UP : H_CI_DOWN; break;
                default: h[i] = hbase[i];
                }
            }
            /* diagonal and chain couplings of this step */
            for (Py_ssize_t k = 0; k < N; k++) {
                diag[k] = base[k * N + k];
                off[k] = k + 1 < N ? base[k * N + k + 1] : 0.0;
            }
            diag[0] += hve[t];
            for (Py_ssize_t i = 0; i < E; i++) {
                double dh = (h[i] - hbase[i]) * area[i];
                diag[outside[i]] += hout[t * E + i];
                diag[inside[i]] += dh;
                diag[0] += dh;
            }
            for (Py_ssize_t w = 0; w < W; w++) {
                Py_ssize_t j = (Py_ssize_t)widx[w];
                Py_ssize_t a = outside[j], b = inside[j];
                double tm = 0.5 * (x[a] + x[b]) + 273.15, res = wres[w];
                for (long long gi = gstart[w]; gi < gstart[w + 1]; gi++)
                    res += 1.0 / (ghg[gi] + 4 * SIGMA * geps[gi] * tm * tm * tm);
                double dh = (1.0 / res - 1.0 / wrw[w]) * area[j];
                diag[a] += dh;
                diag[b] += dh;
                off[a] -= dh;
            }
            /* forward sweep along each chain onto its inside node; columns: free, unit heat at the air */
            for (Py_ssize_t i = 0; i < E; i++) {
                Py_ssize_t f = outside[i], l = inside[i];
                d[f] = diag[f];
                r[2 * f] = rt[f] + cdt[f] * x[f];
                r[2 * f + 1] = 0.0;
                for (Py_ssize_t k = f; k < l; k++) {
                    double m = off[k] / d[k];      /* symmetric: M[k+1, k] = M[k, k+1] */
                    d[k + 1] = diag[k + 1] - m * off[k];
                    r[2 * (k + 1)] = rt[k + 1] + cdt[k + 1] * x[k + 1] - m * r[2 * k];
                    r[2 * (k + 1) + 1] = -m * r[2 * k + 1];
                }
            }
            /* the reduced system: air (0) and the inside nodes (1..E) */
            for (Py_ssize_t a = 0; a < S; a++) {
                Py_ssize_t na = a ? inside[a - 1] : 0;
                for (Py_ssize_t b = 0; b < S; b++) {
                    Py_ssize_t nb = b ? inside[b - 1] : 0;
                    R[a * S + b] = base[na * N + nb];
                }
            }
            R[0] = diag[0];
            q[0] = rt[0] + cdt[0] * x[0];
            q[1] = 1.0;
            for (Py_ssize_t i = 0; i < E; i++) {
                Py_ssize_t a = i + 1, l = inside[i];
                double dh = (h[i] - hbase[i]) * area[i];
                R[a * S + a] = d[l];
                R[a * S] -= dh;
                R[a] -= dh;
                q[2 * a] = r[2 * l];
                q[2 * a + 1] = r[2 * l + 1];
            }
            for (Py_ssize_t c = 0; c < S; c++) {        /* Gaussian elimination, partial pivoting */
                Py_ssize_t p = c;
                for (Py_ssize_t a = c + 1; a < S; a++)
                    if (fabs(R[a * S + c]) > fabs(R[p * S + c]))
                        p = a;
                if (p != c) {
                    for (Py_ssize_t b = 0; b < S; b++) {
                        double tmp = R[c * S + b];
                        R[c * S + b] = R[p * S + b];
                        R[p * S + b] = tmp;
                    }
                    for (int k = 0; k < 2; k++) {
                        double tmp = q[2 * c + k];
                        q[2 * c + k] = q[2 * p + k];
                        q[2 * p + k] = tmp;
                    }
                }
                for (Py_ssize_t a = c + 1; a < S; a++) {
                    double m = R[a * S + c] / R[c * S + c];
                    if (m == 0.0)
                        continue;
                    for (Py_ssize_t b = c; b < S; b++)
                        R[a * S + b] -= m * R[c * S + b];
                    q[2 * a] -= m * q[2 * c];
                    q[2 * a + 1] -= m * q[2 * c + 1];
                }
            }
            for (Py_ssize_t c = S - 1; c >= 0; c--) {
                for (int k = 0; k < 2; k++) {
                    double s = q[2 * c + k];
                    for (Py_ssize_t b = c + 1; b < S; b++)
                        s -= R[c * S + b] * q[2 * b + k];
                    q[2 * c + k] = s / R[c * S + c];
                }
            }
            /* the ideal heating (> 0) or cooling (< 0) that holds the air at its set-point */
            double free_air = q[0], unit_air = q[1], Q = 0.0;
            if (free_air < hs[t])
                Q = (hs[t] - free_air) / unit_air;
            else if (free_air > cs[t])
                Q = (cs[t] - free_air) / unit_air;
            x[0] = free_air + Q * unit_air;
            for (Py_ssize_t i = 0; i < E; i++) {           /* backward sweep along each chain */
                Py_ssize_t f = outside[i], l = inside[i];
                double xn = q[2 * (i + 1)] + Q * q[2 * (i + 1) + 1];
                x[l] = xn;
                for (Py_ssize_t k = l - 1; k >= f; k--) {
                    double v = (r[2 * k] + Q * r[2 * k + 1] - off[k] * x[k + 1]) / d[k];
                    x[k] = v;
                }
            }
            if (step >= n_warm) {
                double s = 0.0;
                for (Py_ssize_t i = 0; i < E; i++)
                    s += area[i] * x[inside[i]];
                ta[t] = x[0];
                tsurf[t] = s / a_tot;
                need_out[t] = Q;
            }
        }
        Py_END_ALLOW_THREADS
        result = Py_None;
        Py_INCREF(result);
    }
done:
    free(work);
    for (int k = 0; k < n_all; k++)
        PyBuffer_Release(all[k]);
    return result;
}

static PyMethodDef methods[] = {
    {"run", run, METH_VARARGS,
     "run(N, E, T, n_warm, W, temp_start, base, cdt, h_out, h_ve, rhs, heating, cooling, outside, inside, area, "
     "h_base, mode, cos_in, tilt, height, pressure, window_index, window_resistance, window_rated_resistance, "
     "gap_start, gap_hg, gap_eps, temp_air, temp_surface, need): the ISO 52016-1 step loop (module doc)"},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef moddef = {PyModuleDef_HEAD_INIT, "_iso52016",
                                    "The ISO 52016-1 zone balance's step loop (thermal/zone_iso52016.py).", -1,
                                    methods};

PyMODINIT_FUNC PyInit__iso52016(void) { return PyModule_Create(&moddef); }
