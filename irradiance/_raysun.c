/*
 * irradiance._raysun: the per-point arithmetic of the reflected-sun sampling over the shading cells
 * (irradiance/raystages.py, _cell_sun), array in, array out; raystages.py lays out every argument.
 *
 * draw():       for a block of reflecting points (sorted by orientation bin) and every shading cell, the sun
 *               bin drawn from the point's identity, u = frac(0.5 + (ident + c) 0.618...), pick =
 *               searchsorted(cdf[bin], u tot[bin], "right") capped at C - 1, and the in-front test n . s > 0;
 *               the rays in front are packed, cell by cell in the points' order, into float32 ray origins and
 *               directions for one Embree call per block.
 * accumulate(): the lit rays' weights summed per (cell, analysis point) / (cell, analysis point, bin) from
 *               zero in the rays' order (each cell's terms in the points' order, as numpy.bincount per cell);
 *               raystages.py then adds each cell's sums to its row.
 *
 * The operations are numpy's, in numpy's order (raystages.py before 2026-12-05 computed them with numpy):
 * u's three steps one rounding each (no fused multiply-add: built with -ffp-contract=off), frac by
 * u - floor(u) (exact), numpy's searchsorted (the count of entries <= key of a non-decreasing array: any
 * search that compares the same entries with the same key finds it), the dot product as
 * (n0 s0 + n1 s1) + n2 s2 (numpy's sum over an axis of 3), and numpy.bincount's in-order sums. The results
 * are bit for bit those of the numpy code (tests/test_raystages_sun.py, tests/test_raystages_kernels.py).
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <stdint.h>
#include <string.h>

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__)
#define RS_CLONES __attribute__((target_clones("arch=x86-64-v3", "default")))
#else
#define RS_CLONES
#endif

static int need(Py_buffer *b, Py_ssize_t bytes, const char *what)
{
    if (b->len != bytes) {
        PyErr_Format(PyExc_ValueError, "_raysun: %s has %zd bytes, expected %zd", what, b->len, bytes);
        return -1;
    }
    return 0;
}

/* numpy's searchsorted(side="right") on the non-decreasing cb[0:C]: the count of entries <= key (branch-free; the
 * answer stays in [base, base + len]) */
static inline Py_ssize_t upper_bound(const double *cb, Py_ssize_t C, double key)
{
    Py_ssize_t base = 0, len = C;
    while (len > 1) {
        const Py_ssize_t half = len >> 1;
        base += (cb[base + half] <= key) ? half : 0;
        len -= half;
    }
    return base + (cb[base] <= key);
}

#define NBUCKET 1024

/* The draws of the points a0 <= i < a1 (sorted by orientation bin) for every active cell c, cell by cell: the
 * points of the cell's used bins. The search starts from the cell's table: key = u tot is non-decreasing in u,
 * so for u in [k / NBUCKET, (k + 1) / NBUCKET) the answer lies between those of the bucket's two ends
 * (tab[k], tab[k + 1], numpy's searchsorted of the same products); it is found by comparing the same entries with
 * the same key, so it is the count above. The rays in front are packed in that order (cell, then point). */
RS_CLONES
static Py_ssize_t draw_kernel(int64_t a0, int64_t a1, const void *ident, int ident_float, const int64_t *edges,
                              Py_ssize_t B, Py_ssize_t Gc, const int64_t *cell_k, const int64_t *cell_g,
                              const int64_t *cell_C, const int64_t *cdf_off, const int64_t *sd_off,
                              const int64_t *use_off, const int64_t *use_all, const double *tot_all,
                              const double *cdf_all, const int32_t *tab_all, const double *sd_all,
                              const float *sd32_all, const double *tn, const float *x32, float *xo, float *dout,
                              int64_t *jj, int32_t *gid)
{
    Py_ssize_t m = 0;
    for (Py_ssize_t c = 0; c < Gc; ++c) {
        const Py_ssize_t C = cell_C[c];
        const int64_t add_i = cell_k[c];
        const double add_f = (double)cell_k[c];
        const int32_t g = (int32_t)cell_g[c];
        const double *sd = sd_all + 3 * sd_off[c];
        const float *sd32 = sd32_all + 3 * sd_off[c];
        for (int64_t q = use_off[c]; q < use_off[c + 1]; ++q) {
            const int64_t b = use_all[q];
            const double *cb = cdf_all + cdf_off[c] + b * C;
            const double tb = tot_all[c * B + b];
            const int32_t *tq = tab_all + q * (NBUCKET + 1);
            const int64_t i0 = edges[b] > a0 ? edges[b] : a0, i1 = edges[b + 1] < a1 ? edges[b + 1] : a1;
            for (int64_t i = i0; i < i1; ++i) {
                double u = ident_float ? ((const double *)ident)[i] + add_f
                                       : (double)(((const int64_t *)ident)[i] + add_i);
                u = u * 0.6180339887498949;
                u = u + 0.5;
                u = u - floor(u);                      /* in [0, 1), exact */
                const double key = u * tb;
                int kb = (int)(u * NBUCKET);           /* exact: a power of 2 */
                kb = kb < NBUCKET ? kb : NBUCKET - 1;
                const Py_ssize_t hi = tq[kb + 1] < C ? (tq[kb + 1] > 0 ? tq[kb + 1] : 0) : C;    /* clamped: */
                Py_ssize_t lo = tq[kb] < hi ? (tq[kb] > 0 ? tq[kb] : 0) : hi;               /* in 0..C */
                if (hi - lo > 8)
                    lo += upper_bound(cb + lo, hi - lo, key);
                else
                    while (lo < hi && cb[lo] <= key) ++lo;
                const Py_ssize_t p = lo < C - 1 ? lo : C - 1;
                const double *s = sd + 3 * p, *t = tn + 3 * i;
                double dot = t[0] * s[0] + t[1] * s[1];
                dot = dot + t[2] * s[2];
                if (dot > 0) {
                    xo[3 * m] = x32[3 * i];
                    xo[3 * m + 1] = x32[3 * i + 1];
                    xo[3 * m + 2] = x32[3 * i + 2];
                    dout[3 * m] = sd32[3 * p];
                    dout[3 * m + 1] = sd32[3 * p + 1];
                    dout[3 * m + 2] = sd32[3 * p + 2];
                    gid[m] = g;
                    jj[m++] = i;
                }
            }
        }
    }
    return m;
}

