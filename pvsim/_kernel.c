/*
 * pvsim._kernel: the yield model's per-face arithmetic for one chunk of daylight steps.
 *
 * Array in, array out (pvsim/stream.py validates and lays out every argument). For each step of the
 * chunk and each module group it reads the faces' broadband and cover parts, the angle of incidence
 * and the sub-cell currents (factored as the integrator's fused product gives them: diffuse + dni x
 * beam), and writes the area-weighted sums the group's series are built from: the POA parts, the
 * cover, the unshaded POA, the angle of incidence, and per technology the front and total effective
 * irradiance, the low-irradiance-corrected irradiance, the DC power density, the cell temperature and
 * the sub-cell currents. The per-face formulas are those of pvsim/system.py (_Chunk and
 * _GroupAccumulator.add), evaluated in float32 with double sums; the natural logarithm of the
 * low-irradiance law is computed inline (exponent and mantissa split, then the atanh series
 * ln m = 2 (s + s^3/3 + ... + s^9/9), s = (m - 1) / (m + 1), |s| <= 0.172: truncation below 1e-9) so
 * the face loops vectorise.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <stdint.h>
#include <string.h>

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__)
#define PV_CLONES __attribute__((target_clones("avx512f", "avx2", "default")))
#else
#define PV_CLONES
#endif

#define N_PLANES 8  /* broadband direct, sky, ground; cover direct, sky, ground; aoi; sun_visible */
#define N_COMMON 8  /* poa_global, poa_direct, poa_sky, poa_ground, aoi_w, aoi_a, cover, unshaded */
#define N_TECH 7    /* effective_front, effective, low, dc, tc, j0, j1 */
#define TECH_PARAMS 12
#define MAX_TECH 64
#define MAX_CUR 128

/* ln x for finite x > 0 (x <= 0 gives a finite value the caller discards); integer arithmetic only,
 * no branch, so the loops that call it vectorise */
static inline float ln_f(float x)
{
    uint32_t b;
    memcpy(&b, &x, 4);
    uint32_t mb = (b & 0x007fffffu) | 0x3f800000u;          /* mantissa m in [1, 2) */
    uint32_t big = ((mb + 0x004afb0cu) >> 30) & 1u;          /* m >= sqrt(2) */
    mb -= big << 23;                                         /* then m / 2, in [sqrt(1/2), sqrt(2)) */
    float k = (float)((int32_t)((b >> 23) & 0xffu) - 127 + (int32_t)big);
    float m;
    memcpy(&m, &mb, 4);
    float s = (m - 1.0f) / (m + 1.0f), s2 = s * s;
    float p = 1.0f + s2 * (1.0f / 3.0f + s2 * (1.0f / 5.0f + s2 * (1.0f / 7.0f + s2 * (1.0f / 9.0f))));
    return k * 0.69314718f + 2.0f * s * p;
}

typedef struct {
    const float *plane[N_PLANES]; /* row pointers of this step */
    const float *cur[MAX_CUR], *beam[MAX_CUR];
    float dni[MAX_CUR];
    const float *nx, *ny, *nz, *area;
    double sx, sy, sz, dni_est, ta;
    int up;
} row_t;

/* one run of consecutive front faces [f0, f0 + n) with their backs at [b0, b0 + n) (b0 < 0: none) */
PV_CLONES static void run_common(const row_t *r, Py_ssize_t f0, Py_ssize_t n, float *restrict gbuf, double *acc,
                                 float *gmax_out)
{
    const float *bd = r->plane[0] + f0, *bs = r->plane[1] + f0, *bg = r->plane[2] + f0;
    const float *cd = r->plane[3] + f0, *cs = r->plane[4] + f0, *cg = r->plane[5] + f0;
    const float *ao = r->plane[6] + f0, *a = r->area + f0;
    const float *nx = r->nx + f0, *ny = r->ny + f0, *nz = r->nz + f0;
    const float sx = (float)r->sx, sy = (float)r->sy, sz = (float)r->sz, dn = (float)r->dni_est;
    const float upf = r->up ? 1.0f : 0.0f;
    double s0 = 0, s1 = 0, s2 = 0, s3 = 0, s4 = 0, s5 = 0, s6 = 0, s7 = 0;
    float gm = 0.0f;
#pragma omp simd reduction(+ : s0, s1, s2, s3, s4, s5, s6, s7) reduction(max : gm)
    for (Py_ssize_t i = 0; i < n; ++i) {
        float d = bd[i], g = (d + bs[i]) + bg[i], w = a[i];
        float cov = (cd[i] + cs[i]) + cg[i];
        float c = upf * (sx * nx[i] + sy * ny[i] + sz * nz[i]);
        c = c > 0.0f ? c : 0.0f;
        float beam = dn * c;
        float un = g - d + (beam > d ? beam : d);
        gbuf[i] = g;
        gm = g > gm ? g : gm;
        s0 += (double)(w * g);
        s1 += (double)(w * d);
        s2 += (double)(w * bs[i]);
        s3 += (double)(w * bg[i]);
        s6 += (double)(w * cov);
        s7 += (double)(w * un);
    }
    if (r->up) { /* the angle of incidence: NaN on every face with the sun down, finite with it up */
#pragma omp simd reduction(+ : s4, s5)
        for (Py_ssize_t i = 0; i < n; ++i) {
            s4 += (double)(a[i] * ao[i]);
            s5 += (double)a[i];
        }
    }
    acc[0] += s0; acc[1] += s1; acc[2] += s2; acc[3] += s3;
    acc[4] += s4; acc[5] += s5; acc[6] += s6; acc[7] += s7;
    if (gm > *gmax_out) *gmax_out = gm;
}

/* stack power density of the sub-cell currents (before the STC normalisation): kind 1 single
 * junction J, 2 two-terminal min(J0, J1) (V0 + V1), 4 four-terminal J0 V0 + J1 V1 */
static inline __attribute__((always_inline)) float stack_p(int kind, float j0, float j1, float v0, float v1)
{
    if (kind == 1) return j0;
    if (kind == 2) return (j0 < j1 ? j0 : j1) * (v0 + v1);
    return j0 * v0 + j1 * v1;
}

/* effective irradiance of n faces into e (currents cur + dni * beam times the factors) */
static inline __attribute__((always_inline)) void effective_run(int kind, const float *restrict c0,
    const float *restrict b0, float d0, float f0c, const float *restrict c1, const float *restrict b1, float d1,
    float f1c, float v0, float v1, float ceff, Py_ssize_t n, float *restrict e, float *restrict j0o,
    float *restrict j1o)
{
#pragma omp simd
    for (Py_ssize_t i = 0; i < n; ++i) {
        float j0 = (c0[i] + d0 * b0[i]) * f0c;
        float j1 = kind == 1 ? 0.0f : (c1[i] + d1 * b1[i]) * f1c;
        e[i] = ceff * stack_p(kind, j0, j1, v0, v1);
        j0o[i] = j0;
        j1o[i] = j1;
    }
}

/* the low-irradiance law, temperature and sums of n faces */
PV_CLONES __attribute__((noinline)) static void sums_run(const float *restrict e, const float *restrict eb,
    float bif, const float *restrict j0, const float *restrict j1, const float *restrict gbuf,
    const float *restrict a, float A, float gam, float eta, float ta, float kt, Py_ssize_t n, double *acc)
{
    double s0 = 0, s1 = 0, s2 = 0, s3 = 0, s4 = 0, s5 = 0, s6 = 0;
#pragma omp simd reduction(+ : s0, s1, s2, s3, s4, s5, s6)
    for (Py_ssize_t i = 0; i < n; ++i) {
        float et = e[i] + bif * eb[i];
        float rel = 1.0f + A * ln_f(et * 0.001f);   /* et <= 0: low is 0 below */
        rel = rel > 0.0f ? rel : 0.0f;
        float low = (et > 0.0f ? et : 0.0f) * rel;
        float tc = ta + gbuf[i] * kt;
        float dc = eta * low * (1.0f + gam * (tc - 25.0f));
        float w = a[i];
        s0 += (double)(w * e[i]);
        s1 += (double)(w * et);
        s2 += (double)(w * low);
        s3 += (double)(w * dc);
        s4 += (double)(w * tc);
        s5 += (double)(w * j0[i]);
        s6 += (double)(w * j1[i]);
    }
    acc[0] += s0; acc[1] += s1; acc[2] += s2; acc[3] += s3; acc[4] += s4; acc[5] += s5; acc[6] += s6;
}

/* one pass over n faces without rear sides: currents, effective irradiance, the low-irradiance law,
 * temperature and sums (the common case; with rear sides run_tech takes two passes) */