#define N_DRAW 20
static PyObject *py_draw(PyObject *self, PyObject *args)
{
    Py_buffer v[N_DRAW];
    long long a0, a1;
    int ident_float;
    memset(v, 0, sizeof(v));
    /* ident edges cell_k cell_g cell_C cdf_off sd_off use_off use_all tot_all cdf_all tab_all sd_all sd32_all tn x32
     * | xo do jj gid */
    if (!PyArg_ParseTuple(args, "LLy*p" "y*y*y*y*y*y*y*y*y*y*y*y*y*y*y*" "w*w*w*w*", &a0, &a1, &v[0], &ident_float,
                          &v[1], &v[2], &v[3], &v[4], &v[5], &v[6], &v[7], &v[8], &v[9], &v[10], &v[11], &v[12],
                          &v[13], &v[14], &v[15], &v[16], &v[17], &v[18], &v[19]))
        return NULL;
    PyObject *ret = NULL;
    const Py_ssize_t n = v[0].len / 8, B = v[1].len / 8 - 1, Gc = v[2].len / 8, U = v[8].len / 8;
    const Py_ssize_t ncdf = v[10].len / 8, nsd = v[12].len / 24, nout = v[19].len / 4;
    if (B < 1 || a0 < 0 || a1 < a0 || a1 > n || need(&v[3], 8 * Gc, "cell_g") || need(&v[4], 8 * Gc, "cell_C") ||
        need(&v[5], 8 * Gc, "cdf_off") || need(&v[6], 8 * Gc, "sd_off") || need(&v[7], 8 * (Gc + 1), "use_off") ||
        need(&v[9], 8 * Gc * B, "tot_all") || need(&v[11], 4 * U * (NBUCKET + 1), "tab_all") ||
        need(&v[13], 12 * nsd, "sd32_all") || need(&v[14], 24 * n, "tn") || need(&v[15], 12 * n, "x32") ||
        need(&v[16], 12 * nout, "xo") || need(&v[17], 12 * nout, "do") || need(&v[18], 8 * nout, "jj"))
        goto done;
    {
        const int64_t *edges = v[1].buf, *cell_C = v[4].buf, *cdf_off = v[5].buf, *sd_off = v[6].buf,
                      *use_off = v[7].buf, *use_all = v[8].buf;
        const int32_t *tab = v[11].buf;
        for (Py_ssize_t b = 0; b < B; ++b)
            if (edges[b] < 0 || edges[b] > edges[b + 1] || edges[b + 1] > n) {
                PyErr_SetString(PyExc_IndexError, "_raysun.draw: edges outside the points");
                goto done;
            }
        Py_ssize_t rays = 0;
        for (Py_ssize_t c = 0; c < Gc; ++c) {
            if (cell_C[c] < 1 || cdf_off[c] < 0 || cdf_off[c] + B * cell_C[c] > ncdf || sd_off[c] < 0 ||
                sd_off[c] + cell_C[c] > nsd || use_off[c] < 0 || use_off[c] > use_off[c + 1] || use_off[c + 1] > U) {
                PyErr_SetString(PyExc_IndexError, "_raysun.draw: a cell outside its arrays");
                goto done;
            }
            for (int64_t q = use_off[c]; q < use_off[c + 1]; ++q) {
                if (use_all[q] < 0 || use_all[q] >= B) {
                    PyErr_SetString(PyExc_IndexError, "_raysun.draw: a bin outside the bins");
                    goto done;
                }
                const int64_t b = use_all[q];
                const int64_t i0 = edges[b] > a0 ? edges[b] : a0, i1 = edges[b + 1] < a1 ? edges[b + 1] : a1;
                rays += i1 > i0 ? i1 - i0 : 0;
            }
        }
        if (rays > nout) {
            PyErr_SetString(PyExc_ValueError, "_raysun.draw: the ray buffers are too small");
            goto done;
        }
        Py_ssize_t m;
        Py_BEGIN_ALLOW_THREADS
        m = draw_kernel(a0, a1, v[0].buf, ident_float, edges, B, Gc, v[2].buf, v[3].buf, cell_C, cdf_off, sd_off,
                        use_off, use_all, v[9].buf, v[10].buf, tab, v[12].buf, v[13].buf, v[14].buf, v[15].buf,
                        v[16].buf, v[17].buf, v[18].buf, v[19].buf);
        Py_END_ALLOW_THREADS
        ret = PyLong_FromSsize_t(m);
    }
done:
    for (int k = 0; k < N_DRAW; ++k) PyBuffer_Release(&v[k]);
    return ret;
}