#define ONE_PASS(NAME, KIND)                                                                                 \
    PV_CLONES __attribute__((noinline)) static void NAME(                                                   \
        const float *restrict c0, const float *restrict b0, float d0, float f0c, const float *restrict c1,   \
        const float *restrict b1, float d1, float f1c, float v0, float v1, float ceff,                       \
        const float *restrict gbuf, const float *restrict a, float A, float gam, float eta, float ta,        \
        float kt, Py_ssize_t n, double *acc)                                                                 \
    {                                                                                                        \
        double s0 = 0, s2 = 0, s3 = 0, s4 = 0, s5 = 0, s6 = 0;                                               \
        _Pragma("omp simd reduction(+ : s0, s2, s3, s4, s5, s6)")                                            \
        for (Py_ssize_t i = 0; i < n; ++i) {                                                                 \
            float j0 = (c0[i] + d0 * b0[i]) * f0c;                                                           \
            float j1 = KIND == 1 ? 0.0f : (c1[i] + d1 * b1[i]) * f1c;                                        \
            float e = ceff * stack_p(KIND, j0, j1, v0, v1);                                                  \
            float rel = 1.0f + A * ln_f(e * 0.001f);                                                         \
            rel = rel > 0.0f ? rel : 0.0f;                                                                   \
            float low = (e > 0.0f ? e : 0.0f) * rel;                                                         \
            float tc = ta + gbuf[i] * kt;                                                                    \
            float dc = eta * low * (1.0f + gam * (tc - 25.0f));                                              \
            float w = a[i];                                                                                  \
            s0 += (double)(w * e);                                                                           \
            s2 += (double)(w * low);                                                                         \
            s3 += (double)(w * dc);                                                                          \
            s4 += (double)(w * tc);                                                                          \
            s5 += (double)(w * j0);                                                                          \
            s6 += (double)(w * j1);                                                                          \
        }                                                                                                    \
        acc[0] += s0; acc[1] += s0; acc[2] += s2; acc[3] += s3; acc[4] += s4; acc[5] += s5; acc[6] += s6;    \
    }
ONE_PASS(one_pass_1, 1)
ONE_PASS(one_pass_2, 2)
ONE_PASS(one_pass_4, 4)
#undef ONE_PASS

/* per technology (parameters tp, see py_accumulate) on the run of faces [f0, f0 + n), backs at b0;
 * work: 6 n floats */
PV_CLONES static void run_tech(const row_t *r, const double *tp, double tcoef, Py_ssize_t f0, Py_ssize_t b0,
                               Py_ssize_t n, const float *gbuf, float *work, double *acc)
{
    const int kind = (int)tp[0], r0 = (int)tp[1], r1 = kind == 1 ? (int)tp[1] : (int)tp[3];
    const float f0c = (float)tp[2], f1c = (float)tp[4], v0 = (float)tp[5], v1 = (float)tp[6];
    const float ceff = (float)tp[7], bif = (float)tp[8], A = (float)tp[9], gam = (float)tp[10];
    const float eta = (float)tp[11];
    const float *c0 = r->cur[r0], *e0 = r->beam[r0], *c1 = r->cur[r1], *e1 = r->beam[r1];
    const float d0 = r->dni[r0], d1 = r->dni[r1];
    const int back = b0 >= 0 && bif > 0.0f;
    if (!back) {
#define ONE(NAME) NAME(c0 + f0, e0 + f0, d0, f0c, c1 + f0, e1 + f0, d1, f1c, v0, v1, ceff, gbuf, r->area + f0, A, gam, eta, (float)r->ta, (float)tcoef, n, acc)
        if (kind == 1) ONE(one_pass_1);
        else if (kind == 2) ONE(one_pass_2);
        else ONE(one_pass_4);
#undef ONE
        return;
    }
    float *e = work, *eb = work + n, *j0 = work + 2 * n, *j1 = work + 3 * n, *tmp = work + 4 * n; /* 6 n */
#define EFF(K, F, OUT, J0, J1) effective_run(K, c0 + F, e0 + F, d0, f0c, c1 + F, e1 + F, d1, f1c, v0, v1, ceff, n, OUT, J0, J1)
    switch (kind) {
    case 1: EFF(1, f0, e, j0, j1); EFF(1, b0, eb, tmp, tmp + n); break;
    case 2: EFF(2, f0, e, j0, j1); EFF(2, b0, eb, tmp, tmp + n); break;
    default: EFF(4, f0, e, j0, j1); EFF(4, b0, eb, tmp, tmp + n); break;
    }
#undef EFF
    sums_run(e, eb, bif, j0, j1, gbuf, r->area + f0, A, gam, eta, (float)r->ta, (float)tcoef, n, acc);
}

PV_CLONES static double row_dni(const row_t *r, Py_ssize_t F)
{
    const float *bd = r->plane[0], *sv = r->plane[7];
    const float sx = (float)r->sx, sy = (float)r->sy, sz = (float)r->sz;
    float best = 0.0f;
    if (!r->up) return 0.0;
#pragma omp simd reduction(max : best)
    for (Py_ssize_t f = 0; f < F; ++f) {
        float c = sx * r->nx[f] + sy * r->ny[f] + sz * r->nz[f];
        float v = sv[f];
        float den = v * c;                          /* > 0.1 where the face counts */
        float est = bd[f] / (den > 0.1f ? den : 1.0f);
        est = (v > 0.5f) & (c > 0.2f) ? est : 0.0f;
        best = est > best ? est : best;
    }
    return (double)best;
}

typedef struct {
    Py_buffer b;
    int held;
} buf_t;

static int get_buf(PyObject *o, buf_t *b, int writable, Py_ssize_t itemsize, const char *what)
{
    if (PyObject_GetBuffer(o, &b->b, (writable ? PyBUF_WRITABLE : 0) | PyBUF_C_CONTIGUOUS) < 0) return -1;
    b->held = 1;
    if (b->b.itemsize != itemsize || b->b.len % itemsize) {
        PyErr_Format(PyExc_ValueError, "accumulate: %s has item size %zd, expected %zd", what, b->b.itemsize,
                     itemsize);
        return -1;
    }
    return 0;
}

/* a (Tc, F) float32 view with unit stride along F; the row stride in elements */
static int get_plane(PyObject *o, buf_t *b, Py_ssize_t Tc, Py_ssize_t F, Py_ssize_t *rs)
{
    if (PyObject_GetBuffer(o, &b->b, PyBUF_STRIDED_RO | PyBUF_FORMAT) < 0) return -1;
    b->held = 1;
    if (b->b.ndim != 2 || b->b.itemsize != 4 || strcmp(b->b.format, "f") || b->b.shape[0] != Tc ||
        b->b.shape[1] != F || b->b.strides[1] != 4 || b->b.strides[0] % 4) {
        PyErr_SetString(PyExc_ValueError, "accumulate: a current plane is not a (Tc, F) float32 row view");
        return -1;
    }
    *rs = b->b.strides[0] / 4;
    return 0;
}

static void rel_buf(buf_t *b)
{
    if (b->held) PyBuffer_Release(&b->b);
    b->held = 0;
}

/* accumulate(planes, rows, cur, beam, dni, sun, normals, area, runs, techs, tcoef, ta, dni_out,
 *            common_out, tech_out)
 *   planes   tuple of 8 float32 (nb, F) C-contiguous arrays (the output block)
 *   rows     int64 (Tc,) rows of the block
 *   cur,beam tuples of R float32 (Tc, F) row views; dni float32 (R, Tc)
 *   sun      float64 (Tc, 4): sun vector and up flag; normals float32 (3, F); area float32 (F,)
 *   runs     int64 (nr, 4): group, first front face, count, first back face (-1: none)
 *   techs    float64 (K, 12); tcoef float64 (K, Tc) [K m2 W-1]; ta float64 (Tc,) [degC]
 *   dni_out  float64 (Tc,); common_out float64 (G, Tc, 8); tech_out float64 (G, K, Tc, 7), written */