static PyObject *py_accumulate(PyObject *self, PyObject *args)
{
    Py_buffer bj, bgid, bo, bg, bog, bor, bw, btg, btr;
    Py_ssize_t m, G;
    if (!PyArg_ParseTuple(args, "ny*y*y*y*y*y*y*nw*w*", &m, &bj, &bgid, &bo, &bg, &bog, &bor, &bw, &G, &btg, &btr))
        return NULL;
    Py_buffer *all[] = {&bj, &bgid, &bo, &bg, &bog, &bor, &bw, &btg, &btr};
    PyObject *ret = NULL;
    const Py_ssize_t n = bg.len;
    if (G < 1 || m < 0 || m > bj.len / 8 || m > bgid.len / 4 || m > bo.len || need(&bog, 8 * n, "out_g") ||
        need(&bor, 8 * n, "out_r") || need(&bw, 8 * n, "w") || btg.len % (8 * G) || btr.len % (8 * G))
        goto done;
    {
        const int64_t *jj = bj.buf, *og = bog.buf, *orr = bor.buf;
        const int32_t *gid = bgid.buf;
        const uint8_t *occ = bo.buf, *on_g = bg.buf;
        const double *w = bw.buf;
        double *tg = btg.buf, *tr = btr.buf;
        const Py_ssize_t ng = btg.len / 8 / G, nr = btr.len / 8 / G;
        int bad = 0;
        Py_BEGIN_ALLOW_THREADS
        for (Py_ssize_t q = 0; q < m; ++q) {
            if (occ[q]) continue;
            const int64_t k = jj[q];
            const int32_t g = gid[q];
            if (k < 0 || k >= n || g < 0 || g >= G) { bad = 1; break; }
            if (on_g[k]) {
                if (og[k] < 0 || og[k] >= ng) { bad = 1; break; }
                tg[g * ng + og[k]] += w[k];
            } else {
                if (orr[k] < 0 || orr[k] >= nr) { bad = 1; break; }
                tr[g * nr + orr[k]] += w[k];
            }
        }
        Py_END_ALLOW_THREADS
        if (bad) {
            PyErr_SetString(PyExc_IndexError, "_raysun.accumulate: an index outside the rows");
            goto done;
        }
        Py_INCREF(Py_None);
        ret = Py_None;
    }
done:
    for (size_t k = 0; k < sizeof(all) / sizeof(all[0]); ++k) PyBuffer_Release(all[k]);
    return ret;
}

static PyMethodDef methods[] = {
    {"draw", py_draw, METH_VARARGS,
     "draw(a0, a1, ident, ident_is_float, edges, cell_k, cell_g, cell_C, cdf_off, sd_off, use_off, use_all, tot_all,\n"
     "cdf_all, tab_all, sd_all, sd32_all, tn, x32, xo, do, jj, gid) -> m: the sun bins drawn for the points\n"
     "a0:a1 of every active cell's used bins and the in-front test; the m rays in front packed into xo, do\n"
     "(float32 origins, directions), jj (their points) and gid (their cells), cell by cell."},
    {"accumulate", py_accumulate, METH_VARARGS,
     "accumulate(m, jj, gid, occluded, on_g, out_g, out_r, w, G, tmp_g, tmp_r): the unoccluded rays' weights\n"
     "added in order to tmp_g (G, n_g) or tmp_r (G, n_r) at (cell, out_g / out_r of the point)."},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef moddef = {PyModuleDef_HEAD_INIT, "_raysun",
                                    "The reflected-sun sampling's per-point kernels (irradiance/raystages.py).", -1,
                                    methods};

PyMODINIT_FUNC PyInit__raysun(void) { return PyModule_Create(&moddef); }