static PyObject *py_accumulate(PyObject *self, PyObject *args)
{
    PyObject *planes, *o_rows, *cur, *beam, *o_dni, *o_sun, *o_nrm, *o_area, *o_runs, *o_tech, *o_tcoef,
        *o_ta, *o_dout, *o_cout, *o_tout;
    if (!PyArg_ParseTuple(args, "O!OO!O!OOOOOOOOOOO", &PyTuple_Type, &planes, &o_rows, &PyTuple_Type, &cur,
                          &PyTuple_Type, &beam, &o_dni, &o_sun, &o_nrm, &o_area, &o_runs, &o_tech, &o_tcoef,
                          &o_ta, &o_dout, &o_cout, &o_tout))
        return NULL;
    Py_ssize_t R = PyTuple_GET_SIZE(cur);
    if (PyTuple_GET_SIZE(planes) != N_PLANES || PyTuple_GET_SIZE(beam) != R || R > MAX_CUR) {
        PyErr_SetString(PyExc_ValueError, "accumulate: 8 planes and as many beams as currents (<= 128)");
        return NULL;
    }
    buf_t pb[N_PLANES], cb[MAX_CUR], eb[MAX_CUR], ob[12];
    memset(pb, 0, sizeof(pb));
    memset(cb, 0, sizeof(cb));
    memset(eb, 0, sizeof(eb));
    memset(ob, 0, sizeof(ob));
    PyObject *ret = NULL;
    PyObject *objs[12] = {o_rows, o_dni, o_sun, o_nrm, o_area, o_runs, o_tech, o_tcoef, o_ta, o_dout, o_cout, o_tout};
    const Py_ssize_t isz[12] = {8, 4, 8, 4, 4, 8, 8, 8, 8, 8, 8, 8};
    for (int i = 0; i < 12; ++i)
        if (get_buf(objs[i], &ob[i], i >= 9, isz[i], "an argument") < 0) goto done;
    {
        const Py_ssize_t F = ob[4].b.len / 4, Tc = ob[0].b.len / 8, K = ob[6].b.len / (8 * TECH_PARAMS);
        const Py_ssize_t nr = ob[5].b.len / 32;
        const int64_t *rows = ob[0].b.buf, *runs = ob[5].b.buf;
        Py_ssize_t G = 0, nb = 0, crs[MAX_CUR], ers[MAX_CUR];
        for (Py_ssize_t i = 0; i < nr; ++i) G = runs[4 * i] + 1 > G ? runs[4 * i] + 1 : G;
        if (F < 1 || K > MAX_TECH || ob[1].b.len != 4 * R * Tc || ob[2].b.len != 32 * Tc || ob[3].b.len != 12 * F ||
            ob[7].b.len != 8 * K * Tc || ob[8].b.len != 8 * Tc || ob[9].b.len != 8 * Tc ||
            ob[10].b.len != 8 * G * Tc * N_COMMON || ob[11].b.len != 8 * G * K * Tc * N_TECH) {
            PyErr_SetString(PyExc_ValueError, "accumulate: inconsistent sizes");
            goto done;
        }
        for (int i = 0; i < N_PLANES; ++i) {
            if (get_buf(PyTuple_GET_ITEM(planes, i), &pb[i], 0, 4, "a plane") < 0) goto done;
            if (i == 0) nb = pb[0].b.len / (4 * F);
            if (pb[i].b.len != 4 * F * nb) {
                PyErr_SetString(PyExc_ValueError, "accumulate: the planes differ in size");
                goto done;
            }
        }
        for (Py_ssize_t t = 0; t < Tc; ++t)
            if (rows[t] < 0 || rows[t] >= nb) {
                PyErr_SetString(PyExc_IndexError, "accumulate: a row outside the block");
                goto done;
            }
        for (Py_ssize_t i = 0; i < nr; ++i) {
            const int64_t *q = runs + 4 * i;
            if (q[0] < 0 || q[1] < 0 || q[2] < 0 || q[1] + q[2] > F || (q[3] >= 0 && q[3] + q[2] > F)) {
                PyErr_SetString(PyExc_IndexError, "accumulate: a face run outside the faces");
                goto done;
            }
        }
        const double *tp = ob[6].b.buf;
        for (Py_ssize_t k = 0; k < K; ++k) {
            const double *q = tp + TECH_PARAMS * k;
            int kind = (int)q[0];
            if ((kind != 1 && kind != 2 && kind != 4) || q[1] < 0 || q[1] >= R || (kind != 1 && (q[3] < 0 || q[3] >= R))) {
                PyErr_SetString(PyExc_ValueError, "accumulate: a technology row is invalid");
                goto done;
            }
        }
        for (Py_ssize_t i = 0; i < R; ++i) {
            if (get_plane(PyTuple_GET_ITEM(cur, i), &cb[i], Tc, F, &crs[i]) < 0) goto done;
            if (get_plane(PyTuple_GET_ITEM(beam, i), &eb[i], Tc, F, &ers[i]) < 0) goto done;
        }
        const float *dni = ob[1].b.buf, *nrm = ob[3].b.buf, *area = ob[4].b.buf;
        const double *sun = ob[2].b.buf, *tcoef = ob[7].b.buf, *ta = ob[8].b.buf;
        double *dout = ob[9].b.buf, *cout = ob[10].b.buf, *tout = ob[11].b.buf;
        Py_ssize_t maxrun = 1;
        for (Py_ssize_t i = 0; i < nr; ++i) maxrun = runs[4 * i + 2] > maxrun ? runs[4 * i + 2] : maxrun;
        float *gbuf = PyMem_RawMalloc(sizeof(float) * maxrun * 7), *work = gbuf + maxrun;
        float *gmax = PyMem_RawMalloc(sizeof(float) * (G + 1));
        if (!gbuf || !gmax) {
            PyMem_RawFree(gbuf);
            PyMem_RawFree(gmax);
            PyErr_NoMemory();
            goto done;
        }
        memset(cout, 0, 8 * G * Tc * N_COMMON);
        memset(tout, 0, 8 * G * K * Tc * N_TECH);
        Py_BEGIN_ALLOW_THREADS
        for (Py_ssize_t t = 0; t < Tc; ++t) {
            row_t r;
            for (int i = 0; i < N_PLANES; ++i) r.plane[i] = (const float *)pb[i].b.buf + rows[t] * F;
            for (Py_ssize_t i = 0; i < R; ++i) {
                r.cur[i] = (const float *)cb[i].b.buf + t * crs[i];
                r.beam[i] = (const float *)eb[i].b.buf + t * ers[i];
                r.dni[i] = dni[i * Tc + t];
            }
            r.nx = nrm;
            r.ny = nrm + F;
            r.nz = nrm + 2 * F;
            r.area = area;
            r.sx = sun[4 * t];
            r.sy = sun[4 * t + 1];
            r.sz = sun[4 * t + 2];
            r.up = sun[4 * t + 3] > 0.5;
            r.ta = ta[t];
            r.dni_est = row_dni(&r, F);
            dout[t] = r.dni_est;
            for (Py_ssize_t g = 0; g < G; ++g) gmax[g] = 0.0f;
            for (Py_ssize_t i = 0; i < nr; ++i) {
                const int64_t *q = runs + 4 * i;
                Py_ssize_t g = q[0], f0 = q[1], n = q[2], b0 = q[3];
                if (n == 0) continue;
                run_common(&r, f0, n, gbuf, cout + (g * Tc + t) * N_COMMON, &gmax[g]);
                for (Py_ssize_t k = 0; k < K; ++k)
                    run_tech(&r, tp + TECH_PARAMS * k, tcoef[k * Tc + t], f0, b0, n, gbuf, work,
                             tout + ((g * K + k) * Tc + t) * N_TECH);
            }
            for (Py_ssize_t g = 0; g < G; ++g)
                if (!(gmax[g] > 0.0f)) { /* no light on the group: the step adds nothing (as pv_yield) */
                    memset(cout + (g * Tc + t) * N_COMMON, 0, 8 * N_COMMON);
                    for (Py_ssize_t k = 0; k < K; ++k) memset(tout + ((g * K + k) * Tc + t) * N_TECH, 0, 8 * N_TECH);
                }
        }
        Py_END_ALLOW_THREADS
        PyMem_RawFree(gbuf);
        PyMem_RawFree(gmax);
        ret = Py_None;
        Py_INCREF(ret);
    }
done:
    for (int i = 0; i < N_PLANES; ++i) rel_buf(&pb[i]);
    for (Py_ssize_t i = 0; i < R; ++i) {
        rel_buf(&cb[i]);
        rel_buf(&eb[i]);
    }
    for (int i = 0; i < 12; ++i) rel_buf(&ob[i]);
    return ret;
}

static PyMethodDef methods[] = {
    {"accumulate", py_accumulate, METH_VARARGS,
     "Area-weighted yield sums of one chunk of steps per module group (see pvsim.stream)."},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef moddef = {PyModuleDef_HEAD_INIT, "_kernel",
                                    "The yield model's per-face arithmetic (pvsim.stream).", -1, methods};

PyMODINIT_FUNC PyInit__kernel(void) { return PyModule_Create(&moddef); }
