/*
 * widesky skymodel._core: hot kernels of the Prague Sky Model evaluator.
 *
 * Array in, array out. The Python wrapper (skymodel/evaluate.py) validates every argument,
 * converts units and computes the per-sky-state quantities (configuration weights, sun vector);
 * these kernels do the per-direction and per-channel work with the GIL released, OpenMP over
 * directions.
 *
 * The evaluation rules follow the published reference algorithm (Wilkie et al. 2021, Vevoda et al.
 * 2022) as documented in shared/spec/psm-dataset-format.md section 5: parameter computation with the
 * 50 m safety altitude and altitude-corrected view direction, clamped knot lookup, piecewise-linear
 * factors in double precision, per-configuration clamp at zero, nested linear interpolation over
 * visibility, albedo, altitude and elevation, and the transmittance (altitude, distance) mapping.
 *
 * Two radiance paths:
 *   direct: per direction the angle lookups are done once and reused for every channel and
 *           configuration (the reference's work, reorganised): only the configurations of non-zero
 *           weight, directions sorted by sun knot in chunks, and (AVX2/FMA or AVX-512, chosen at run
 *           time) four or eight channels per vector from a channel-contiguous copy of the coefficients.
 *   table:  for a fixed sky state with the sun above the horizon, the weighted sum over
 *           configurations of emph(zero) * sum_r sun_r(gamma) zen_r(zero) is, inside each cell of
 *           (sun knots) x (union of zenith and emphasis knots), a polynomial
 *           A + B g + C z + D g z + E z^2 + F g z^2 in the local offsets g, z. A configuration whose
 *           product cannot change sign inside a cell (checked exactly: the rank sum is bilinear, so
 *           its extremes are at the cell corners, and emph is linear) folds into the cell's
 *           polynomial; one that may change sign keeps its own clamped term. Exact to rounding.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#ifdef WIDESKY_OPENMP
#include <omp.h>
#endif

#define PLANET_RADIUS 6378000.0
#define SAFETY_ALTITUDE 50.0
#define ATMOSPHERE_WIDTH 100000.0
#define DIST_TO_EDGE 1571524.413613
#define DBL_EPSILON_ 2.220446049250313e-16
/* narrowest cell of the table path [rad]; narrower ones go to the direct path */
#define TABLE_MIN_CELL 1e-9
/* below this much work (inner iterations) a parallel region costs more than it saves */
#define PAR_MIN_WORK 65536

/* ------------------------------------------------------------------------------------------ */
/* small helpers                                                                              */

typedef struct {
    int idx;
    double f;
} ip_t;

/* Reference knot lookup: clamp q to [b0, b_{n-1}], idx = k-1 for the first k >= 1 with b[k] > q,
 * factor (q - b[idx]) / (b[k] - b[idx]); at the last knot idx = n-1 and factor 0. */
static inline ip_t knot_lookup(double q, const double *b, int n)
{
    ip_t r;
    if (!(q >= b[0])) q = b[0]; /* also maps NaN to the first knot: never index out of range */
    if (q > b[n - 1]) q = b[n - 1];
    int lo = 1, hi = n;
    while (lo < hi) {
        int mid = (lo + hi) >> 1;
        if (b[mid] > q)
            hi = mid;
        else
            lo = mid + 1;
    }
    if (lo >= n) {
        r.idx = n - 1;
        r.f = 0.0;
    } else {
        r.idx = lo - 1;
        r.f = (q - b[lo - 1]) / (b[lo] - b[lo - 1]);
    }
    return r;
}

/* Piecewise-linear value, reference formula (c1 - c0) * f + c0 in double; the read of c[idx+1] is
 * guarded when the factor is zero (the reference reads past the vector there and multiplies by 0). */
static inline double pl_eval(const float *c, ip_t p)
{
    double c0 = (double)c[p.idx];
    if (p.f == 0.0) return c0;
    return ((double)c[p.idx + 1] - c0) * p.f + c0;
}

static inline double clamp_unit(double x)
{
    return x > 1.0 ? 1.0 : (x < -1.0 ? -1.0 : x);
}

typedef struct {
    double theta, gamma, shadow, zero;
} angles_t;

/* Per-sky-state geometry for an observer at (0, 0, h) (reference computeParameters). */
typedef struct {
    double d;        /* |p - C| + safety altitude [m] */
    double sz;       /* z of the shifted view point S = C + n d */
    double oz;       /* z of the corrected origin O' = C + n (d - c) */
    int corrected;   /* d > R */
    double s[3];     /* unit vector to the sun */
    double h[3];     /* shadow direction */
    int use_shadow;  /* elevation < 0: radiance uses the shadow angle */
} geom_t;

static void geom_init(geom_t *g, double obs_alt, double el, double az)
{
    const double R = PLANET_RADIUS;
    double tz = obs_alt + R; /* to_viewpoint = p - C = (0, 0, h + R) */
    double len = fabs(tz);
    double nz = tz / len;    /* normalised: exactly 1 */
    g->d = len + SAFETY_ALTITUDE;
    g->sz = -R + nz * g->d;
    g->corrected = g->d > R;
    if (g->corrected) {
        double c = sqrt(g->d * g->d - R * R) / g->d;
        g->oz = -R + nz * (g->d - c);
    } else {
        g->oz = 0.0;
    }
    g->s[0] = cos(az) * cos(el);
    g->s[1] = sin(az) * cos(el);
    g->s[2] = sin(el);
    double sig = el + 0.5 * M_PI;
    g->h[0] = cos(sig) * cos(az);
    g->h[1] = cos(sig) * sin(az);
    g->h[2] = sin(sig);
    /* elevation at the view point: pi/2 - angle(n, s) with n = (0, 0, 1) */
    double elev = 0.5 * M_PI - acos(clamp_unit(g->s[2]));
    g->use_shadow = elev < 0.0;
}

static inline angles_t compute_angles(const double *v, const geom_t *g, int need_theta, int need_shadow)
{
    angles_t a;
    double nv = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    if (nv < DBL_EPSILON_) nv = DBL_EPSILON_;
    double vx = v[0] / nv, vy = v[1] / nv, vz = v[2] / nv;
    double cx = vx, cy = vy, cz = vz;
    if (g->corrected) {
        /* look = S + v; corrected view = look - O' */
        cz = (vz + g->sz) - g->oz;
        double nc = sqrt(cx * cx + cy * cy + cz * cz);
        cx /= nc;
        cy /= nc;
        cz /= nc;
    }
    a.gamma = acos(clamp_unit(vx * g->s[0] + vy * g->s[1] + vz * g->s[2]));
    a.zero = acos(clamp_unit(cz));
    a.theta = need_theta ? acos(clamp_unit(vz)) : 0.0;
    a.shadow = need_shadow ? acos(clamp_unit(cx * g->h[0] + cy * g->h[1] + cz * g->h[2])) : 0.0;
    return a;
}

/* One model component: radiance (with emphasis, clamped) or polarisation (no emphasis). */
typedef struct {
    const float *sun;   /* [ncfg][rank][ns] */
    const float *zen;   /* [ncfg][rank][nz] */
    const float *emph;  /* [ncfg][ne] or NULL */
    const double *sb, *zb, *eb;
    int ns, nz, ne, rank;
    int clamp;
    int nch;            /* channels per configuration block in the loaded arrays */
} comp_t;

static inline double eval_config(const comp_t *m, size_t cfg, ip_t g, ip_t a, ip_t z)
{
    const float *sun = m->sun + cfg * (size_t)m->rank * m->ns;
    const float *zen = m->zen + cfg * (size_t)m->rank * m->nz;
    double res = 0.0;
    for (int r = 0; r < m->rank; ++r)
        res += pl_eval(sun + (size_t)r * m->ns, g) * pl_eval(zen + (size_t)r * m->nz, a);
    if (m->emph) {
        res *= pl_eval(m->emph + cfg * (size_t)m->ne, z);
        if (res < 0.0) res = 0.0;
    }
    return res;
}

/* Output writers (float32 or float64). */
static inline void put(void *out, size_t i, double v, int is_double)
{
    if (is_double)
        ((double *)out)[i] = v;
    else
        ((float *)out)[i] = (float)v;
}

/* ------------------------------------------------------------------------------------------ */
/* direct path                                                                                */

/* output row of direction i: rows[i] where the caller scatters into an image, else i */
#define OUT_ROW(rows, i) ((rows) ? (size_t)(rows)[i] : (size_t)(i))

/* The direct path's channel-contiguous copy of the coefficients, kept across calls (one entry, at most
 * DCACHE_MAX_BYTES): the second call in a row with the same coefficient arrays, configurations of non-zero
 * weight (in order) and channels copies every knot once into the entry, and later such calls skip the copy
 * (the same numbers read in the same order: the same bits). Managed under the GIL (py_radiance): the entry
 * holds weak references to the coefficient arrays, so a freed or replaced dataset never matches; users
 * counts the calls reading it with the GIL released, and an entry replaced while read is freed by its last
 * reader. */
#define DCACHE_MAX_BYTES ((size_t)64 << 20)
typedef struct {
    const float *sun, *zen, *emph;
    int ns, nz, ne, rank, nch, nact, nc;
    int64_t *cfg, *chi; /* [nact] configurations of non-zero weight, [nc] channels */
} dkey_t;
typedef struct {
    dkey_t k;
    PyObject *ref[3]; /* weak references to the sun, zenith and emphasis arrays (ref[2] NULL without) */
    double *buf;      /* float: sun [nact][ns][rank][nc4], zenith [nact][nz][rank][nc4], emphasis
                         [nact][ne][nc4]; from a 64-byte boundary in mem (the allocation) */
    void *mem;
    int users, filled, orphan;
} dcache_t;
static dcache_t *dc_cur = NULL; /* the entry (GIL) */
static dkey_t dc_seen;          /* the previous call's key (GIL) */

static void dkey_free(dkey_t *k)
{
    free(k->cfg);
    free(k->chi);
    k->cfg = k->chi = NULL;
}

static int dkey_make(dkey_t *k, const comp_t *m, const int64_t *cfg_base, const double *cfg_w, int ncfg,
                     const int64_t *chi, int nc)
{
    *k = (dkey_t){m->sun, m->zen, m->emph, m->ns, m->nz, m->emph ? m->ne : 0, m->rank, m->nch, 0, nc, NULL, NULL};
    k->cfg = malloc(sizeof(int64_t) * (ncfg > 0 ? ncfg : 1));
    k->chi = malloc(sizeof(int64_t) * (nc > 0 ? nc : 1));
    if (!k->cfg || !k->chi) {
        dkey_free(k);
        return -1;
    }
    for (int c = 0; c < ncfg; ++c)
        if (cfg_w[c] != 0.0) k->cfg[k->nact++] = cfg_base[c];
    if (nc > 0) memcpy(k->chi, chi, sizeof(int64_t) * nc);
    return 0;
}

static int dkey_eq(const dkey_t *a, const dkey_t *b)
{
    return a->cfg && b->cfg && a->sun == b->sun && a->zen == b->zen && a->emph == b->emph && a->ns == b->ns &&
           a->nz == b->nz && a->ne == b->ne && a->rank == b->rank && a->nch == b->nch && a->nact == b->nact &&
           a->nc == b->nc && !memcmp(a->cfg, b->cfg, sizeof(int64_t) * a->nact) &&
           !memcmp(a->chi, b->chi, sizeof(int64_t) * a->nc);
}

/* doubles of an entry's buffer (the layout of radiance_direct_vec's copy, every knot) */
static size_t dcache_doubles(const dkey_t *k)
{
    size_t nc4 = 4 * (size_t)((k->nc + 3) / 4), kr = (size_t)k->rank * nc4;
    size_t nsun = (size_t)k->nact * k->ns * kr, nzen = (size_t)k->nact * k->nz * kr;
    size_t nemph = (size_t)k->nact * k->ne * nc4;
    return (nsun + nzen + nemph + 1) / 2;
}

static void dcache_free(dcache_t *e)
{
    for (int i = 0; i < 3; ++i) Py_XDECREF(e->ref[i]);
    dkey_free(&e->k);
    free(e->mem);
    free(e);
}

/* the entry for a direct-path call (GIL held), NULL for none: the current one, or a new one for this call
 * to fill (the key seen in the previous call too), to be handed back with dcache_put */
static dcache_t *dcache_get(const comp_t *m, PyObject *const *arr, const int64_t *cfg_base, const double *cfg_w,
                            int ncfg, const int64_t *chi, int nc)
{
    dkey_t k;
    if (nc < 1 || dkey_make(&k, m, cfg_base, cfg_w, ncfg, chi, nc) < 0) return NULL;
    if (k.nact == 0) {
        dkey_free(&k);
        return NULL;
    }
    if (dc_cur && dkey_eq(&dc_cur->k, &k)) {
        int alive = 1;
        for (int i = 0; i < 3; ++i)
            alive &= (dc_cur->ref[i] ? PyWeakref_GetObject(dc_cur->ref[i]) : Py_None) == arr[i];
        if (alive) {
            dkey_free(&k);
            dc_cur->users++;
            return dc_cur;
        }
    }
    if (!dkey_eq(&dc_seen, &k) || dcache_doubles(&k) * sizeof(double) > DCACHE_MAX_BYTES) {
        dkey_free(&dc_seen);
        dc_seen = k;
        return NULL;
    }
    dcache_t *e = calloc(1, sizeof(*e));
    if (!e) {
        dkey_free(&k);
        return NULL;
    }
    e->k = k;
    e->users = 1;
    for (int i = 0; i < 3; ++i)
        if (arr[i] != Py_None && !(e->ref[i] = PyWeakref_NewRef(arr[i], NULL))) {
            PyErr_Clear();
            dcache_free(e);
            return NULL;
        }
    return e;
}

/* hands back an entry from dcache_get (GIL held): a new one, filled, replaces the current one */
static void dcache_put(dcache_t *e)
{
    if (!e) return;
    e->users--;
    if (e != dc_cur && !e->orphan) {
        if (!e->filled) {
            dcache_free(e);
            return;
        }
        if (dc_cur) {
            if (dc_cur->users)
                dc_cur->orphan = 1;
            else
                dcache_free(dc_cur);
        }
        dc_cur = e;
    }
    if (e->orphan && e->users == 0) dcache_free(e);
}

#if defined(__GNUC__) && defined(__x86_64__)
#define DIRECT_VEC 1
#include <immintrin.h>
/* AVX2/FMA direct path (dispatched at run time): four channels per vector lane group. Resolved once per
 * call (they depend only on the sky state and the channels): the configurations of non-zero weight, and
 * for each (configuration, block of four channels) the rows of sun, zenith and emphasis coefficients.
 * Per direction the three knot lookups once; then per block of four channels and per configuration the
 * rank sum in rank order, sum_r ((s1 - s0) g + s0) ((z1 - z0) a + z0), each factor the reference's
 * piecewise-linear value from the pair (c[i], c[i+1]) read with one 8-byte load per channel, times the
 * emphasis, clamped at zero, weighted and summed over the configurations in their order. A channel's
 * value does not depend on the other channels of the call (a padded block repeats the last channel). */
static double *ws_acquire(size_t n);
static void ws_release(double *p);
static void angle_range(const geom_t *geo, const double *dirs, Py_ssize_t n, double *range);
static int interval_of(double q, const double *b, int n);
typedef struct {
    int nact, nb;      /* configurations of non-zero weight; blocks of four channels */
    const double *w;   /* [nact] */
    const float **row; /* [nact][nb][3][4]: sun, zenith, emphasis rows of each channel of the block */
} direct_plan_t;

/* lo = (c[0] of the rows p[0..3]), hi = (c[1] of the same rows), from the offset o (floats) */
__attribute__((target("avx2,fma"))) static inline void direct_pairs(const float *const *p, size_t o, __m256d *lo,
                                                                    __m256d *hi)
{
    __m128i a = _mm_loadl_epi64((const __m128i_u *)(p[0] + o)), b = _mm_loadl_epi64((const __m128i_u *)(p[1] + o));
    __m128i c = _mm_loadl_epi64((const __m128i_u *)(p[2] + o)), d = _mm_loadl_epi64((const __m128i_u *)(p[3] + o));
    __m256d X = _mm256_cvtps_pd(_mm_castsi128_ps(_mm_unpacklo_epi64(a, c))); /* a0 a1 c0 c1 */
    __m256d Y = _mm256_cvtps_pd(_mm_castsi128_ps(_mm_unpacklo_epi64(b, d))); /* b0 b1 d0 d1 */
    *lo = _mm256_unpacklo_pd(X, Y);                                           /* a0 b0 c0 d0 */
    *hi = _mm256_unpackhi_pd(X, Y);
}

/* a knot lookup as (pair offset, factor, take the pair's upper value): at the last knot the pair below
 * is read and its upper value taken (factor 0), so no read goes past a row */
typedef struct {
    size_t o;
    __m256d f, last;
} direct_ip_t;

__attribute__((target("avx2,fma"))) static inline direct_ip_t direct_ip(ip_t p, int n)
{
    direct_ip_t r;
    int last = p.idx >= n - 1;
    r.o = (size_t)(last ? n - 2 : p.idx);
    r.f = _mm256_set1_pd(p.f);
    r.last = _mm256_castsi256_pd(_mm256_set1_epi64x(last ? -1 : 0));
    return r;
}

/* the reference's piecewise-linear value (c1 - c0) f + c0 of four channels */
__attribute__((target("avx2,fma"))) static inline __m256d direct_lerp(const float *const *p, size_t o,
                                                                     const direct_ip_t *q)
{
    __m256d lo, hi;
    direct_pairs(p, o + q->o, &lo, &hi);
    lo = _mm256_blendv_pd(lo, hi, q->last);
    return _mm256_fmadd_pd(_mm256_sub_pd(hi, lo), q->f, lo);
}

__attribute__((target("avx2,fma"), noinline)) static void direct_dir_avx2(const direct_plan_t *P, const comp_t *m,
                                                                         ip_t gp0, ip_t ap0, ip_t zp0, int nc,
                                                                         double *res, double sign)
{
    const int R = m->rank, ns = m->ns, nz = m->nz;
    /* direct_ip builds its vectors here (inlined into this AVX2 function) */
    direct_ip_t gp = direct_ip(gp0, ns), ap = direct_ip(ap0, nz), zp = direct_ip(zp0, m->emph ? m->ne : 2);
    const __m256d zero = _mm256_setzero_pd(), sg = _mm256_set1_pd(sign);
    for (int b = 0; b < P->nb; ++b) {
        __m256d acc = zero;
        for (int c = 0; c < P->nact; ++c) {
            const float *const *row = P->row + ((size_t)c * P->nb + b) * 12;
            __m256d s = zero;
            for (int r = 0; r < R; ++r) {
                __m256d S = direct_lerp(row, (size_t)r * ns, &gp);
                __m256d Z = direct_lerp(row + 4, (size_t)r * nz, &ap);
                s = _mm256_fmadd_pd(S, Z, s);
            }
            if (m->emph) {
                s = _mm256_mul_pd(s, direct_lerp(row + 8, 0, &zp));
                s = _mm256_max_pd(zero, s); /* s < 0 -> 0; -0 and NaN kept, as the scalar clamp */
            }
            acc = _mm256_fmadd_pd(_mm256_set1_pd(P->w[c]), s, acc);
        }
        _mm256_storeu_pd(res + 4 * (size_t)b, _mm256_mul_pd(sg, acc));
    }
    (void)nc;
}

/* The same values from the call's coefficients copied channel-contiguous (T: sun [nact][ns][rank][nc4],
 * zenith [nact][nz][rank][nc4] and emphasis [nact][ne][nc4], float as in the dataset, nc4 the channels padded
 * to four): the four (eight) channels' values of a knot are one load. Float, not double: the evaluation of a
 * call that finds the copy out of the cache (as after other work) waits on memory, and half the bytes halve
 * that; the AVX-512 kernel converts each sun vector once for up to four directions. Same operations in the
 * same order as direct_dir_avx2 (at the last knot both ends of the pair are that knot: (c - c) 0 + c = c), so
 * the two agree to the bit. */
typedef struct {
    const float *sun, *zen, *emph;
    int nc4;
} direct_t_t;

__attribute__((target("avx2,fma"))) static inline __m256d direct_lerp_t(const float *lo, const float *hi, __m256d f)
{
    __m256d l = _mm256_cvtps_pd(_mm_loadu_ps(lo)), h = _mm256_cvtps_pd(_mm_loadu_ps(hi));
    return _mm256_fmadd_pd(_mm256_sub_pd(h, l), f, l);
}

/* Directions in chunks (a window of up to 512, ordered by sun interval), configurations outer: one
 * configuration's channel-contiguous coefficients (a few hundred kilobytes) stay in cache while the chunk's
 * directions use them, and the next one's are prefetched meanwhile. Per direction and channel the same
 * operations in the same order as direct_dir_avx2 (the configurations summed in their order). */
#define DIRECT_CHUNK 128
typedef struct {
    int g, a, z;
    double fg, fa, fz;
    Py_ssize_t i; /* the direction */
} direct_look_t;

/* The part of the next configuration's coefficients that a chunk's directions read (its rows from the
 * lowest to the highest knot pair visited: sun, zenith, emphasis), fetched into the cache a slice per
 * direction while the current configuration is evaluated, so that the loads find it there even when a
 * call finds none of the copy cached (as after another program's work). Prefetches change no value. */
typedef struct {
    const char *p[3]; /* start of each region in configuration 0 */
    size_t step[3];   /* bytes from one configuration's region to the next's */
    size_t lines[3];  /* cache lines of each region */
    size_t quota[3];  /* lines per direction */
} direct_pf_t;

static void direct_pf_plan(direct_pf_t *F, const direct_t_t *T, const comp_t *m, const direct_look_t *d, int cnt)
{
    const size_t kr = (size_t)m->rank * T->nc4;
    int lo[3] = {m->ns, m->nz, m->ne}, hi[3] = {0, 0, 0};
    for (int i = 0; i < cnt; ++i) {
        int k[3] = {d[i].g, d[i].a, d[i].z};
        for (int t = 0; t < 3; ++t) {
            lo[t] = k[t] < lo[t] ? k[t] : lo[t];
            hi[t] = k[t] > hi[t] ? k[t] : hi[t];
        }
    }
    const int nk[3] = {m->ns, m->nz, m->emph ? m->ne : 0};
    const size_t row[3] = {kr * sizeof(float), kr * sizeof(float), (size_t)T->nc4 * sizeof(float)};
    const char *base[3] = {(const char *)T->sun, (const char *)T->zen, (const char *)T->emph};
    for (int t = 0; t < 3; ++t) {
        F->lines[t] = F->quota[t] = 0;
        F->p[t] = base[t];
        F->step[t] = (size_t)nk[t] * row[t];
        if (nk[t] == 0 || cnt < 1) continue;
        int h = hi[t] + 1 < nk[t] ? hi[t] + 1 : nk[t] - 1;
        F->p[t] = base[t] + (size_t)lo[t] * row[t];
        F->lines[t] = ((size_t)(h - lo[t] + 1) * row[t] + 63) / 64;
        F->quota[t] = (F->lines[t] + cnt - 1) / cnt;
    }
}

/* direction i's slice of configuration c's regions */
__attribute__((always_inline)) static inline void direct_pf(const direct_pf_t *F, int c, int i)
{
    for (int t = 0; t < 3; ++t) {
        size_t k0 = (size_t)i * F->quota[t], k1 = k0 + F->quota[t];
        if (k1 > F->lines[t]) k1 = F->lines[t];
        const char *p = F->p[t] + (size_t)c * F->step[t];
        for (size_t k = k0; k < k1; ++k) _mm_prefetch(p + 64 * k, _MM_HINT_T1);
    }
}

/* blocks b .. b + L - 1 of one configuration at one direction, added into A (L constant at each call site:
 * L independent chains of multiply-adds; each lane's operations the same for any L) */
__attribute__((target("avx2,fma"), always_inline)) static inline void direct_group_t(
    const float *S0, const float *Z0, const float *E0, int R, int nc4, int b, const int L, size_t g0, size_t g1,
    size_t a0, size_t a1, size_t z0, size_t z1, __m256d fg, __m256d fa, __m256d fz, __m256d w, double *A)
{
    const __m256d zero = _mm256_setzero_pd();
    const float *S = S0 + 4 * (size_t)b;
    const float *Z = Z0 + 4 * (size_t)b;
    __m256d s[4] = {zero, zero, zero, zero};
    for (int r = 0; r < R; ++r) {
        size_t o = (size_t)r * nc4;
        for (int l = 0; l < L; ++l)
            s[l] = _mm256_fmadd_pd(direct_lerp_t(S + g0 + o + 4 * l, S + g1 + o + 4 * l, fg),
                                   direct_lerp_t(Z + a0 + o + 4 * l, Z + a1 + o + 4 * l, fa), s[l]);
    }
    for (int l = 0; l < L; ++l) {
        if (E0) {
            const float *E = E0 + 4 * (size_t)(b + l);
            s[l] = _mm256_mul_pd(s[l], direct_lerp_t(E + z0, E + z1, fz));
            s[l] = _mm256_max_pd(zero, s[l]);
        }
        double *a = A + 4 * (size_t)(b + l);
        _mm256_storeu_pd(a, _mm256_fmadd_pd(w, s[l], _mm256_loadu_pd(a)));
    }
}

/* direct_group_t at K directions in the same sun interval (K and L constant at each call site): each sun
 * pair loaded, converted and differenced once for all K; per direction and lane the same operations in the
 * same order as direct_group_t */
__attribute__((target("avx2,fma"), always_inline)) static inline void direct_group_txk(
    const float *S0, const float *Z0, const float *E0, int R, int nc4, int b, const int K, const int L, size_t g0,
    size_t g1, const size_t *a0, const size_t *a1, const size_t *z0, const size_t *z1, const __m256d *fg,
    const __m256d *fa, const __m256d *fz, __m256d w, double *const *A)
{
    const __m256d zero = _mm256_setzero_pd();
    const float *S = S0 + 4 * (size_t)b;
    const float *Z = Z0 + 4 * (size_t)b;
    __m256d s[4][2];
    for (int k = 0; k < K; ++k)
        for (int l = 0; l < L; ++l) s[k][l] = zero;
    for (int r = 0; r < R; ++r) {
        size_t o = (size_t)r * nc4;
        for (int l = 0; l < L; ++l) {
            __m256d sl = _mm256_cvtps_pd(_mm_loadu_ps(S + g0 + o + 4 * l));
            __m256d ds = _mm256_sub_pd(_mm256_cvtps_pd(_mm_loadu_ps(S + g1 + o + 4 * l)), sl);
            for (int k = 0; k < K; ++k)
                s[k][l] = _mm256_fmadd_pd(_mm256_fmadd_pd(ds, fg[k], sl),
                                          direct_lerp_t(Z + a0[k] + o + 4 * l, Z + a1[k] + o + 4 * l, fa[k]), s[k][l]);
        }
    }
    for (int k = 0; k < K; ++k)
        for (int l = 0; l < L; ++l) {
            if (E0) {
                const float *E = E0 + 4 * (size_t)(b + l);
                s[k][l] = _mm256_mul_pd(s[k][l], direct_lerp_t(E + z0[k], E + z1[k], fz[k]));
                s[k][l] = _mm256_max_pd(zero, s[k][l]);
            }
            double *a = A[k] + 4 * (size_t)(b + l);
            _mm256_storeu_pd(a, _mm256_fmadd_pd(w, s[k][l], _mm256_loadu_pd(a)));
        }
}

__attribute__((target("avx2,fma"), noinline)) static void direct_chunk_t_avx2(const direct_plan_t *P,
                                                                             const direct_t_t *T, const comp_t *m,
                                                                             const direct_look_t *d, int cnt,
                                                                             double *acc)
{
    const int R = m->rank, ns = m->ns, nz = m->nz, ne = m->ne, nc4 = T->nc4, nb = P->nb;
    const size_t kr = (size_t)R * nc4;
    for (size_t j = 0; j < (size_t)cnt * nc4; ++j) acc[j] = 0.0;
    direct_pf_t F;
    direct_pf_plan(&F, T, m, d, cnt);
    for (int c = 0; c < P->nact; ++c) {
        const float *S0 = T->sun + (size_t)c * ns * kr;
        const float *Z0 = T->zen + (size_t)c * nz * kr;
        const float *E0 = m->emph ? T->emph + (size_t)c * ne * nc4 : NULL;
        const __m256d w = _mm256_set1_pd(P->w[c]);
        for (int i = 0; i < cnt; ++i) {
            const size_t g0 = (size_t)d[i].g * kr, g1 = d[i].g < ns - 1 ? g0 + kr : g0;
            int K = 1; /* directions from i in the same sun interval, at most four */
            while (K < 4 && i + K < cnt && d[i + K].g == d[i].g) ++K;
            if (K > 1) {
                size_t a0[4], a1[4], z0[4], z1[4];
                __m256d fg[4], fa[4], fz[4];
                double *A4[4];
                for (int k = 0; k < K; ++k) {
                    const direct_look_t *q = d + i + k;
                    a0[k] = (size_t)q->a * kr, a1[k] = q->a < nz - 1 ? a0[k] + kr : a0[k];
                    z0[k] = (size_t)q->z * nc4, z1[k] = E0 && q->z < ne - 1 ? z0[k] + nc4 : z0[k];
                    fg[k] = _mm256_set1_pd(q->fg), fa[k] = _mm256_set1_pd(q->fa), fz[k] = _mm256_set1_pd(q->fz);
                    A4[k] = acc + (size_t)(i + k) * nc4;
                    if (c + 1 < P->nact) direct_pf(&F, c + 1, i + k);
                }
#define DIRECT_GK4(KK, LL) \
    direct_group_txk(S0, Z0, E0, R, nc4, b, KK, LL, g0, g1, a0, a1, z0, z1, fg, fa, fz, w, A4)
                int b = 0;
                if (K == 2) {
                    for (; b + 2 <= nb; b += 2) DIRECT_GK4(2, 2);
                    if (b < nb) DIRECT_GK4(2, 1);
                } else if (K == 3) {
                    for (; b + 2 <= nb; b += 2) DIRECT_GK4(3, 2);
                    if (b < nb) DIRECT_GK4(3, 1);
                } else {
                    for (; b + 2 <= nb; b += 2) DIRECT_GK4(4, 2);
                    if (b < nb) DIRECT_GK4(4, 1);
                }
#undef DIRECT_GK4
                i += K - 1;
                continue;
            }
            const size_t a0 = (size_t)d[i].a * kr, a1 = d[i].a < nz - 1 ? a0 + kr : a0;
            const size_t z0 = (size_t)d[i].z * nc4, z1 = E0 && d[i].z < ne - 1 ? z0 + nc4 : z0;
            const __m256d fg = _mm256_set1_pd(d[i].fg), fa = _mm256_set1_pd(d[i].fa), fz = _mm256_set1_pd(d[i].fz);
            double *A = acc + (size_t)i * nc4;
            if (c + 1 < P->nact) direct_pf(&F, c + 1, i);
            int b = 0;
            for (; b + 4 <= nb; b += 4) direct_group_t(S0, Z0, E0, R, nc4, b, 4, g0, g1, a0, a1, z0, z1, fg, fa, fz, w, A);
            for (; b + 2 <= nb; b += 2) direct_group_t(S0, Z0, E0, R, nc4, b, 2, g0, g1, a0, a1, z0, z1, fg, fa, fz, w, A);
            if (b < nb) direct_group_t(S0, Z0, E0, R, nc4, b, 1, g0, g1, a0, a1, z0, z1, fg, fa, fz, w, A);
        }
    }
}

/* The AVX-512 form of direct_chunk_t_avx2 (dispatched at run time where the processor has AVX-512F): eight
 * channels per vector, so half the instructions per value. Per lane the same operations in the same order
 * (subtract, multiply-add for each factor, the rank sum's multiply-adds from zero in rank order, the
 * emphasis product, max(0, .), the weighted multiply-add into the accumulator), so the values are the
 * AVX2 kernel's to the bit (tests/test_sky_direct_isa.py). Channels past the last multiple of eight (a
 * block of four) take the AVX2 group functions. */
__attribute__((target("avx512f,avx2,fma"), always_inline)) static inline void direct_group_t8(
    const float *S0, const float *Z0, const float *E0, int R, int nc4, int c0, const int L, size_t g0, size_t g1,
    size_t a0, size_t a1, size_t z0, size_t z1, __m512d fg, __m512d fa, __m512d fz, __m512d w, double *A)
{
    const __m512d zero = _mm512_setzero_pd();
    const float *S = S0 + c0;
    const float *Z = Z0 + c0;
    __m512d s[8];
    for (int l = 0; l < L; ++l) s[l] = zero;
    for (int r = 0; r < R; ++r) {
        size_t o = (size_t)r * nc4;
        for (int l = 0; l < L; ++l) {
            __m512d sl = _mm512_cvtps_pd(_mm256_loadu_ps(S + g0 + o + 8 * l));
            __m512d sh = _mm512_cvtps_pd(_mm256_loadu_ps(S + g1 + o + 8 * l));
            __m512d zl = _mm512_cvtps_pd(_mm256_loadu_ps(Z + a0 + o + 8 * l));
            __m512d zh = _mm512_cvtps_pd(_mm256_loadu_ps(Z + a1 + o + 8 * l));
            s[l] = _mm512_fmadd_pd(_mm512_fmadd_pd(_mm512_sub_pd(sh, sl), fg, sl),
                                   _mm512_fmadd_pd(_mm512_sub_pd(zh, zl), fa, zl), s[l]);
        }
    }
    for (int l = 0; l < L; ++l) {
        if (E0) {
            const float *E = E0 + c0 + 8 * l;
            __m512d el = _mm512_cvtps_pd(_mm256_loadu_ps(E + z0)), eh = _mm512_cvtps_pd(_mm256_loadu_ps(E + z1));
            s[l] = _mm512_mul_pd(s[l], _mm512_fmadd_pd(_mm512_sub_pd(eh, el), fz, el));
            s[l] = _mm512_max_pd(zero, s[l]);
        }
        double *a = A + c0 + 8 * (size_t)l;
        _mm512_storeu_pd(a, _mm512_fmadd_pd(w, s[l], _mm512_loadu_pd(a)));
    }
}

/* direct_group_t8 at K directions in the same sun interval (consecutive in the sun-ordered chunk; K and L
 * constant at each call site): each sun pair loaded, and its difference formed, once for all K; per
 * direction and lane the same operations in the same order as direct_group_t8 */
__attribute__((target("avx512f,avx2,fma"), always_inline)) static inline void direct_group_t8xk(
    const float *S0, const float *Z0, const float *E0, int R, int nc4, int c0, const int K, const int L, size_t g0,
    size_t g1, const size_t *a0, const size_t *a1, const size_t *z0, const size_t *z1, const __m512d *fg,
    const __m512d *fa, const __m512d *fz, __m512d w, double *const *A)
{
    const __m512d zero = _mm512_setzero_pd();
    const float *S = S0 + c0;
    const float *Z = Z0 + c0;
    __m512d s[4][4];
    for (int k = 0; k < K; ++k)
        for (int l = 0; l < L; ++l) s[k][l] = zero;
    for (int r = 0; r < R; ++r) {
        size_t o = (size_t)r * nc4;
        for (int l = 0; l < L; ++l) {
            __m512d sl = _mm512_cvtps_pd(_mm256_loadu_ps(S + g0 + o + 8 * l));
            __m512d sh = _mm512_cvtps_pd(_mm256_loadu_ps(S + g1 + o + 8 * l));
            __m512d ds = _mm512_sub_pd(sh, sl);
            for (int k = 0; k < K; ++k) {
                __m512d zl = _mm512_cvtps_pd(_mm256_loadu_ps(Z + a0[k] + o + 8 * l));
                __m512d zh = _mm512_cvtps_pd(_mm256_loadu_ps(Z + a1[k] + o + 8 * l));
                s[k][l] = _mm512_fmadd_pd(_mm512_fmadd_pd(ds, fg[k], sl),
                                          _mm512_fmadd_pd(_mm512_sub_pd(zh, zl), fa[k], zl), s[k][l]);
            }
        }
    }
    for (int k = 0; k < K; ++k)
        for (int l = 0; l < L; ++l) {
            if (E0) {
                const float *E = E0 + c0 + 8 * l;
                __m512d el = _mm512_cvtps_pd(_mm256_loadu_ps(E + z0[k]));
                __m512d eh = _mm512_cvtps_pd(_mm256_loadu_ps(E + z1[k]));
                s[k][l] = _mm512_mul_pd(s[k][l], _mm512_fmadd_pd(_mm512_sub_pd(eh, el), fz[k], el));
                s[k][l] = _mm512_max_pd(zero, s[k][l]);
            }
            double *a = A[k] + c0 + 8 * (size_t)l;
            _mm512_storeu_pd(a, _mm512_fmadd_pd(w, s[k][l], _mm512_loadu_pd(a)));
        }
}

__attribute__((target("avx512f,avx2,fma"), noinline)) static void direct_chunk_t_avx512(const direct_plan_t *P,
                                                                                     const direct_t_t *T,
                                                                                     const comp_t *m,
                                                                                     const direct_look_t *d, int cnt,
                                                                                     double *acc)
{
    const int R = m->rank, ns = m->ns, nz = m->nz, ne = m->ne, nc4 = T->nc4, nb8 = nc4 / 8;
    const size_t kr = (size_t)R * nc4;
    for (size_t j = 0; j < (size_t)cnt * nc4; ++j) acc[j] = 0.0;
    direct_pf_t F;
    direct_pf_plan(&F, T, m, d, cnt);
    for (int c = 0; c < P->nact; ++c) {
        const float *S0 = T->sun + (size_t)c * ns * kr;
        const float *Z0 = T->zen + (size_t)c * nz * kr;
        const float *E0 = m->emph ? T->emph + (size_t)c * ne * nc4 : NULL;
        const __m512d w = _mm512_set1_pd(P->w[c]);
        const __m256d w4 = _mm256_set1_pd(P->w[c]);
        for (int i = 0; i < cnt; ++i) {
            const size_t g0 = (size_t)d[i].g * kr, g1 = d[i].g < ns - 1 ? g0 + kr : g0;
            int K = 1; /* directions from i in the same sun interval, at most four */
            while (K < 4 && i + K < cnt && d[i + K].g == d[i].g) ++K;
            if (K > 1) {
                size_t a0[4], a1[4], z0[4], z1[4];
                __m512d fg[4], fa[4], fz[4];
                double *A4[4];
                for (int k = 0; k < K; ++k) {
                    const direct_look_t *q = d + i + k;
                    a0[k] = (size_t)q->a * kr, a1[k] = q->a < nz - 1 ? a0[k] + kr : a0[k];
                    z0[k] = (size_t)q->z * nc4, z1[k] = E0 && q->z < ne - 1 ? z0[k] + nc4 : z0[k];
                    fg[k] = _mm512_set1_pd(q->fg), fa[k] = _mm512_set1_pd(q->fa), fz[k] = _mm512_set1_pd(q->fz);
                    A4[k] = acc + (size_t)(i + k) * nc4;
                    if (c + 1 < P->nact) direct_pf(&F, c + 1, i + k);
                }
#define DIRECT_GK(KK, LL) \
    direct_group_t8xk(S0, Z0, E0, R, nc4, 8 * v, KK, LL, g0, g1, a0, a1, z0, z1, fg, fa, fz, w, A4)
                int v = 0;
                if (K == 2) {
                    for (; v + 4 <= nb8; v += 4) DIRECT_GK(2, 4);
                    for (; v + 2 <= nb8; v += 2) DIRECT_GK(2, 2);
                    if (v < nb8) DIRECT_GK(2, 1);
                } else if (K == 3) {
                    for (; v + 2 <= nb8; v += 2) DIRECT_GK(3, 2);
                    if (v < nb8) DIRECT_GK(3, 1);
                } else {
                    for (; v + 2 <= nb8; v += 2) DIRECT_GK(4, 2);
                    if (v < nb8) DIRECT_GK(4, 1);
                }
#undef DIRECT_GK
                if (nc4 & 4) { /* the last block of four channels */
                    __m256d fg4[4], fa4[4], fz4[4];
                    for (int k = 0; k < K; ++k)
                        fg4[k] = _mm256_set1_pd(d[i + k].fg), fa4[k] = _mm256_set1_pd(d[i + k].fa),
                        fz4[k] = _mm256_set1_pd(d[i + k].fz);
                    const int b4 = nc4 / 4 - 1;
                    if (K == 2)
                        direct_group_txk(S0, Z0, E0, R, nc4, b4, 2, 1, g0, g1, a0, a1, z0, z1, fg4, fa4, fz4, w4, A4);
                    else if (K == 3)
                        direct_group_txk(S0, Z0, E0, R, nc4, b4, 3, 1, g0, g1, a0, a1, z0, z1, fg4, fa4, fz4, w4, A4);
                    else
                        direct_group_txk(S0, Z0, E0, R, nc4, b4, 4, 1, g0, g1, a0, a1, z0, z1, fg4, fa4, fz4, w4, A4);
                }
                i += K - 1;
                continue;
            }
            const size_t a0 = (size_t)d[i].a * kr, a1 = d[i].a < nz - 1 ? a0 + kr : a0;
            const size_t z0 = (size_t)d[i].z * nc4, z1 = E0 && d[i].z < ne - 1 ? z0 + nc4 : z0;
            const __m512d fg = _mm512_set1_pd(d[i].fg), fa = _mm512_set1_pd(d[i].fa), fz = _mm512_set1_pd(d[i].fz);
            double *A = acc + (size_t)i * nc4;
            if (c + 1 < P->nact) direct_pf(&F, c + 1, i);
            int v = 0;
            for (; v + 4 <= nb8; v += 4)
                direct_group_t8(S0, Z0, E0, R, nc4, 8 * v, 4, g0, g1, a0, a1, z0, z1, fg, fa, fz, w, A);
            switch (nb8 - v) {
            case 3: direct_group_t8(S0, Z0, E0, R, nc4, 8 * v, 3, g0, g1, a0, a1, z0, z1, fg, fa, fz, w, A); break;
            case 2: direct_group_t8(S0, Z0, E0, R, nc4, 8 * v, 2, g0, g1, a0, a1, z0, z1, fg, fa, fz, w, A); break;
            case 1: direct_group_t8(S0, Z0, E0, R, nc4, 8 * v, 1, g0, g1, a0, a1, z0, z1, fg, fa, fz, w, A); break;
            default: break;
            }
            if (nc4 & 4)
                direct_group_t(S0, Z0, E0, R, nc4, nc4 / 4 - 1, 1, g0, g1, a0, a1, z0, z1, _mm256_set1_pd(d[i].fg),
                               _mm256_set1_pd(d[i].fa), _mm256_set1_pd(d[i].fz), w4, A);
        }
    }
}

/* dst[j * stride + l] = p[l][o + j] for the four rows l, j < n (a 4 x 4 transpose per step) */
static void direct_transpose4(const float *const *p, size_t o, int n, float *dst, size_t stride)
{
    int j = 0;
    for (; j + 4 <= n; j += 4) {
        __m128 r0 = _mm_loadu_ps(p[0] + o + j), r1 = _mm_loadu_ps(p[1] + o + j);
        __m128 r2 = _mm_loadu_ps(p[2] + o + j), r3 = _mm_loadu_ps(p[3] + o + j);
        _MM_TRANSPOSE4_PS(r0, r1, r2, r3);
        _mm_storeu_ps(dst + (size_t)j * stride, r0);
        _mm_storeu_ps(dst + (size_t)(j + 1) * stride, r1);
        _mm_storeu_ps(dst + (size_t)(j + 2) * stride, r2);
        _mm_storeu_ps(dst + (size_t)(j + 3) * stride, r3);
    }
    for (; j < n; ++j)
        for (int l = 0; l < 4; ++l) dst[(size_t)j * stride + l] = p[l][o + j];
}

static int direct_vec_ok(void)
{
    static int ok = -1;
    if (ok < 0) ok = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
    return ok;
}

/* the direct path's chunk kernel: 0 not decided yet, 1 AVX2, 2 AVX-512 (direct_impl() sets it, for tests) */
static int direct_impl = 0;
static int direct_512_available(void)
{
    return direct_vec_ok() && __builtin_cpu_supports("avx512f");
}
static int direct_use_512(void)
{
    if (direct_impl == 0) direct_impl = direct_512_available() ? 2 : 1;
    return direct_impl == 2;
}

/* the configurations' coefficients at knots kn[0..1] (sun), kn[2..3] (zenith), kn[4..5] (emphasis),
 * channel-contiguous into tbuf (T->nc4 set; the layout of dcache_t's buffer) */
static void direct_copy(const direct_plan_t *P, const comp_t *m, const int *kn, direct_t_t *T, double *tbuf)
{
    const float **row = P->row;
    size_t kr = (size_t)m->rank * T->nc4;
    size_t nsun = (size_t)P->nact * m->ns * kr, nzen = (size_t)P->nact * m->nz * kr;
    float *ts = (float *)tbuf, *tz = ts + nsun, *te = tz + nzen;
    for (int c = 0; c < P->nact; ++c)
        for (int b = 0; b < P->nb; ++b) {
            const float *const *q = row + ((size_t)c * P->nb + b) * 12;
            for (int r = 0; r < m->rank; ++r) {
                direct_transpose4(q, (size_t)r * m->ns + kn[0], kn[1] - kn[0] + 1,
                                  ts + ((size_t)c * m->ns + kn[0]) * kr + (size_t)r * T->nc4 + 4 * (size_t)b, kr);
                direct_transpose4(q + 4, (size_t)r * m->nz + kn[2], kn[3] - kn[2] + 1,
                                  tz + ((size_t)c * m->nz + kn[2]) * kr + (size_t)r * T->nc4 + 4 * (size_t)b, kr);
            }
            if (m->emph)
                direct_transpose4(q + 8, kn[4], kn[5] - kn[4] + 1,
                                  te + ((size_t)c * m->ne + kn[4]) * T->nc4 + 4 * (size_t)b, T->nc4);
        }
    T->sun = ts;
    T->zen = tz;
    T->emph = te;
}

/* knot_lookup's result by a search without data-dependent branches (the interval's index from the same
 * comparisons b[k] <= q, so the same index and factor for every q, NaN and infinities included; checked
 * against knot_lookup on 15 million queries, repeated knots included): a window's lookups do not stall
 * on mispredicted branches */
static inline ip_t direct_lookup(double q, const double *b, int n)
{
    ip_t r;
    if (!(q >= b[0])) q = b[0];
    if (q > b[n - 1]) q = b[n - 1];
    const double *base = b + 1; /* first k >= 1 with b[k] > q, or n: in b[1 .. n - 1] (n >= 2) */
    int len = n - 1;
    while (len > 1) {
        int half = len >> 1;
        base = base[half] <= q ? base + half : base;
        len -= half;
    }
    int lo = (int)(base - b) + (*base <= q);
    if (lo >= n) {
        r.idx = n - 1;
        r.f = 0.0;
    } else {
        r.idx = lo - 1;
        r.f = (q - b[lo - 1]) / (b[lo] - b[lo - 1]);
    }
    return r;
}

/* The direct path's work buffers of a call (each thread's lookups, counts and accumulators), one block kept
 * across calls as ws_block is: fresh pages would cost a page fault each (as after another program's frees
 * gave the heap's top back). A concurrent caller allocates its own. */
static char *dw_block = NULL;
static size_t dw_cap = 0;
static int dw_busy = 0;
static char *dw_acquire(size_t bytes)
{
    if (__atomic_exchange_n(&dw_busy, 1, __ATOMIC_ACQUIRE)) return malloc(bytes);
    if (dw_cap < bytes) {
        free(dw_block);
        dw_block = malloc(bytes);
        dw_cap = dw_block ? bytes : 0;
    }
    if (!dw_block) __atomic_store_n(&dw_busy, 0, __ATOMIC_RELEASE);
    return dw_block;
}
static void dw_release(char *p)
{
    if (p == NULL) return;
    if (p == dw_block)
        __atomic_store_n(&dw_busy, 0, __ATOMIC_RELEASE);
    else
        free(p);
}

/* Returns 0 when done, -1 when the vector path does not apply (no AVX2/FMA, fewer than two knots in a
 * lookup, no memory): the scalar path then runs. dc: the cached copy (dcache_get; filled here when new),
 * or NULL. */
static int radiance_direct_vec(const comp_t *m, const geom_t *geo, const int64_t *cfg_base, const double *cfg_w,
                               int ncfg, const int64_t *chi, int nc, const double *dirs, Py_ssize_t n, void *out,
                               int is_double, double sign, const int64_t *rows, dcache_t *dc)
{
    if (!direct_vec_ok() || nc < 1 || m->ns < 2 || m->nz < 2 || (m->emph && m->ne < 2)) return -1;
    direct_plan_t P;
    P.nb = (nc + 3) / 4;
    P.nact = 0;
    double *w = malloc(sizeof(double) * (ncfg > 0 ? ncfg : 1));
    const float **row = malloc(sizeof(*row) * 12 * (size_t)P.nb * (ncfg > 0 ? ncfg : 1));
    if (!w || !row) {
        free(w);
        free(row);
        return -1;
    }
    const size_t rs = (size_t)m->rank * m->ns, rz = (size_t)m->rank * m->nz;
    for (int c = 0; c < ncfg; ++c) {
        if (cfg_w[c] == 0.0) continue; /* contributes nothing (the weights of a grid value's other branch) */
        w[P.nact] = cfg_w[c];
        for (int b = 0; b < P.nb; ++b)
            for (int l = 0; l < 4; ++l) {
                int k = 4 * b + l < nc ? 4 * b + l : nc - 1;
                size_t cfg = (size_t)cfg_base[c] * m->nch + (size_t)chi[k];
                const float **q = row + ((size_t)P.nact * P.nb + b) * 12;
                q[l] = m->sun + cfg * rs;
                q[4 + l] = m->zen + cfg * rz;
                q[8 + l] = m->emph ? m->emph + cfg * (size_t)m->ne : m->sun + cfg * rs; /* unread without emph */
            }
        P.nact++;
    }
    P.w = w;
    P.row = row;
    const int shadow = m->emph != NULL && geo->use_shadow;
    /* Enough directions (each visits two knots of each table): copy the configurations' coefficients
     * channel-contiguous once (read row by row, sequentially) rather than one cache line per channel and
     * rank at every direction. */
    direct_t_t T;
    double *tbuf = NULL;
    T.nc4 = 4 * P.nb;
    /* only the knots in the range of the call's angles are copied (kn: first and last knot of the sun,
     * zenith and emphasis tables); a direction whose knots fall outside (none should) takes the path that
     * reads the dataset's rows, which gives the same values */
    int kn[6] = {0, m->ns - 1, 0, m->nz - 1, 0, m->emph ? m->ne - 1 : 0};
    int cached = 0; /* T is the cache entry's copy of every knot */
    if (dc && P.nact == dc->k.nact && T.nc4 == 4 * ((dc->k.nc + 3) / 4)) {
        /* from a 64-byte boundary, as the uncached copy below */
        if (!dc->filled && (dc->mem = malloc(sizeof(double) * dcache_doubles(&dc->k) + 64)) != NULL) {
            dc->buf = (double *)(((uintptr_t)dc->mem + 63) & ~(uintptr_t)63);
            direct_copy(&P, m, kn, &T, dc->buf);
            dc->filled = 1;
        }
        if (dc->filled) {
            size_t kr = (size_t)m->rank * T.nc4;
            T.sun = (const float *)dc->buf;
            T.zen = T.sun + (size_t)P.nact * m->ns * kr;
            T.emph = (float *)T.zen + (size_t)P.nact * m->nz * kr;
            cached = 1;
        }
    }
    if (!cached) {
        double rg[4];
        angle_range(geo, dirs, n, rg);
        if (rg[0] == rg[0] && rg[2] == rg[2]) {
            kn[0] = interval_of(rg[0], m->sb, m->ns), kn[1] = interval_of(rg[1], m->sb, m->ns) + 1;
            if (!shadow) kn[2] = interval_of(rg[2], m->zb, m->nz), kn[3] = interval_of(rg[3], m->zb, m->nz) + 1;
            if (m->emph) kn[4] = interval_of(rg[2], m->eb, m->ne), kn[5] = interval_of(rg[3], m->eb, m->ne) + 1;
        }
    }
    if (!cached && P.nact > 0 && 6 * n >= m->ns + m->nz) {
        size_t kr = (size_t)m->rank * T.nc4;
        size_t nsun = (size_t)P.nact * m->ns * kr, nzen = (size_t)P.nact * m->nz * kr;
        size_t nemph = m->emph ? (size_t)P.nact * m->ne * T.nc4 : 0;
        /* reused block (no fresh pages), the copy from a 64-byte boundary (a vector load then never spans two
         * cache lines where the channels are a multiple of eight) */
        tbuf = ws_acquire((nsun + nzen + nemph + 1) / 2 + 8);
        if (tbuf) direct_copy(&P, m, kn, &T, (double *)(((uintptr_t)tbuf + 63) & ~(uintptr_t)63));
    }
    Py_ssize_t i;
    if (tbuf || cached) {
        /* windows of directions (one per thread's share, 128 to 512; each evaluated as one chunk, so a call
         * of a few hundred directions on one thread reads each configuration's coefficients once), each
         * ordered by its sun interval (a counting sort) so that consecutive directions reuse the same sun
         * coefficients; the order does not change any value */
        const int par = n * (Py_ssize_t)nc * ncfg >= PAR_MIN_WORK;
        int nthr = 1;
#ifdef WIDESKY_OPENMP
        if (par) nthr = omp_get_max_threads();
#endif
        Py_ssize_t W = ((n + nthr - 1) / nthr + DIRECT_CHUNK - 1) / DIRECT_CHUNK * DIRECT_CHUNK;
        if (W > 4 * DIRECT_CHUNK) W = 4 * DIRECT_CHUNK;
        Py_ssize_t nwin = (n + W - 1) / W;
        const int use512 = direct_use_512();
        /* the kept copy's first configuration (sun and zenith rows) is fetched into the cache while the
         * angles are computed (the kernel fetches each next one itself) */
        const char *pf0 = cached ? (const char *)T.sun : NULL, *pf1 = cached ? (const char *)T.zen : NULL;
        const size_t pfl0 = (size_t)m->ns * m->rank * T.nc4 * sizeof(float) / 64;
        const size_t pfl1 = (size_t)m->nz * m->rank * T.nc4 * sizeof(float) / 64;
        /* per thread: lookups [2 W], accumulators [W][nc4], counts [ns + 1], each from a 64-byte boundary */
        const size_t b_look = (sizeof(direct_look_t) * 2 * W + 63) & ~(size_t)63;
        const size_t b_acc = (sizeof(double) * W * T.nc4 + 63) & ~(size_t)63;
        const size_t b_thr = b_look + b_acc + ((sizeof(int) * (m->ns + 1) + 63) & ~(size_t)63);
        char *wbuf = dw_acquire(b_thr * nthr + 64);
        char *wal = wbuf ? (char *)(((uintptr_t)wbuf + 63) & ~(uintptr_t)63) : NULL;
#pragma omp parallel if (par)
        {
            int tid = 0;
#ifdef WIDESKY_OPENMP
            tid = omp_get_thread_num();
#endif
            char *wt = wal && tid < nthr ? wal + b_thr * tid : NULL;
            direct_look_t *look = wt ? (direct_look_t *)wt : NULL;
            double *acc = wt ? (double *)(wt + b_look) : NULL;
            int *cnts = wt ? (int *)(wt + b_look + b_acc) : NULL;
            double res[4 * P.nb];
#pragma omp for schedule(static)
            for (i = 0; i < nwin; ++i) {
                Py_ssize_t i0 = i * W, cnt = n - i0 < W ? n - i0 : W, kept = 0;
                int mem = look && cnts && acc;
                const size_t q0 = pf0 ? (pfl0 + cnt - 1) / cnt : 0, q1 = pf1 ? (pfl1 + cnt - 1) / cnt : 0;
                /* the angles of the window first, then their lookups: the arccos calls do not wait on the
                 * lookups' branches, so their table reads (cold after other work) overlap */
                for (Py_ssize_t j = 0; mem && j < cnt; ++j) {
                    for (size_t k = j * q0; k < (j + 1) * q0 && k < pfl0; ++k) _mm_prefetch(pf0 + 64 * k, _MM_HINT_T1);
                    for (size_t k = j * q1; k < (j + 1) * q1 && k < pfl1; ++k) _mm_prefetch(pf1 + 64 * k, _MM_HINT_T1);
                    angles_t a = compute_angles(dirs + 3 * (i0 + j), geo, 0, shadow);
                    look[W + j].fg = a.gamma, look[W + j].fa = shadow ? a.shadow : a.zero, look[W + j].fz = a.zero;
                }
                for (Py_ssize_t j = 0; j < cnt; ++j) {
                    double ag, aa, az;
                    if (mem) {
                        ag = look[W + j].fg, aa = look[W + j].fa, az = look[W + j].fz;
                    } else {
                        angles_t a = compute_angles(dirs + 3 * (i0 + j), geo, 0, shadow);
                        ag = a.gamma, aa = shadow ? a.shadow : a.zero, az = a.zero;
                    }
                    ip_t gp = direct_lookup(ag, m->sb, m->ns);
                    ip_t ap = direct_lookup(aa, m->zb, m->nz);
                    ip_t zp = {0, 0.0};
                    if (m->emph) zp = direct_lookup(az, m->eb, m->ne);
                    int outside = gp.idx < kn[0] || gp.idx + (gp.idx < m->ns - 1) > kn[1] || ap.idx < kn[2] ||
                                  ap.idx + (ap.idx < m->nz - 1) > kn[3] ||
                                  (m->emph && (zp.idx < kn[4] || zp.idx + (zp.idx < m->ne - 1) > kn[5]));
                    if (outside || !mem) { /* one direction at a time */
                        direct_dir_avx2(&P, m, gp, ap, zp, nc, res, sign);
                        size_t o = OUT_ROW(rows, i0 + j) * nc;
                        for (int k = 0; k < nc; ++k) put(out, o + k, res[k], is_double);
                    } else {
                        look[kept++] = (direct_look_t){gp.idx, ap.idx, zp.idx, gp.f, ap.f, zp.f, i0 + j};
                    }
                }
                if (!mem) continue;
                direct_look_t *sorted = look + W;
                memset(cnts, 0, sizeof(int) * (m->ns + 1));
                for (Py_ssize_t j = 0; j < kept; ++j) cnts[look[j].g + 1]++;
                for (int g = 0; g < m->ns; ++g) cnts[g + 1] += cnts[g];
                for (Py_ssize_t j = 0; j < kept; ++j) sorted[cnts[look[j].g]++] = look[j];
                for (Py_ssize_t j0 = 0; j0 < kept; j0 += W) {
                    int cc = (int)(kept - j0 < W ? kept - j0 : W);
                    if (use512)
                        direct_chunk_t_avx512(&P, &T, m, sorted + j0, cc, acc);
                    else
                        direct_chunk_t_avx2(&P, &T, m, sorted + j0, cc, acc);
                    for (int j = 0; j < cc; ++j) {
                        size_t o = OUT_ROW(rows, sorted[j0 + j].i) * nc;
                        const double *A = acc + (size_t)j * T.nc4;
                        for (int k = 0; k < nc; ++k) put(out, o + k, sign * A[k], is_double);
                    }
                }
            }
        }
        dw_release(wbuf);
    } else {
#pragma omp parallel if (n * (Py_ssize_t)nc * ncfg >= PAR_MIN_WORK)
        {
            double res[4 * P.nb];
#pragma omp for schedule(static)
            for (i = 0; i < n; ++i) {
                angles_t a = compute_angles(dirs + 3 * i, geo, 0, shadow);
                ip_t gp = knot_lookup(a.gamma, m->sb, m->ns);
                ip_t ap = knot_lookup(shadow ? a.shadow : a.zero, m->zb, m->nz);
                ip_t zp = {0, 0.0};
                if (m->emph) zp = knot_lookup(a.zero, m->eb, m->ne);
                direct_dir_avx2(&P, m, gp, ap, zp, nc, res, sign);
                size_t o = OUT_ROW(rows, i) * nc;
                if (is_double)
                    memcpy((double *)out + o, res, sizeof(double) * nc);
                else
                    for (int k = 0; k < nc; ++k) ((float *)out)[o + k] = (float)res[k];
            }
        }
    }
    ws_release(tbuf);
    free(w);
    free(row);
    return 0;
}
#endif

static void radiance_direct(const comp_t *m, const geom_t *geo, const int64_t *cfg_base,
                            const double *cfg_w, int ncfg, const int64_t *chi, int nc,
                            const double *dirs, Py_ssize_t n, void *out, int is_double, double sign,
                            const int64_t *rows, dcache_t *dc)
{
#ifdef DIRECT_VEC
    if (radiance_direct_vec(m, geo, cfg_base, cfg_w, ncfg, chi, nc, dirs, n, out, is_double, sign, rows, dc) == 0)
        return;
#else
    (void)dc;
#endif
    Py_ssize_t i;
#pragma omp parallel for schedule(static) if (n * (Py_ssize_t)nc * ncfg >= PAR_MIN_WORK)
    for (i = 0; i < n; ++i) {
        angles_t a = compute_angles(dirs + 3 * i, geo, 0, m->emph != NULL && geo->use_shadow);
        ip_t gp = knot_lookup(a.gamma, m->sb, m->ns);
        double alpha = (m->emph != NULL && geo->use_shadow) ? a.shadow : a.zero;
        ip_t ap = knot_lookup(alpha, m->zb, m->nz);
        ip_t zp = {0, 0.0};
        if (m->emph) zp = knot_lookup(a.zero, m->eb, m->ne);
        for (int k = 0; k < nc; ++k) {
            double acc = 0.0;
            for (int c = 0; c < ncfg; ++c) {
                size_t cfg = (size_t)cfg_base[c] * m->nch + (size_t)chi[k];
                acc += cfg_w[c] * eval_config(m, cfg, gp, ap, zp);
            }
            put(out, OUT_ROW(rows, i) * nc + k, sign * acc, is_double);
        }
    }
}

/* ------------------------------------------------------------------------------------------ */
/* table path                                                                                 */

typedef struct {
    int ns, nu;
    const double *sb;
    double *u;       /* merged zenith/emphasis knots [nu] */
    double *tab;     /* [(ns-1)*(nu-1)][6][nc] */
    int *mix_start;  /* [ncell + 1] */
    int *mix_ch;     /* [nmix] */
    Py_ssize_t nmix;
    double *mix_coef;/* [nmix][6] */
    int nc;
    int ilo, ihi, jlo, jhi; /* the sun rows and merged-knot columns of cells built (inclusive); the others
                             * are not (no direction of the call falls in them) */
} table_t;

/* The table (megabytes) is reused across calls: fresh pages would cost a page fault and a kernel
 * zeroing each, which is as much as the evaluation itself. One cached block; a concurrent caller
 * (another Python thread, the GIL being released) simply allocates its own. */
static double *ws_block = NULL;
static size_t ws_cap = 0;
static int ws_busy = 0;

static double *ws_acquire(size_t n)
{
    if (__atomic_exchange_n(&ws_busy, 1, __ATOMIC_ACQUIRE)) return malloc(n * sizeof(double));
    if (ws_cap < n) {
        free(ws_block);
        ws_block = malloc(n * sizeof(double));
        ws_cap = ws_block ? n : 0;
    }
    if (!ws_block) __atomic_store_n(&ws_busy, 0, __ATOMIC_RELEASE);
    return ws_block;
}

static void ws_release(double *p)
{
    if (p == NULL) return;
    if (p == ws_block)
        __atomic_store_n(&ws_busy, 0, __ATOMIC_RELEASE);
    else
        free(p);
}

static void table_free(table_t *t)
{
    free(t->u);
    ws_release(t->tab);
    free(t->mix_start);
    free(t->mix_ch);
    free(t->mix_coef);
    memset(t, 0, sizeof(*t));
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

typedef struct {
    int n, cap;
    int *cell, *ch;
    double *coef;
} mixlist_t;

static int mix_push(mixlist_t *l, int cell, int ch, const double *c6)
{
    if (l->n == l->cap) {
        int cap = l->cap ? 2 * l->cap : 64;
        int *nc_ = realloc(l->cell, sizeof(int) * cap);
        if (!nc_) return -1;
        l->cell = nc_;
        int *nh = realloc(l->ch, sizeof(int) * cap);
        if (!nh) return -1;
        l->ch = nh;
        double *nd = realloc(l->coef, sizeof(double) * 6 * cap);
        if (!nd) return -1;
        l->coef = nd;
        l->cap = cap;
    }
    l->cell[l->n] = cell;
    l->ch[l->n] = ch;
    memcpy(l->coef + 6 * (size_t)l->n, c6, 6 * sizeof(double));
    l->n++;
    return 0;
}

/* Hot functions get an AVX2/FMA clone next to the portable one where the toolchain supports
 * function multi-versioning (resolved once at load time). */
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__)
#define HOT __attribute__((target_clones("arch=x86-64-v3", "default")))
#else
#define HOT
#endif

/* Accelerated cell lookup on ascending knots: a uniform bucket grid gives a starting interval, a short
 * forward scan finishes. Returns the interval i in [0, n-2] containing the clamped q (the last interval
 * for q at the last knot), as the reference lookup would select, and the local offset q - b[i]. */
typedef struct {
    const double *b;
    int n, nbk;
    double b0, inv;
    int *start;
} accel_t;

static int accel_init(accel_t *a, const double *b, int n)
{
    a->b = b;
    a->n = n;
    a->b0 = b[0];
    double span = b[n - 1] - b[0];
    /* buckets at most 1/8 of the narrowest interval wide (at most 2^16 of them), so a bucket rarely holds a
     * knot and the scans below rarely step: branches the processor predicts */
    double dmin = span;
    for (int i = 0; i + 1 < n; ++i)
        if (b[i + 1] - b[i] > 0 && b[i + 1] - b[i] < dmin) dmin = b[i + 1] - b[i];
    double want = dmin > 0 ? 8.0 * span / dmin : 0.0;
    a->nbk = want > 65536.0 ? 65536 : (want > 8.0 * n ? (int)want : 8 * n);
    a->inv = span > 0 ? a->nbk / span : 0.0;
    a->start = malloc(sizeof(int) * (a->nbk + 1));
    if (!a->start) return -1;
    int i = 0;
    for (int k = 0; k <= a->nbk; ++k) {
        double q = b[0] + k / a->inv;
        while (i + 1 < n - 1 && b[i + 1] <= q) ++i;
        /* rounding in q may overshoot: step back while the interval starts above the bucket */
        while (i > 0 && b[i] > b[0] + (double)k / a->inv) --i;
        a->start[k] = i;
    }
    return 0;
}

static inline int accel_cell(const accel_t *a, double q, double *local)
{
    const double *b = a->b;
    const int n = a->n;
    if (!(q >= b[0])) q = b[0];
    if (q > b[n - 1]) q = b[n - 1];
    int k = (int)((q - a->b0) * a->inv);
    if (k > a->nbk) k = a->nbk;
    if (k < 0) k = 0;
    int i = a->start[k];
    while (i > 0 && b[i] > q) --i;
    while (i + 1 < n - 1 && b[i + 1] <= q) ++i;
    *local = q - b[i];
    return i;
}

/* accel_cell, trying the interval of the previous direction first (in an image's order it is mostly the
 * same): the same interval and offset as accel_cell. */
static inline int accel_cell_hint(const accel_t *a, double q, double *local, int hint)
{
    const double *b = a->b;
    const int n = a->n;
    if (!(q >= b[0])) q = b[0];
    if (q > b[n - 1]) q = b[n - 1];
    if (b[hint] <= q && (q < b[hint + 1] || hint == n - 2)) {
        *local = q - b[hint];
        return hint;
    }
    return accel_cell(a, q, local);
}

typedef struct {
    const comp_t *m;
    const int64_t *cfg_base;
    const double *cfg_w;
    int ncfg, nc, nu, nup, ncell_u;
    const int64_t *chi;
    const double *u;
    const ip_t *zl, *el; /* the merged knots' lookups in the zenith and emphasis knots */
    const double *ix;    /* 1 / (u[j + 1] - u[j]) */
    int ja, jb;          /* the knot columns [ja, jb) formed: multiples of 4 around the cells built */
    table_t *t;
    double sign; /* the output's sign, carried by the table (exact: a negation) */
} build_ctx_t;

/* four doubles (GCC/clang vector extension: one AVX register in the x86-64-v3 clone, two SSE2 ones in the
 * portable build); v4du is the unaligned variant for loads and stores from double arrays */
typedef double v4d __attribute__((vector_size(32)));
typedef double v4du __attribute__((vector_size(32), aligned(8)));
#define v4_load(p) (*(const v4du *)(p))
#define v4_store(p, v) (*(v4du *)(p) = (v))
#define v4_set1(x) ((v4d){(x), (x), (x), (x)})

/* sum_r sun_r(knot i) zen_r(merged knot j) for every configuration of channel k, j in [0, nup) (rows of
 * nup values; the rank sum in rank order, as the direct path forms it; four vectors at a time, whose chains
 * are independent). zq: channel k's zenith factors at the merged knots [c][r][nup]; sv: scratch [R]. */
static inline void knot_sums(const build_ctx_t *X, int k, int i, const double *restrict zq, double *restrict sv,
                             double *restrict dst)
{
    const comp_t *m = X->m;
    const int R = m->rank, ns = m->ns, nup = X->nup;
    for (int c = 0; c < X->ncfg; ++c) {
        const size_t cfg = (size_t)X->cfg_base[c] * m->nch + (size_t)X->chi[k];
        const float *sun = m->sun + cfg * (size_t)R * ns + i; /* knot i of rank 0; rank r at r * ns */
        for (int r = 0; r < R; ++r) sv[r] = (double)sun[(size_t)r * ns];
        const double *z = zq + (size_t)c * R * nup;
        double *d = dst + (size_t)c * nup;
        const int jb = X->jb;
        int j = X->ja;
        for (; j + 16 <= jb; j += 16) {
            v4d a0 = v4_set1(0.0), a1 = a0, a2 = a0, a3 = a0;
            for (int r = 0; r < R; ++r) {
                const v4d s = v4_set1(sv[r]);
                const double *zr = z + (size_t)r * nup + j;
                a0 += s * v4_load(zr);
                a1 += s * v4_load(zr + 4);
                a2 += s * v4_load(zr + 8);
                a3 += s * v4_load(zr + 12);
            }
            v4_store(d + j, a0);
            v4_store(d + j + 4, a1);
            v4_store(d + j + 8, a2);
            v4_store(d + j + 12, a3);
        }
        for (; j < jb; j += 4) {
            v4d a0 = v4_set1(0.0);
            for (int r = 0; r < R; ++r) a0 += v4_set1(sv[r]) * v4_load(z + (size_t)r * nup + j);
            v4_store(d + j, a0);
        }
    }
}

/* Channel k's table, row by row of sun cells: the rank sums at sun knots i and i+1 (ra, rb; each knot's
 * once), then 8 corner-product sums per cell acc[p][j], p = (e0|e1) x (S00|S01|S10|S11), over the
 * configurations that cannot change sign inside the cell (a whole row at once where the configuration's sums
 * and emphasis keep one sign over the row, four cells per vector, configurations innermost); the others go
 * to the mixed list (clamped terms) or are dropped (<= 0). Scratch: ra, rb [ncfg][nup], acc [8][nup],
 * unsafe [ncfg]. */
HOT static int build_channel(const build_ctx_t *X, int k, mixlist_t *mix, double *restrict ra, double *restrict rb,
                             double *restrict acc, int *restrict unsafe, double *restrict zq, double *restrict eq,
                             double *restrict sv)
{
    const comp_t *m = X->m;
    const int nu = X->nu, nup = X->nup, ncfg = X->ncfg, R = m->rank, ncell_u = X->ncell_u;
    const double *u = X->u, *ixs = X->ix;
    const int ilo = X->t->ilo, ihi = X->t->ihi, jlo = X->t->jlo, jhi = X->t->jhi, ja = X->ja, jb = X->jb;
    const int jend = jb < nu ? jb : nu;
    /* every zenith factor and the emphasis of channel k at the merged knots [ja, jb) (rows of nup, zero past
     * nu): zq[(c * R + r) * nup + j], eq[c * nup + j] */
    for (int c = 0; c < ncfg; ++c) {
        size_t cfg = (size_t)X->cfg_base[c] * m->nch + (size_t)X->chi[k];
        const float *zen = m->zen + cfg * (size_t)R * m->nz;
        for (int r = 0; r < R; ++r) {
            double *zr = zq + ((size_t)c * R + r) * nup;
            for (int j = ja; j < jend; ++j) zr[j] = pl_eval(zen + (size_t)r * m->nz, X->zl[j]);
            for (int j = jend; j < jb; ++j) zr[j] = 0.0;
        }
        double *er = eq + (size_t)c * nup;
        for (int j = ja; j < jend; ++j) er[j] = m->emph ? pl_eval(m->emph + cfg * (size_t)m->ne, X->el[j]) : 1.0;
        for (int j = jend; j < jb; ++j) er[j] = 0.0;
    }
    knot_sums(X, k, ilo, zq, sv, ra);
    for (int i = ilo; i <= ihi; ++i) {
        knot_sums(X, k, i + 1, zq, sv, rb);
        const double dg = m->sb[i + 1] - m->sb[i];
        int nunsafe = 0;
        for (int c = 0; c < ncfg; ++c) {
            if (!m->clamp) continue;
            const double *restrict a = ra + (size_t)c * nup, *restrict b = rb + (size_t)c * nup;
            const double *restrict er = eq + (size_t)c * nup;
            int sneg = 0, spos = 0, eneg = 0, epos = 0;
            for (int j = jlo; j <= jhi + 1; ++j) {
                sneg |= (a[j] < 0) | (b[j] < 0);
                spos |= (a[j] > 0) | (b[j] > 0);
                eneg |= er[j] < 0;
                epos |= er[j] > 0;
            }
            if (!((!sneg && !eneg) || (!spos && !epos))) unsafe[nunsafe++] = c;
        }
        /* the row-safe configurations, four cells at a time */
        for (int j = ja; j <= jhi; j += 4) {
            v4d x00 = v4_set1(0.0), x01 = x00, x10 = x00, x11 = x00, y00 = x00, y01 = x00, y10 = x00, y11 = x00;
            for (int c = 0, nx = 0; c < ncfg; ++c) {
                if (nx < nunsafe && unsafe[nx] == c) {
                    ++nx;
                    continue;
                }
                const v4d w = v4_set1(X->cfg_w[c]);
                const double *er = eq + (size_t)c * nup + j;
                const double *a = ra + (size_t)c * nup + j, *b = rb + (size_t)c * nup + j;
                const v4d e0 = w * v4_load(er), e1 = w * v4_load(er + 1);
                const v4d S00 = v4_load(a), S01 = v4_load(a + 1), S10 = v4_load(b), S11 = v4_load(b + 1);
                x00 += e0 * S00;
                x01 += e0 * S01;
                x10 += e0 * S10;
                x11 += e0 * S11;
                y00 += e1 * S00;
                y01 += e1 * S01;
                y10 += e1 * S10;
                y11 += e1 * S11;
            }
            v4_store(acc + j, x00);
            v4_store(acc + nup + j, x01);
            v4_store(acc + 2 * (size_t)nup + j, x10);
            v4_store(acc + 3 * (size_t)nup + j, x11);
            v4_store(acc + 4 * (size_t)nup + j, y00);
            v4_store(acc + 5 * (size_t)nup + j, y01);
            v4_store(acc + 6 * (size_t)nup + j, y10);
            v4_store(acc + 7 * (size_t)nup + j, y11);
        }
        /* configurations that change sign somewhere in the row: cell by cell */
        for (int x = 0; x < nunsafe; ++x) {
            const int c = unsafe[x];
            const double w = X->cfg_w[c];
            const double *er = eq + (size_t)c * nup;
            const double *a = ra + (size_t)c * nup, *b = rb + (size_t)c * nup;
            for (int j = jlo; j <= jhi; ++j) {
                const double S00 = a[j], S01 = a[j + 1], S10 = b[j], S11 = b[j + 1];
                const double e0 = er[j], e1v = er[j + 1];
                const double l0 = S00 < S01 ? S00 : S01, l1 = S10 < S11 ? S10 : S11;
                const double h0 = S00 > S01 ? S00 : S01, h1 = S10 > S11 ? S10 : S11;
                const double smin = l0 < l1 ? l0 : l1, smax = h0 > h1 ? h0 : h1;
                const double emin = e0 < e1v ? e0 : e1v, emax = e0 > e1v ? e0 : e1v;
                if ((smin >= 0 && emin >= 0) || (smax <= 0 && emax <= 0)) {
                    const double we0 = w * e0, we1 = w * e1v;
                    acc[j] += we0 * S00;
                    acc[nup + j] += we0 * S01;
                    acc[2 * (size_t)nup + j] += we0 * S10;
                    acc[3 * (size_t)nup + j] += we0 * S11;
                    acc[4 * (size_t)nup + j] += we1 * S00;
                    acc[5 * (size_t)nup + j] += we1 * S01;
                    acc[6 * (size_t)nup + j] += we1 * S10;
                    acc[7 * (size_t)nup + j] += we1 * S11;
                } else if (!((smin >= 0 && emax <= 0) || (smax <= 0 && emin >= 0))) {
                    const double dz = u[j + 1] - u[j];
                    const double P10 = (S10 - S00) / dg, P01 = (S01 - S00) / dz;
                    const double P11 = (S11 - S10 - S01 + S00) / (dg * dz);
                    const double E1 = (e1v - e0) / dz;
                    double c6[6] = {w * e0 * S00, w * e0 * P10, w * (e0 * P01 + E1 * S00),
                                    w * (e0 * P11 + E1 * P10), w * E1 * P01, w * E1 * P11};
                    if (mix_push(mix, i * ncell_u + j, k, c6)) return -1;
                }
            }
        }
        /* polynomial coefficients from the corner-product sums (x: e0 S, y: e1 S):
         * e(z) = e0 + (e1 - e0) z/dz, S = S00 + (S10-S00) g/dg + (S01-S00) z/dz + (S11-S10-S01+S00) g z/(dg dz) */
        const double ig = 1.0 / dg, sg = X->sign;
        const int nc = X->nc;
        for (int j = jlo; j <= jhi; ++j) {
            const double ix = ixs[j];
            const double x00 = acc[j], x01 = acc[nup + j], x10 = acc[2 * (size_t)nup + j];
            const double x11 = acc[3 * (size_t)nup + j], y00 = acc[4 * (size_t)nup + j];
            const double y01 = acc[5 * (size_t)nup + j], y10 = acc[6 * (size_t)nup + j];
            const double y11 = acc[7 * (size_t)nup + j];
            double *T = X->t->tab + ((size_t)(i * ncell_u + j)) * 6 * nc + k;
            T[0] = sg * x00;
            T[nc] = sg * ((x10 - x00) * ig);
            T[2 * nc] = sg * (((x01 - x00) + (y00 - x00)) * ix);
            T[3 * nc] = sg * (((x11 - x10 - x01 + x00) + (y10 - x10) - (y00 - x00)) * ig * ix);
            T[4 * nc] = sg * (((y01 - x01) - (y00 - x00)) * ix * ix);
            T[5 * nc] = sg * (((y11 - x11) - (y10 - x10) - (y01 - x01) + (y00 - x00)) * ig * ix * ix);
        }
        double *tmp = ra;
        ra = rb;
        rb = tmp;
    }
    return 0;
}

/* Build the per-cell polynomial table for a fixed sky state (sun above the horizon), its values times
 * sign (+1 or -1). Returns 0 on success, -1 on allocation failure, 1 when a cell is too narrow (use the
 * direct path). */
static void angle_range(const geom_t *geo, const double *dirs, Py_ssize_t n, double *range);
static int interval_of(double q, const double *b, int n);
static int table_pays(const comp_t *m, const geom_t *geo, const double *dirs, Py_ssize_t n, int ncfg, int nc);

static int table_build_signed(table_t *t, const comp_t *m, const int64_t *cfg_base, const double *cfg_w,
                              int ncfg, const int64_t *chi, int nc, double sign, const geom_t *geo,
                              const double *dirs, Py_ssize_t n)
{
    memset(t, 0, sizeof(*t));
    const int ns = m->ns, R = m->rank;
    t->ns = ns;
    t->sb = m->sb;
    t->nc = nc;
    /* merged knots */
    int nmax = m->nz + (m->emph ? m->ne : 0);
    t->u = malloc(sizeof(double) * nmax);
    if (!t->u) return -1;
    memcpy(t->u, m->zb, sizeof(double) * m->nz);
    if (m->emph) memcpy(t->u + m->nz, m->eb, sizeof(double) * m->ne);
    qsort(t->u, nmax, sizeof(double), cmp_double);
    int nu = 0;
    for (int j = 0; j < nmax; ++j)
        if (nu == 0 || t->u[j] > t->u[nu - 1]) t->u[nu++] = t->u[j];
    t->nu = nu;
    const int ncell_u = nu - 1, ncell = (ns - 1) * ncell_u;
    /* rows padded to whole vectors, with room for the (j + 1) loads of the last vector */
    const int nup = (nu + 4 + 3) & ~3;
    /* only the cells the directions can fall in (dirs given): their angles' range, one cell of margin on
     * each side (the range's arccos and the evaluation's may differ by an ulp at a knot) */
    t->ilo = 0, t->ihi = ns - 2, t->jlo = 0, t->jhi = ncell_u - 1;
    if (dirs && n > 0) {
        double rg[4];
        angle_range(geo, dirs, n, rg);
        if (isfinite(rg[0]) && isfinite(rg[1]) && isfinite(rg[2]) && isfinite(rg[3])) {
            int a = interval_of(rg[0], m->sb, ns) - 1, b = interval_of(rg[1], m->sb, ns) + 1;
            t->ilo = a > 0 ? a : 0, t->ihi = b < ns - 2 ? b : ns - 2;
            a = interval_of(rg[2], t->u, nu) - 1, b = interval_of(rg[3], t->u, nu) + 1;
            t->jlo = a > 0 ? a : 0, t->jhi = b < ncell_u - 1 ? b : ncell_u - 1;
        }
    }
    const int ja = t->jlo & ~3, jb0 = (t->jhi & ~3) + 8, jb = jb0 < nup ? jb0 : nup;
    /* zenith and emphasis knots closer than TABLE_MIN_CELL make a cell whose polynomial coefficients grow
     * as 1/width^2 (they may overflow): leave such a sky state to the direct path, which is exact */
    for (int j = 0; j + 1 < nu; ++j)
        if (t->u[j + 1] - t->u[j] < TABLE_MIN_CELL) {
            free(t->u);
            t->u = NULL;
            return 1;
        }

    ip_t *zl = malloc(sizeof(ip_t) * nu), *el = malloc(sizeof(ip_t) * nu);
    double *ix = malloc(sizeof(double) * nu);
    t->tab = ws_acquire((size_t)ncell * 6 * nc);
    t->mix_start = calloc((size_t)ncell + 1, sizeof(int));
    mixlist_t *lists = calloc((size_t)(nc > 0 ? nc : 1), sizeof(mixlist_t));
    int fail = !zl || !el || !ix || !t->tab || !t->mix_start || !lists;
    if (!fail) {
        for (int j = 0; j < nu; ++j) {
            zl[j] = knot_lookup(t->u[j], m->zb, m->nz);
            if (m->emph) el[j] = knot_lookup(t->u[j], m->eb, m->ne);
            if (j + 1 < nu) ix[j] = 1.0 / (t->u[j + 1] - t->u[j]);
        }
        build_ctx_t X = {m, cfg_base, cfg_w, ncfg, nc, nu, nup, ncell_u, chi, t->u, zl, el, ix, ja, jb, t, sign};
        int ch_fail = 0;
        int k;
#pragma omp parallel reduction(|| : ch_fail) if ((Py_ssize_t)ns * nc * ncfg * R * nu >= PAR_MIN_WORK && nc > 1)
        {
            /* ra, rb [ncfg][nup], acc [8][nup], zq [ncfg][R][nup], eq [ncfg][nup], sv [R] */
            const size_t cn = (size_t)ncfg * nup;
            double *buf = malloc(sizeof(double) * ((3 + (size_t)R) * cn + 8 * (size_t)nup + (size_t)R));
            int *unsafe = malloc(sizeof(int) * (ncfg > 0 ? ncfg : 1));
            if (!buf || !unsafe) ch_fail = 1;
#pragma omp for schedule(dynamic, 1)
            for (k = 0; k < nc; ++k)
                if (buf && unsafe &&
                    build_channel(&X, k, &lists[k], buf, buf + cn, buf + 2 * cn, unsafe, buf + 2 * cn + 8 * (size_t)nup,
                                  buf + (2 + (size_t)R) * cn + 8 * (size_t)nup,
                                  buf + (3 + (size_t)R) * cn + 8 * (size_t)nup))
                    ch_fail = 1;
            free(buf);
            free(unsafe);
        }
        fail = ch_fail;
    }
    if (!fail) {
        /* CSR of the mixed terms by cell; within a cell by channel, then configuration */
        size_t total = 0;
        for (int k = 0; k < nc; ++k) total += lists[k].n;
        t->nmix = (Py_ssize_t)total;
        t->mix_ch = malloc(sizeof(int) * (total ? total : 1));
        t->mix_coef = malloc(sizeof(double) * 6 * (total ? total : 1));
        int *fill = calloc((size_t)ncell, sizeof(int));
        if (!t->mix_ch || !t->mix_coef || !fill) fail = 1;
        if (!fail) {
            for (int k = 0; k < nc; ++k)
                for (int e = 0; e < lists[k].n; ++e) t->mix_start[lists[k].cell[e] + 1]++;
            for (int c = 0; c < ncell; ++c) t->mix_start[c + 1] += t->mix_start[c];
            for (int k = 0; k < nc; ++k)
                for (int e = 0; e < lists[k].n; ++e) {
                    int cell = lists[k].cell[e];
                    int pos = t->mix_start[cell] + fill[cell]++;
                    t->mix_ch[pos] = lists[k].ch[e];
                    memcpy(t->mix_coef + 6 * (size_t)pos, lists[k].coef + 6 * (size_t)e, 6 * sizeof(double));
                }
        }
        free(fill);
    }
    if (lists)
        for (int k = 0; k < nc; ++k) {
            free(lists[k].cell);
            free(lists[k].ch);
            free(lists[k].coef);
        }
    free(lists);
    free(zl);
    free(el);
    free(ix);
    if (fail) {
        table_free(t);
        return -1;
    }
    return 0;
}

static inline void store_row(void *out, size_t i, int nc, const double *restrict acc, int is_double,
                             double sign)
{
    if (is_double) {
        double *restrict o = (double *)out + (size_t)i * nc;
        for (int k = 0; k < nc; ++k) o[k] = sign * acc[k];
    } else {
        float *restrict o = (float *)out + (size_t)i * nc;
        for (int k = 0; k < nc; ++k) o[k] = (float)(sign * acc[k]);
    }
}

static int table_build(table_t *t, const comp_t *m, const int64_t *cfg_base, const double *cfg_w, int ncfg,
                       const int64_t *chi, int nc)
{
    return table_build_signed(t, m, cfg_base, cfg_w, ncfg, chi, nc, 1.0, NULL, NULL, 0);
}

/* arccos for the table paths: branch-free (vectorised in a loop over a block of directions), within one ulp
 * of the C library's acos (checked on 2e7 arguments, dense near -1, -1/2, 1/2 and 1, in both builds).
 * Range reduction by the identities acos(x) = pi/2 - asin(x) for |x| <= 1/2 and acos(|x|) = 2 asin(s),
 * s = sqrt((1 - |x|) / 2) for |x| > 1/2 (acos(-a) = pi - acos(a)), so asin is only needed on [0, 1/2]:
 * asin(s) = s + s t P(t), t = s^2 <= 1/4, P(t) = (asin(s) - s) / s^3 approximated by a degree-12 polynomial:
 * least squares on 48 Chebyshev points of [0, 1/4] against P's Maclaurin series (coefficients
 * (2n)! / (4^n (n!)^2 (2n + 1))), in exact rational arithmetic, then rounded; relative error 1.2e-16 of P,
 * which enters asin scaled by t P / (1 + t P) < 0.05. */
static const double ASIN_C[13] = {
    0x1.5555555555556p-3, 0x1.3333333332e87p-4, 0x1.6db6db6e3844bp-5, 0x1.f1c71c19f8d29p-6,
    0x1.6e8bb25868b49p-6, 0x1.1c4d28ea04196p-6, 0x1.c9d07d4d03ddbp-7, 0x1.78186416c6a4ep-7,
    0x1.529a9bba29802p-7, 0x1.62c22a53244eap-8, 0x1.1f0750c0651fcp-6, -0x1.ec92eb603f637p-7,
    0x1.d924a1e3b6e41p-6};
#define PI_HI 0x1.921fb54442d18p+1
#define PI_LO 0x1.1a62633145c07p-53
#define PIO2_HI 0x1.921fb54442d18p+0
#define PIO2_LO 0x1.1a62633145c07p-54

static inline double acos_block(double x)
{
    const double a = fabs(x);
    const int big = a > 0.5;
    const double tb = (1.0 - a) * 0.5, ts = a * a;
    const double t = big ? tb : ts;
    const double sq = sqrt(tb);
    const double s = big ? sq : a;
    const double *C = ASIN_C;
    double p = C[12] * t + C[11];
    p = p * t + C[10], p = p * t + C[9], p = p * t + C[8], p = p * t + C[7], p = p * t + C[6];
    p = p * t + C[5], p = p * t + C[4], p = p * t + C[3], p = p * t + C[2], p = p * t + C[1];
    p = p * t + C[0];
    const double as = s + s * (t * p); /* asin(s) */
    const double r_small = PIO2_HI - (copysign(as, x) - PIO2_LO);
    const double r_pos = 2.0 * as, r_neg = PI_HI - (2.0 * as - PI_LO);
    const double r_big = x > 0 ? r_pos : r_neg;
    return big ? r_big : r_small;
}

/* Cosines of the angles of directions dirs[0..cnt), by the operations compute_angles uses (so the same
 * values): to the sun (cg), of the altitude-corrected zenith (cz) and, with need_shadow, to the shadow
 * direction (cs), each clamped to [-1, 1]. A loop without calls, vectorised; corrected and need_shadow are
 * constants at every call site (dir_cosines), so each variant is its own loop. */
static inline void dir_cos_body(const geom_t *geo, const double *restrict dirs, int cnt, double *restrict cg,
                                double *restrict cz, double *restrict cs, const int corrected, const int need_shadow)
{
    const double s0 = geo->s[0], s1 = geo->s[1], s2 = geo->s[2];
    const double h0 = geo->h[0], h1 = geo->h[1], h2 = geo->h[2];
    const double sz = geo->sz, oz = geo->oz;
    for (int t = 0; t < cnt; ++t) {
        const double x = dirs[3 * t], y = dirs[3 * t + 1], z = dirs[3 * t + 2];
        double nv = sqrt(x * x + y * y + z * z);
        nv = nv < DBL_EPSILON_ ? DBL_EPSILON_ : nv;
        const double vx = x / nv, vy = y / nv, vz = z / nv;
        double cx = vx, cy = vy, c = vz;
        if (corrected) {
            c = (vz + sz) - oz;
            const double n2 = sqrt(cx * cx + cy * cy + c * c);
            cx /= n2;
            cy /= n2;
            c /= n2;
        }
        cg[t] = clamp_unit(vx * s0 + vy * s1 + vz * s2);
        cz[t] = clamp_unit(c);
        if (need_shadow) cs[t] = clamp_unit(cx * h0 + cy * h1 + c * h2);
    }
}

static inline void dir_cosines(const geom_t *geo, const double *restrict dirs, int cnt, int need_shadow,
                               double *restrict cg, double *restrict cz, double *restrict cs)
{
    if (geo->corrected) {
        if (need_shadow)
            dir_cos_body(geo, dirs, cnt, cg, cz, cs, 1, 1);
        else
            dir_cos_body(geo, dirs, cnt, cg, cz, cs, 1, 0);
    } else {
        if (need_shadow)
            dir_cos_body(geo, dirs, cnt, cg, cz, cs, 0, 1);
        else
            dir_cos_body(geo, dirs, cnt, cg, cz, cs, 0, 0);
    }
}

/* directions per block of the table paths: angles for a block first (vectorised), then the channels */
#define EVAL_BLOCK 256

typedef float v4fo __attribute__((vector_size(16), aligned(4)));

/* The cell polynomial T0 + g T1 + z (T2 + g T3 + z (T4 + g T5)) (rows T0..T5 of nc channels) at L
 * directions (g[l], z[l]) that share the cell, into the output rows o[l] (float32 or float64): each
 * coefficient vector is loaded once for the L directions. The same operations in the same order as for one
 * direction alone (L is a constant at every call site), so the values do not depend on the grouping. */
static inline double cell_poly(const double *T0, int nc, int k, double g, double z)
{
    const double *T1 = T0 + nc, *T2 = T1 + nc, *T3 = T2 + nc, *T4 = T3 + nc, *T5 = T4 + nc;
    return T0[k] + g * T1[k] + z * (T2[k] + g * T3[k] + z * (T4[k] + g * T5[k]));
}

static inline __attribute__((always_inline)) void poly_group(const double *restrict T0, int nc, const double *g,
                                                             const double *z, void *const *o, const int L,
                                                             const int is_double)
{
    const double *restrict T1 = T0 + nc, *restrict T2 = T1 + nc, *restrict T3 = T2 + nc;
    const double *restrict T4 = T3 + nc, *restrict T5 = T4 + nc;
    v4d G[4], Z[4];
    for (int l = 0; l < 4; ++l) {
        G[l] = v4_set1(g[l < L ? l : 0]);
        Z[l] = v4_set1(z[l < L ? l : 0]);
    }
    /* whole vectors; a remainder as the last four channels again (overlapping: the same values rewritten) */
    for (int k = 0; k < nc && nc >= 4; k += 4) {
        if (k + 4 > nc) k = nc - 4;
        const v4d t0 = v4_load(T0 + k), t1 = v4_load(T1 + k), t2 = v4_load(T2 + k);
        const v4d t3 = v4_load(T3 + k), t4 = v4_load(T4 + k), t5 = v4_load(T5 + k);
        for (int l = 0; l < L; ++l) {
            const v4d v = t0 + G[l] * t1 + Z[l] * (t2 + G[l] * t3 + Z[l] * (t4 + G[l] * t5));
            if (is_double)
                v4_store((double *)o[l] + k, v);
            else
                *(v4fo *)((float *)o[l] + k) = __builtin_convertvector(v, v4fo);
        }
    }
    for (int k = 0; k < nc && nc < 4; ++k)
        for (int l = 0; l < L; ++l) {
            const double v = cell_poly(T0, nc, k, g[l], z[l]);
            if (is_double)
                ((double *)o[l])[k] = v;
            else
                ((float *)o[l])[k] = (float)v;
        }
}

/* The clamped terms [m0, m1) of a cell at 4 directions (g[l], z[l]) sharing it, added to acc rows l (4 rows
 * of nc): each term's 6 coefficients loaded once, its value for the 4 directions in one vector, by the same
 * operations in the same order as for one direction; max(value, 0) added without a branch (whether a term
 * is positive is as good as random: a branch on it is mispredicted half the time). */
typedef long long v4di __attribute__((vector_size(32)));
static inline void mixed_group(const table_t *t, int m0, int m1, const double *g, const double *z,
                               double *restrict acc, int nc)
{
    const v4d G = {g[0], g[1], g[2], g[3]}, Z = {z[0], z[1], z[2], z[3]};
    const v4d GZ = G * Z, Z2 = Z * Z, GZ2 = GZ * Z;
    for (int e = m0; e < m1; ++e) {
        const double *c6 = t->mix_coef + 6 * (size_t)e;
        const v4d v = v4_set1(c6[0]) + G * v4_set1(c6[1]) + Z * v4_set1(c6[2]) + GZ * v4_set1(c6[3]) +
                      Z2 * v4_set1(c6[4]) + GZ2 * v4_set1(c6[5]);
        const int ch = t->mix_ch[e];
        const v4d vp = (v4d)((v4di)v & (v4di)(v > 0));
        for (int l = 0; l < 4; ++l) acc[(size_t)l * nc + ch] += vp[l];
    }
}

/* Evaluate directions [i0, i0 + cnt) in their given order (an image's order keeps neighbouring directions,
 * which mostly share a cell, together): the block's cosines (vectorised), its angles and cells, then per
 * direction the cell's polynomial over the channels (channel-innermost, vectorised), written straight to the
 * output where the cell has no separately clamped term, else through acc. The table carries the output's
 * sign (table_build_signed). */
HOT static void eval_chunk(const table_t *t, const accel_t *ag, const accel_t *az, const geom_t *geo,
                           const double *dirs, Py_ssize_t i0, int cnt, void *out, int is_double,
                           double *restrict acc, const int64_t *rows)
{
    double cg[EVAL_BLOCK], cz[EVAL_BLOCK], gv[EVAL_BLOCK], zv[EVAL_BLOCK];
    int cell[EVAL_BLOCK];
    const int ncell_u = t->nu - 1, nc = t->nc;
    dir_cosines(geo, dirs + 3 * i0, cnt, 0, cg, cz, NULL);
    for (int j = 0; j < cnt; ++j) {
        cg[j] = acos_block(cg[j]);
        cz[j] = acos_block(cz[j]);
    }
    int ig = 0, iz = 0;
    for (int j = 0; j < cnt; ++j) {
        ig = accel_cell_hint(ag, cg[j], &gv[j], ig);
        iz = accel_cell_hint(az, cz[j], &zv[j], iz);
        cell[j] = ig * ncell_u + iz;
    }
    const size_t osz = is_double ? sizeof(double) : sizeof(float);
    for (int j = 0; j < cnt;) {
        const int c = cell[j];
        const double *restrict T0 = t->tab + (size_t)c * 6 * nc;
        const int m0 = t->mix_start[c], m1 = t->mix_start[c + 1];
        /* the following directions in the same cell (most, in an image's order) share the loads */
        int L = 1;
        while (L < 4 && j + L < cnt && cell[j + L] == c) ++L;
        if (m0 == m1) {
            void *o[4];
            for (int l = 0; l < L; ++l) o[l] = (char *)out + OUT_ROW(rows, i0 + j + l) * nc * osz;
            if (is_double) {
                if (L == 4) poly_group(T0, nc, gv + j, zv + j, o, 4, 1);
                else if (L >= 2) poly_group(T0, nc, gv + j, zv + j, o, 2, 1);
                else poly_group(T0, nc, gv + j, zv + j, o, 1, 1);
            } else {
                if (L == 4) poly_group(T0, nc, gv + j, zv + j, o, 4, 0);
                else if (L >= 2) poly_group(T0, nc, gv + j, zv + j, o, 2, 0);
                else poly_group(T0, nc, gv + j, zv + j, o, 1, 0);
            }
            j += L == 4 ? 4 : (L >= 2 ? 2 : 1);
            continue;
        }
        /* a cell with separately clamped terms: the polynomial into acc (double, 4 rows of nc), the clamped
         * terms added there, then the rows written */
        void *a[4] = {acc, acc + nc, acc + 2 * (size_t)nc, acc + 3 * (size_t)nc};
        if (L >= 2) { /* four lanes (a run of 2 or 3 repeats its last direction in the spare lanes) */
            double g4[4], z4[4];
            for (int l = 0; l < 4; ++l) g4[l] = gv[j + (l < L ? l : L - 1)], z4[l] = zv[j + (l < L ? l : L - 1)];
            poly_group(T0, nc, g4, z4, a, 4, 1);
            mixed_group(t, m0, m1, g4, z4, acc, nc);
        } else {
            L = 1;
            poly_group(T0, nc, gv + j, zv + j, a, 1, 1);
            const double g = gv[j], z = zv[j], gz = g * z, z2 = z * z, gz2 = gz * z;
            for (int e = m0; e < m1; ++e) {
                const double *c6 = t->mix_coef + 6 * (size_t)e;
                double v = c6[0] + g * c6[1] + z * c6[2] + gz * c6[3] + z2 * c6[4] + gz2 * c6[5];
                acc[t->mix_ch[e]] += v > 0 ? v : 0.0;
            }
        }
        for (int l = 0; l < L; ++l) store_row(out, OUT_ROW(rows, i0 + j + l), nc, acc + (size_t)l * nc, is_double, 1.0);
        j += L;
    }
}

/* A range containing the sun angle and the zero angle of every direction [rad]: range = {gamma min, gamma
 * max, zero min, zero max}, or NaN where a direction is NaN. Bounds, cheaply: the cosines of gamma and of
 * the uncorrected zenith angle by one reciprocal (within a few ulp of the evaluation's), the range then
 * widened by 1e-6 rad (far more than a few ulp of a cosine make, even near +-1), and the zenith range by
 * asin(h) more, h the altitude correction's shift of the view point (adding h to a unit vector's z turns
 * it by at most asin(h)). */
HOT static void angle_range_block(const geom_t *geo, const double *dirs, int cnt, double *mm)
{
    double cg[EVAL_BLOCK], cz[EVAL_BLOCK];
    const double s0 = geo->s[0], s1 = geo->s[1], s2 = geo->s[2];
    for (int t = 0; t < cnt; ++t) {
        const double x = dirs[3 * t], y = dirs[3 * t + 1], z = dirs[3 * t + 2];
        double nv = sqrt(x * x + y * y + z * z);
        nv = nv < DBL_EPSILON_ ? DBL_EPSILON_ : nv;
        const double r = 1.0 / nv;
        cg[t] = (x * s0 + y * s1 + z * s2) * r;
        cz[t] = z * r;
    }
    double gl = mm[0], gh = mm[1], zl = mm[2], zh = mm[3];
    for (int j = 0; j < cnt; ++j) {
        gl = cg[j] < gl ? cg[j] : gl;
        gh = cg[j] > gh ? cg[j] : gh;
        zl = cz[j] < zl ? cz[j] : zl;
        zh = cz[j] > zh ? cz[j] : zh;
    }
    int bad = 0;
    for (int j = 0; j < cnt; ++j) bad |= (cg[j] != cg[j]) | (cz[j] != cz[j]);
    if (bad) gl = gh = zl = zh = NAN;
    mm[0] = gl, mm[1] = gh, mm[2] = zl, mm[3] = zh;
}

static void angle_range(const geom_t *geo, const double *dirs, Py_ssize_t n, double *range)
{
    double gl = 2.0, gh = -2.0, zl = 2.0, zh = -2.0;
    int bad = 0;
    Py_ssize_t b, nb = (n + EVAL_BLOCK - 1) / EVAL_BLOCK;
#pragma omp parallel for schedule(static) reduction(min : gl, zl) reduction(max : gh, zh) reduction(|| : bad) if (n >= 16384)
    for (b = 0; b < nb; ++b) {
        double mm[4] = {2.0, -2.0, 2.0, -2.0};
        const Py_ssize_t i0 = b * EVAL_BLOCK;
        angle_range_block(geo, dirs + 3 * i0, (int)(n - i0 < EVAL_BLOCK ? n - i0 : EVAL_BLOCK), mm);
        if (mm[0] != mm[0]) bad = 1;
        else {
            gl = mm[0] < gl ? mm[0] : gl, gh = mm[1] > gh ? mm[1] : gh;
            zl = mm[2] < zl ? mm[2] : zl, zh = mm[3] > zh ? mm[3] : zh;
        }
    }
    if (bad) {
        range[0] = range[1] = range[2] = range[3] = NAN;
        return;
    }
    const double h = geo->corrected ? geo->sz - geo->oz : 0.0;
    const double wz = 1e-6 + (h < 1.0 ? asin(h > 0 ? h : 0.0) : M_PI);
    range[0] = acos_block(clamp_unit(gh)) - 1e-6, range[1] = acos_block(clamp_unit(gl)) + 1e-6;
    range[2] = acos_block(clamp_unit(zh)) - wz, range[3] = acos_block(clamp_unit(zl)) + wz;
}

/* the interval [0, n-2] containing q (clamped to the knots), as accel_cell selects it */
static int interval_of(double q, const double *b, int n)
{
    if (!(q >= b[0])) q = b[0];
    if (q > b[n - 1]) q = b[n - 1];
    int i = 0;
    while (i + 1 < n - 1 && b[i + 1] <= q) ++i;
    return i;
}

/* n floats from src to dst (float32 output rows, contiguous): non-temporal (streaming) stores where dst is
 * 16-byte aligned, so the output's cache lines are written without being read first (an image's output does
 * not fit a cache: the read doubles its memory traffic); the caller fences (nt_fence) before the output is
 * read. Elsewhere a plain copy. The values are the staged ones, bit for bit. */
static void nt_copy_f32(float *restrict dst, const float *restrict src, size_t n)
{
#ifdef DIRECT_VEC
    while (n && ((uintptr_t)dst & 15)) *dst++ = *src++, --n;
    for (; n >= 16; n -= 16, dst += 16, src += 16) {
        _mm_stream_ps(dst, _mm_loadu_ps(src));
        _mm_stream_ps(dst + 4, _mm_loadu_ps(src + 4));
        _mm_stream_ps(dst + 8, _mm_loadu_ps(src + 8));
        _mm_stream_ps(dst + 12, _mm_loadu_ps(src + 12));
    }
#endif
    memcpy(dst, src, n * sizeof(float));
}

static inline void nt_fence(void)
{
#ifdef DIRECT_VEC
    _mm_sfence();
#endif
}

static int table_eval(const table_t *t, const geom_t *geo, const double *dirs, Py_ssize_t n, void *out,
                      int is_double, const int64_t *rows)
{
    accel_t ag, az;
    if (accel_init(&ag, t->sb, t->ns)) return -1;
    if (accel_init(&az, t->u, t->nu)) {
        free(ag.start);
        return -1;
    }
    const Py_ssize_t chunk = EVAL_BLOCK;
    Py_ssize_t nchunks = (n + chunk - 1) / chunk, c;
    int fail = 0;
    /* float32 rows in order, beyond a cache's worth: each block evaluated into a staging buffer (a cache's
     * worth, reused) and streamed to the output */
    const int stream = !is_double && !rows && n * (Py_ssize_t)t->nc >= (Py_ssize_t)1 << 20;
#pragma omp parallel reduction(|| : fail) if (n * (Py_ssize_t)t->nc >= PAR_MIN_WORK / 8)
    {
        double *acc = malloc(sizeof(double) * 4 * (t->nc > 0 ? t->nc : 1));
        float *stage = stream ? malloc(sizeof(float) * chunk * (t->nc > 0 ? t->nc : 1)) : NULL;
        if (!acc || (stream && !stage)) fail = 1;
#pragma omp for schedule(static)
        for (c = 0; c < nchunks; ++c) {
            if (!acc || (stream && !stage)) continue;
            Py_ssize_t i0 = c * chunk, i1 = i0 + chunk < n ? i0 + chunk : n;
            if (stream) {
                eval_chunk(t, &ag, &az, geo, dirs + 3 * i0, 0, (int)(i1 - i0), stage, 0, acc, NULL);
                nt_copy_f32((float *)out + (size_t)i0 * t->nc, stage, (size_t)(i1 - i0) * t->nc);
            } else
                eval_chunk(t, &ag, &az, geo, dirs, i0, (int)(i1 - i0), out, is_double, acc, rows);
        }
        if (stream) nt_fence();
        free(stage);
        free(acc);
    }
    free(ag.start);
    free(az.start);
    return fail ? -1 : 0;
}

/* ------------------------------------------------------------------------------------------ */
/* twilight table path (sun below the horizon)                                                */
/*
 * Below the horizon the zenith factor takes the shadow angle and the emphasis the zero angle, so a
 * configuration's product emph(zero) * sum_r sun_r(gamma) zen_r(shadow) is, inside each cell of
 * (sun knots) x (zenith knots) x (emphasis knots), the polynomial (e0 + e1 z)(A + B g + C s + D g s) in
 * the local offsets g, s, z: 8 terms. The three-dimensional table would be large (cells^3), so only the
 * cells the given directions visit are built: pass 1 finds each direction's cell and offsets, pass 2
 * builds the visited cells (corner products sum_r sun_r zen_r at every knot pair are precomputed once),
 * folding the configurations that cannot change sign inside the cell and keeping the others as their own
 * clamped terms, as the daytime table does; pass 3 evaluates. Exact to rounding, like the daytime table.
 */

typedef struct {
    int64_t key;
    double g, s, z;
} tw_dir_t;

/* largest number of 3-D cells indexed directly; beyond it the direct path is used */
#define TW_MAX_CELLS 50000000

/* pass 1 of the twilight table for the block of directions from i0: cells and local offsets */
HOT static void tw_locate(const geom_t *geo, const accel_t *ag, const accel_t *as, const accel_t *ae,
                          const double *dirs, Py_ssize_t i0, Py_ssize_t n, int64_t cz, int64_t ce, tw_dir_t *d)
{
    double cg[EVAL_BLOCK], cs[EVAL_BLOCK], cze[EVAL_BLOCK];
    const int cnt = (int)(n - i0 < EVAL_BLOCK ? n - i0 : EVAL_BLOCK);
    dir_cosines(geo, dirs + 3 * i0, cnt, 1, cg, cze, cs);
    for (int j = 0; j < cnt; ++j) {
        cg[j] = acos_block(cg[j]);
        cs[j] = acos_block(cs[j]);
        cze[j] = acos_block(cze[j]);
    }
    int ig = 0, is = 0, iz = 0;
    for (int j = 0; j < cnt; ++j) {
        tw_dir_t *e = d + i0 + j;
        ig = accel_cell_hint(ag, cg[j], &e->g, ig);
        is = accel_cell_hint(as, cs[j], &e->s, is);
        iz = accel_cell_hint(ae, cze[j], &e->z, iz);
        e->key = ((int64_t)ig * cz + is) * ce + iz;
    }
}

typedef struct {
    const double *tab;
    const int *mix_start, *mix_ch;
    const double *mix_coef;
    const int32_t *slot;
    int nc;
} tw_tab_t;

/* The twilight cell polynomial T0 + g T1 + s (T2 + g T3) + z (T4 + g T5 + s (T6 + g T7)) at L directions
 * sharing the cell (as poly_group: one load of each coefficient vector for the L directions, the same
 * operations in the same order as one direction alone). */
static inline double tw_poly(const double *T, int nc, int k, double g, double s, double z)
{
    return T[k] + g * T[nc + k] + s * (T[2 * nc + k] + g * T[3 * nc + k]) +
           z * (T[4 * nc + k] + g * T[5 * nc + k] + s * (T[6 * nc + k] + g * T[7 * nc + k]));
}

static inline __attribute__((always_inline)) void tw_poly_group(const double *restrict T, int nc, const tw_dir_t *dd,
                                                                void *const *o, const int L, const int is_double)
{
    v4d G[4], S[4], Z[4];
    for (int l = 0; l < 4; ++l) {
        const tw_dir_t *e = dd + (l < L ? l : 0);
        G[l] = v4_set1(e->g);
        S[l] = v4_set1(e->s);
        Z[l] = v4_set1(e->z);
    }
    for (int k = 0; k < nc && nc >= 4; k += 4) { /* a remainder as the last four channels again */
        if (k + 4 > nc) k = nc - 4;
        const v4d t0 = v4_load(T + k), t1 = v4_load(T + nc + k), t2 = v4_load(T + 2 * nc + k);
        const v4d t3 = v4_load(T + 3 * nc + k), t4 = v4_load(T + 4 * nc + k), t5 = v4_load(T + 5 * nc + k);
        const v4d t6 = v4_load(T + 6 * nc + k), t7 = v4_load(T + 7 * nc + k);
        for (int l = 0; l < L; ++l) {
            const v4d v = t0 + G[l] * t1 + S[l] * (t2 + G[l] * t3) + Z[l] * (t4 + G[l] * t5 + S[l] * (t6 + G[l] * t7));
            if (is_double)
                v4_store((double *)o[l] + k, v);
            else
                *(v4fo *)((float *)o[l] + k) = __builtin_convertvector(v, v4fo);
        }
    }
    for (int k = 0; k < nc && nc < 4; ++k)
        for (int l = 0; l < L; ++l) {
            const double v = tw_poly(T, nc, k, dd[l].g, dd[l].s, dd[l].z);
            if (is_double)
                ((double *)o[l])[k] = v;
            else
                ((float *)o[l])[k] = (float)v;
        }
}

/* pass 3 of the twilight table for the block of directions from i0 */
HOT static void tw_eval_block(const tw_tab_t *X, const tw_dir_t *d, Py_ssize_t i0, int cnt, void *out, int is_double,
                              double *restrict acc, const int64_t *rows)
{
    const int nc = X->nc;
    const size_t osz = is_double ? sizeof(double) : sizeof(float);
    const tw_dir_t *db = d + i0;
    for (int j = 0; j < cnt;) {
        const int v = X->slot[db[j].key];
        const double *restrict T = X->tab + (size_t)v * 8 * nc;
        const int m0 = X->mix_start[v], m1 = X->mix_start[v + 1];
        if (m0 == m1) {
            int L = 1;
            while (L < 4 && j + L < cnt && db[j + L].key == db[j].key) ++L;
            void *o[4];
            for (int l = 0; l < L; ++l) o[l] = (char *)out + OUT_ROW(rows, i0 + j + l) * nc * osz;
            if (is_double) {
                if (L == 4) tw_poly_group(T, nc, db + j, o, 4, 1);
                else if (L >= 2) tw_poly_group(T, nc, db + j, o, 2, 1);
                else tw_poly_group(T, nc, db + j, o, 1, 1);
            } else {
                if (L == 4) tw_poly_group(T, nc, db + j, o, 4, 0);
                else if (L >= 2) tw_poly_group(T, nc, db + j, o, 2, 0);
                else tw_poly_group(T, nc, db + j, o, 1, 0);
            }
            j += L == 4 ? 4 : (L >= 2 ? 2 : 1);
            continue;
        }
        const double g = db[j].g, sv = db[j].s, z = db[j].z, gs = g * sv;
        for (int k = 0; k < nc; ++k) acc[k] = tw_poly(T, nc, k, g, sv, z);
        for (int e = m0; e < m1; ++e) {
            const double *c8 = X->mix_coef + 8 * (size_t)e;
            double x = c8[0] + g * c8[1] + sv * c8[2] + gs * c8[3] + z * (c8[4] + g * c8[5] + sv * c8[6] + gs * c8[7]);
            acc[X->mix_ch[e]] += x > 0 ? x : 0.0; /* without a branch: the sign is as good as random */
        }
        store_row(out, OUT_ROW(rows, i0 + j), nc, acc, is_double, 1.0);
        ++j;
    }
}

static int twilight_eval(const comp_t *m, const geom_t *geo, const int64_t *cfg_base, const double *cfg_w,
                         int ncfg, const int64_t *chi, int nc, const double *dirs, Py_ssize_t n, void *out,
                         int is_double, const int64_t *rows, Py_ssize_t *nvisited_out, Py_ssize_t *nmix_out)
{
    const int ns = m->ns, nz = m->nz, ne = m->ne, R = m->rank;
    const int64_t cz = nz - 1, ce = ne - 1, ncell3 = (int64_t)(ns - 1) * cz * ce;
    if (ncell3 > TW_MAX_CELLS) return 1;
    for (int j = 0; j + 1 < ns; ++j) if (m->sb[j + 1] - m->sb[j] < TABLE_MIN_CELL) return 1;
    for (int j = 0; j + 1 < nz; ++j) if (m->zb[j + 1] - m->zb[j] < TABLE_MIN_CELL) return 1;
    for (int j = 0; j + 1 < ne; ++j) if (m->eb[j + 1] - m->eb[j] < TABLE_MIN_CELL) return 1;
    const size_t cn = (size_t)ncfg * nc;
    int fail = 0;
    accel_t ag, as, ae;
    memset(&ag, 0, sizeof(ag)), memset(&as, 0, sizeof(as)), memset(&ae, 0, sizeof(ae));
    double *K = NULL; /* [i - i0k][j - j0k][c][k] corner products over the visited cells' knots */
    double *E = malloc(sizeof(double) * (size_t)ne * cn);      /* [l][c][k] emphasis at its knots */
    tw_dir_t *d = malloc(sizeof(tw_dir_t) * (n ? n : 1));
    int32_t *slot = malloc(sizeof(int32_t) * (size_t)ncell3);
    int64_t *cells = NULL;
    double *tab = NULL;
    int *mix_start = NULL, *mix_ch = NULL;
    double *mix_coef = NULL;
    mixlist_t *lists = NULL;
    Py_ssize_t nvis = 0, nmix = 0;
    if (!E || !d || !slot || accel_init(&ag, m->sb, ns) || accel_init(&as, m->zb, nz) ||
        accel_init(&ae, m->eb, ne)) {
        fail = -1;
        goto out;
    }
    {
        Py_ssize_t b, nb = (n + EVAL_BLOCK - 1) / EVAL_BLOCK;
#pragma omp parallel for schedule(static) if (n >= 4096)
        for (b = 0; b < nb; ++b) tw_locate(geo, &ag, &as, &ae, dirs, b * EVAL_BLOCK, n, cz, ce, d);
    }
    for (int64_t c = 0; c < ncell3; ++c) slot[c] = -1;
    int i0k = ns, i1k = -1, j0k = nz, j1k = -1; /* knots of the visited cells' corners */
    for (Py_ssize_t i = 0; i < n; ++i)
        if (slot[d[i].key] < 0) {
            slot[d[i].key] = (int32_t)nvis++;
            const int64_t key = d[i].key;
            const int is = (int)((key / ce) % cz), ig = (int)(key / (ce * cz));
            i0k = ig < i0k ? ig : i0k, i1k = ig + 1 > i1k ? ig + 1 : i1k;
            j0k = is < j0k ? is : j0k, j1k = is + 1 > j1k ? is + 1 : j1k;
        }
    const int nik = i1k >= i0k ? i1k - i0k + 1 : 0, njk = j1k >= j0k ? j1k - j0k + 1 : 0;
    K = malloc(sizeof(double) * ((size_t)nik * njk * cn + 1));
    if (!K) {
        fail = -1;
        goto out;
    }
    {
        Py_ssize_t q, nq = (Py_ssize_t)cn;
#pragma omp parallel for schedule(static) if (nq * nik * njk * R >= PAR_MIN_WORK)
        for (q = 0; q < nq; ++q) {
            int c = (int)(q / nc), k = (int)(q % nc);
            size_t cfg = (size_t)cfg_base[c] * m->nch + (size_t)chi[k];
            const float *sun = m->sun + cfg * (size_t)R * ns, *zen = m->zen + cfg * (size_t)R * nz;
            for (int i = i0k; i <= i1k; ++i)
                for (int j = j0k; j <= j1k; ++j) {
                    double acc = 0.0;
                    for (int r = 0; r < R; ++r) acc += (double)sun[(size_t)r * ns + i] * (double)zen[(size_t)r * nz + j];
                    K[((size_t)(i - i0k) * njk + (j - j0k)) * cn + q] = acc;
                }
            for (int l = 0; l < ne; ++l) E[(size_t)l * cn + q] = (double)m->emph[cfg * (size_t)ne + l];
        }
    }
    cells = malloc(sizeof(int64_t) * (nvis ? nvis : 1));
    tab = malloc(sizeof(double) * 8 * (size_t)nc * (nvis ? nvis : 1));
    mix_start = calloc((size_t)nvis + 1, sizeof(int));
    if (!cells || !tab || !mix_start) {
        fail = -1;
        goto out;
    }
    for (int64_t c = 0; c < ncell3; ++c)
        if (slot[c] >= 0) cells[slot[c]] = c;
    int nthr = 1;
#ifdef WIDESKY_OPENMP
    nthr = omp_get_max_threads();
#endif
    lists = calloc((size_t)nthr, sizeof(mixlist_t));
    if (!lists) {
        fail = -1;
        goto out;
    }
    {
        Py_ssize_t v;
        int bfail = 0;
#pragma omp parallel for schedule(dynamic, 16) reduction(|| : bfail) if (nvis * (Py_ssize_t)cn >= PAR_MIN_WORK / 4)
        for (v = 0; v < nvis; ++v) {
            int tid = 0;
#ifdef WIDESKY_OPENMP
            tid = omp_get_thread_num();
#endif
            const int64_t key = cells[v];
            const int iz = (int)(key % ce), is = (int)((key / ce) % cz), ig = (int)(key / (ce * cz));
            const double dg = m->sb[ig + 1] - m->sb[ig], ds = m->zb[is + 1] - m->zb[is];
            const double dz = m->eb[iz + 1] - m->eb[iz];
            const size_t kr = (size_t)(ig - i0k) * njk + (is - j0k);
            const double *K00 = K + kr * cn, *K01 = K + (kr + 1) * cn;
            const double *K10 = K + (kr + njk) * cn, *K11 = K + (kr + njk + 1) * cn;
            const double *E0 = E + (size_t)iz * cn, *E1 = E + (size_t)(iz + 1) * cn;
            double *T = tab + (size_t)v * 8 * nc;
            for (int k = 0; k < nc; ++k) {
                double X00 = 0, X01 = 0, X10 = 0, X11 = 0, Y00 = 0, Y01 = 0, Y10 = 0, Y11 = 0;
                for (int c = 0; c < ncfg; ++c) {
                    const size_t q = (size_t)c * nc + k;
                    const double S00 = K00[q], S01 = K01[q], S10 = K10[q], S11 = K11[q], e0 = E0[q], e1 = E1[q];
                    const double w = cfg_w[c];
                    const double smin = fmin(fmin(S00, S01), fmin(S10, S11)), smax = fmax(fmax(S00, S01), fmax(S10, S11));
                    const double emin = fmin(e0, e1), emax = fmax(e0, e1);
                    if ((smin >= 0 && emin >= 0) || (smax <= 0 && emax <= 0)) {
                        const double a = w * e0, b = w * e1;
                        X00 += a * S00, X01 += a * S01, X10 += a * S10, X11 += a * S11;
                        Y00 += b * S00, Y01 += b * S01, Y10 += b * S10, Y11 += b * S11;
                    } else if (!((smin >= 0 && emax <= 0) || (smax <= 0 && emin >= 0))) {
                        const double a = w * e0, b = w * e1;
                        const double x00 = a * S00, x01 = a * S01, x10 = a * S10, x11 = a * S11;
                        const double y00 = b * S00, y01 = b * S01, y10 = b * S10, y11 = b * S11;
                        double c8[8] = {x00, (x10 - x00) / dg, (x01 - x00) / ds, (x11 - x10 - x01 + x00) / (dg * ds),
                                        (y00 - x00) / dz, ((y10 - y00) - (x10 - x00)) / (dg * dz),
                                        ((y01 - y00) - (x01 - x00)) / (ds * dz),
                                        ((y11 - y10 - y01 + y00) - (x11 - x10 - x01 + x00)) / (dg * ds * dz)};
                        /* two 6-slot records per mixed term: [cell, ch] + coefficients 0-5, then 6-7 */
                        double lo6[6] = {c8[0], c8[1], c8[2], c8[3], c8[4], c8[5]};
                        double hi6[6] = {c8[6], c8[7], 0, 0, 0, 0};
                        if (mix_push(&lists[tid], (int)v, k, lo6) || mix_push(&lists[tid], (int)v, -1, hi6)) bfail = 1;
                    }
                }
                T[k] = X00;
                T[nc + k] = (X10 - X00) / dg;
                T[2 * nc + k] = (X01 - X00) / ds;
                T[3 * nc + k] = (X11 - X10 - X01 + X00) / (dg * ds);
                T[4 * nc + k] = (Y00 - X00) / dz;
                T[5 * nc + k] = ((Y10 - Y00) - (X10 - X00)) / (dg * dz);
                T[6 * nc + k] = ((Y01 - Y00) - (X01 - X00)) / (ds * dz);
                T[7 * nc + k] = ((Y11 - Y10 - Y01 + Y00) - (X11 - X10 - X01 + X00)) / (dg * ds * dz);
            }
        }
        if (bfail) {
            fail = -1;
            goto out;
        }
    }
    /* mixed terms by cell (CSR); each term is two consecutive records of a list */
    for (int t = 0; t < nthr; ++t) nmix += lists[t].n / 2;
    mix_ch = malloc(sizeof(int) * (nmix ? nmix : 1));
    mix_coef = malloc(sizeof(double) * 8 * (nmix ? nmix : 1));
    if (!mix_ch || !mix_coef) {
        fail = -1;
        goto out;
    }
    for (int t = 0; t < nthr; ++t)
        for (int e = 0; e < lists[t].n; e += 2) mix_start[lists[t].cell[e] + 1]++;
    for (Py_ssize_t v = 0; v < nvis; ++v) mix_start[v + 1] += mix_start[v];
    {
        int *fill = calloc((size_t)nvis + 1, sizeof(int));
        if (!fill) {
            fail = -1;
            goto out;
        }
        for (int t = 0; t < nthr; ++t)
            for (int e = 0; e < lists[t].n; e += 2) {
                int v = lists[t].cell[e], pos = mix_start[v] + fill[v]++;
                mix_ch[pos] = lists[t].ch[e];
                memcpy(mix_coef + 8 * (size_t)pos, lists[t].coef + 6 * (size_t)e, 6 * sizeof(double));
                memcpy(mix_coef + 8 * (size_t)pos + 6, lists[t].coef + 6 * (size_t)(e + 1), 2 * sizeof(double));
            }
        free(fill);
    }
    {
        Py_ssize_t b, nb = (n + EVAL_BLOCK - 1) / EVAL_BLOCK;
        const tw_tab_t TT = {tab, mix_start, mix_ch, mix_coef, slot, nc};
        /* float32 rows in order, beyond a cache's worth: staged per block and streamed (as table_eval) */
        const int stream = !is_double && !rows && n * (Py_ssize_t)nc >= (Py_ssize_t)1 << 20;
#pragma omp parallel if (n * (Py_ssize_t)nc >= PAR_MIN_WORK / 8)
        {
            double *acc = malloc(sizeof(double) * (nc > 0 ? nc : 1));
            float *stage = stream ? malloc(sizeof(float) * EVAL_BLOCK * (nc > 0 ? nc : 1)) : NULL;
            const int ok = acc && (!stream || stage);
#pragma omp for schedule(static)
            for (b = 0; b < nb; ++b) {
                if (!ok) continue;
                const Py_ssize_t i0 = b * EVAL_BLOCK;
                const int cnt = (int)(n - i0 < EVAL_BLOCK ? n - i0 : EVAL_BLOCK);
                if (stream) {
                    tw_eval_block(&TT, d + i0, 0, cnt, stage, 0, acc, NULL);
                    nt_copy_f32((float *)out + (size_t)i0 * nc, stage, (size_t)cnt * nc);
                } else
                    tw_eval_block(&TT, d, i0, cnt, out, is_double, acc, rows);
            }
            if (stream) nt_fence();
            if (!ok) fail = -1;
            free(stage);
            free(acc);
        }
    }
out:
    *nvisited_out = nvis;
    *nmix_out = nmix;
    if (lists) {
        for (int t = 0; t < nthr; ++t) {
            free(lists[t].cell);
            free(lists[t].ch);
            free(lists[t].coef);
        }
        free(lists);
    }
    free(ag.start), free(as.start), free(ae.start);
    free(K), free(E), free(d), free(slot), free(cells), free(tab), free(mix_start), free(mix_ch), free(mix_coef);
    return fail;
}

/* ------------------------------------------------------------------------------------------ */
/* transmittance                                                                              */

static double ray_circle(double dx, double dy, double y0, double rc)
{
    double qa = dx * dx + dy * dy;
    double qb = 2.0 * y0 * dy;
    double qc = y0 * y0 - rc * rc;
    double disc = qb * qb - 4.0 * qa * qc;
    if (disc <= 0) return -1.0;
    disc = sqrt(disc);
    double den = fmax(2.0 * qa, DBL_EPSILON_);
    double d1 = (-qb + disc) / den, d2 = (-qb - disc) / den;
    if (d1 > 0 && d2 > 0) return fmin(d1, d2);
    return fmax(d1, d2);
}

static inline ip_t trans_param(double v, int n, double p)
{
    ip_t r;
    int i = (int)(v * n);
    if (i > n - 1) i = n - 1;
    if (i < 0) i = 0;
    r.idx = i;
    r.f = 0.0;
    if (i < n - 1) {
        double c1 = pow((double)i / n, p), c2 = pow((double)(i + 1) / n, p);
        double f = (pow(v, p) - c1) / (c2 - c1);
        r.f = f < 0 ? 0 : (f > 1 ? 1 : f);
    }
    return r;
}

typedef struct {
    const float *U; /* [nAltT][dDim][aDim][rank] */
    const float *V; /* [nVisT][nAltT][nch][rank] */
    int ddim, adim, nalt, rank, nch;
} trans_t;

static inline double trans_uv(const trans_t *T, int ivis, int ialt, int ch, int a, int d)
{
    if (a >= T->adim || d >= T->ddim) return 0.0;
    const float *u = T->U + (((size_t)ialt * T->ddim + d) * T->adim + a) * T->rank;
    const float *v = T->V + (((size_t)ivis * T->nalt + ialt) * T->nch + ch) * T->rank;
    double s = 0.0;
    for (int r = 0; r < T->rank; ++r) s += (double)u[r] * (double)v[r];
    return s;
}

static inline double trans_reconstruct(const trans_t *T, int ivis, int ialt, int ch, ip_t ap, ip_t dp)
{
    double t00 = trans_uv(T, ivis, ialt, ch, ap.idx, dp.idx);
    double t01 = trans_uv(T, ivis, ialt, ch, ap.idx, dp.idx + 1);
    double t10 = trans_uv(T, ivis, ialt, ch, ap.idx + 1, dp.idx);
    double t11 = trans_uv(T, ivis, ialt, ch, ap.idx + 1, dp.idx + 1);
    double lo = t00, hi = t10;
    if (dp.f > 0) {
        lo = (1 - dp.f) * t00 + dp.f * t01;
        hi = (1 - dp.f) * t10 + dp.f * t11;
    }
    lo = lo > 0 ? lo : 0;
    hi = hi > 0 ? hi : 0;
    if (ap.f > 0) return (1 - ap.f) * lo + ap.f * hi;
    return lo;
}

/* theta: uncorrected view zenith angle [rad]; h: altitude parameter [m]; dist [m] */
static inline void trans_location(double theta, double h, double dist, int adim, int ddim, ip_t *ap, ip_t *dp)
{
    const double R = PLANET_RADIUS, top = PLANET_RADIUS + ATMOSPHERE_WIDTH;
    double dx = sin(theta), dy = cos(theta), y0 = R + h;
    double t;
    if (h < 0.3) {
        t = theta <= 0.5 * M_PI ? ray_circle(dx, dy, y0, top) : 0.0;
    } else {
        t = ray_circle(dx, dy, y0, R);
        if (t < 0) t = ray_circle(dx, dy, y0, top);
    }
    if (t < 0) t = 0;
    if (t > dist) t = dist;
    double px = dx * t, py = dy * t + y0;
    double rho = sqrt(px * px + py * py);
    double alt = rho - R;
    alt = alt < 0 ? 0 : (alt > ATMOSPHERE_WIDTH ? ATMOSPHERE_WIDTH : alt);
    double aparam = pow(alt / ATMOSPHERE_WIDTH, 1.0 / 3.0);
    double dd = acos(clamp_unit(py / rho)) * R;
    double dparam = sqrt(sqrt(dd / DIST_TO_EDGE));
    if (dparam > 1) dparam = 1;
    *ap = trans_param(aparam, adim, 3.0);
    *dp = trans_param(dparam, ddim, 4.0);
}

/* ------------------------------------------------------------------------------------------ */
/* buffer plumbing                                                                            */

typedef struct {
    Py_buffer b;
    int held;
} buf_t;

static int get_buf(PyObject *o, buf_t *bb, int writable, const char *name, Py_ssize_t itemsize)
{
    bb->held = 0;
    if (o == Py_None) {
        bb->b.buf = NULL;
        bb->b.len = 0;
        return 0;
    }
    if (PyObject_GetBuffer(o, &bb->b, (writable ? PyBUF_WRITABLE : 0) | PyBUF_C_CONTIGUOUS | PyBUF_FORMAT) < 0)
        return -1;
    bb->held = 1;
    if (bb->b.itemsize != itemsize) {
        PyErr_Format(PyExc_TypeError, "%s: expected itemsize %zd, got %zd", name, itemsize, bb->b.itemsize);
        return -1;
    }
    return 0;
}

static void rel_buf(buf_t *bb)
{
    if (bb->held) PyBuffer_Release(&bb->b);
    bb->held = 0;
}

#define NBUF 12

/* The thread count a call with nthreads <= 0 ("all cores") gets: OpenMP's own default, read once before any
 * call changes it (omp_set_num_threads is per calling thread and sticky, so 0 must restore it explicitly). */
static int default_threads = 0;

static void set_threads(int nthreads)
{
#ifdef WIDESKY_OPENMP
    if (default_threads <= 0) default_threads = omp_get_max_threads();
    omp_set_num_threads(nthreads > 0 ? nthreads : default_threads);
#else
    (void)nthreads;
#endif
}

/* radiance(sun, zen, emph|None, sb, zb, eb|None, rank, nch, cfg_base, cfg_w, chi, dirs, state, out,
 *          method, nthreads[, rows])
 * rows (int64, one per direction, optional): the output row of each direction (out holds any number of
 * rows of nc values; rows must be distinct and in range, checked here), for scattering into an image.
 * state = (observer altitude [m], solar elevation [rad], solar azimuth [rad, from +x toward +y]).
 * method: 0 auto, 1 direct, 2 table. emph None -> polarisation (no clamp, output negated).
 * Returns (method used: 1 direct, 2 table, 3 twilight table; number of cell terms kept separately for
 * the clamp; number of 3-D cells built by the twilight table). */
static PyObject *py_radiance(PyObject *self, PyObject *args)
{
    PyObject *o[14];
    PyObject *rows_obj = Py_None;
    int rank, nch, method, nthreads;
    double alt, el, az;
    if (!PyArg_ParseTuple(args, "OOOOOOiiOOOO(ddd)Oii|O", &o[0], &o[1], &o[2], &o[3], &o[4], &o[5], &rank,
                          &nch, &o[6], &o[7], &o[8], &o[9], &alt, &el, &az, &o[10], &method, &nthreads,
                          &rows_obj))
        return NULL;
    buf_t rb;
    memset(&rb, 0, sizeof(rb));
    buf_t b[11];
    memset(b, 0, sizeof(b));
    const Py_ssize_t isz[11] = {4, 4, 4, 8, 8, 8, 8, 8, 8, 8, 0};
    const int wr[11] = {0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1};
    const char *names[11] = {"sun", "zen", "emph", "sun_breaks", "zen_breaks", "emph_breaks",
                             "cfg_base", "cfg_w", "channels", "dirs", "out"};
    PyObject *ret = NULL;
    for (int i = 0; i < 11; ++i) {
        if (i == 10) {
            if (PyObject_GetBuffer(o[10], &b[10].b, PyBUF_WRITABLE | PyBUF_C_CONTIGUOUS | PyBUF_FORMAT) < 0)
                goto done;
            b[10].held = 1;
            if (b[10].b.itemsize != 4 && b[10].b.itemsize != 8) {
                PyErr_SetString(PyExc_TypeError, "out must be float32 or float64");
                goto done;
            }
            continue;
        }
        if (get_buf(o[i], &b[i], wr[i], names[i], isz[i]) < 0) goto done;
    }
    {
        int ns = (int)(b[3].b.len / 8), nz = (int)(b[4].b.len / 8), ne = (int)(b[5].b.len / 8);
        int ncfg = (int)(b[6].b.len / 8), nc = (int)(b[8].b.len / 8);
        Py_ssize_t n = b[9].b.len / 24;
        int is_double = b[10].b.itemsize == 8;
        comp_t m = {(const float *)b[0].b.buf, (const float *)b[1].b.buf,
                    b[2].held ? (const float *)b[2].b.buf : NULL,
                    (const double *)b[3].b.buf, (const double *)b[4].b.buf,
                    b[5].held ? (const double *)b[5].b.buf : NULL, ns, nz, ne, rank,
                    b[2].held ? 1 : 0, nch};
        const int64_t *rows = NULL;
        Py_ssize_t out_rows = nc ? b[10].b.len / b[10].b.itemsize / nc : 0;
        if (get_buf(rows_obj, &rb, 0, "rows", 8) < 0) goto done;
        if (rb.held) {
            rows = (const int64_t *)rb.b.buf;
            if (rb.b.len / 8 != n) {
                PyErr_SetString(PyExc_ValueError, "radiance kernel: one row per direction");
                goto done;
            }
            for (Py_ssize_t i = 0; i < n; ++i)
                if (rows[i] < 0 || rows[i] >= out_rows) {
                    PyErr_SetString(PyExc_ValueError, "radiance kernel: row outside the output");
                    goto done;
                }
        }
        if (ns < 2 || nz < 2 || (m.emph && ne < 2) || b[7].b.len / 8 != ncfg ||
            (rows ? b[10].b.len / b[10].b.itemsize != out_rows * (Py_ssize_t)nc
                  : b[10].b.len / b[10].b.itemsize != n * (Py_ssize_t)nc)) {
            PyErr_SetString(PyExc_ValueError, "radiance kernel: inconsistent array sizes");
            goto done;
        }
        geom_t geo;
        geom_init(&geo, alt, el, az);
        double sign = m.emph ? 1.0 : -1.0;
        int use_table = method == 2 || (method == 0 && n * (Py_ssize_t)nc >= 20000);
        if (method == 0 && !use_table && !(m.emph && geo.use_shadow) && n * (Py_ssize_t)nc >= 256)
            use_table = table_pays(&m, &geo, (const double *)b[9].b.buf, n, ncfg, nc);
        int twilight = use_table && m.emph && geo.use_shadow;
        int err = 0;
        Py_ssize_t nmix = 0, nvisited = 0;
        dcache_t *dc = NULL; /* the direct path's cached coefficient copy */
        if (!use_table) dc = dcache_get(&m, o, (const int64_t *)b[6].b.buf, (const double *)b[7].b.buf, ncfg,
                                        (const int64_t *)b[8].b.buf, nc);
        Py_BEGIN_ALLOW_THREADS
        set_threads(nthreads);
        if (twilight) {
            err = twilight_eval(&m, &geo, (const int64_t *)b[6].b.buf, (const double *)b[7].b.buf, ncfg,
                                (const int64_t *)b[8].b.buf, nc, (const double *)b[9].b.buf, n, b[10].b.buf,
                                is_double, rows, &nvisited, &nmix);
            if (err == 1) { /* too many cells or an ill-conditioned one: the direct path */
                err = 0;
                use_table = twilight = 0;
                radiance_direct(&m, &geo, (const int64_t *)b[6].b.buf, (const double *)b[7].b.buf, ncfg,
                                (const int64_t *)b[8].b.buf, nc, (const double *)b[9].b.buf, n, b[10].b.buf,
                                is_double, sign, rows, NULL);
            }
        } else if (use_table) {
            table_t t;
            err = table_build_signed(&t, &m, (const int64_t *)b[6].b.buf, (const double *)b[7].b.buf, ncfg,
                                     (const int64_t *)b[8].b.buf, nc, sign, &geo, (const double *)b[9].b.buf, n);
            if (err == 1) { /* ill-conditioned cell: the direct path instead */
                err = 0;
                use_table = 0;
                radiance_direct(&m, &geo, (const int64_t *)b[6].b.buf, (const double *)b[7].b.buf, ncfg,
                                (const int64_t *)b[8].b.buf, nc, (const double *)b[9].b.buf, n, b[10].b.buf,
                                is_double, sign, rows, NULL);
            } else if (!err) {
                nmix = t.nmix;
                err = table_eval(&t, &geo, (const double *)b[9].b.buf, n, b[10].b.buf, is_double, rows);
                table_free(&t);
            }
        } else {
            radiance_direct(&m, &geo, (const int64_t *)b[6].b.buf, (const double *)b[7].b.buf, ncfg,
                            (const int64_t *)b[8].b.buf, nc, (const double *)b[9].b.buf, n, b[10].b.buf,
                            is_double, sign, rows, dc);
        }
        Py_END_ALLOW_THREADS
        dcache_put(dc);
        if (err) {
            PyErr_NoMemory();
            goto done;
        }
        ret = Py_BuildValue("inn", twilight ? 3 : (use_table ? 2 : 1), nmix, nvisited);
    }
done:
    for (int i = 0; i < 11; ++i) rel_buf(&b[i]);
    rel_buf(&rb);
    return ret;
}

/* check_dirs(dirs float64 (n, 3) C-contiguous) -> index of the first direction whose squared length
 * x^2 + y^2 + z^2 is not finite and positive (NaN, infinity, overflow or the zero vector), or -1. One pass
 * without temporaries (the evaluator's argument check). */
static PyObject *py_check_dirs(PyObject *self, PyObject *args)
{
    PyObject *o;
    if (!PyArg_ParseTuple(args, "O", &o)) return NULL;
    buf_t b;
    memset(&b, 0, sizeof(b));
    if (get_buf(o, &b, 0, "dirs", 8) < 0) {
        rel_buf(&b);
        return NULL;
    }
    const double *v = (const double *)b.b.buf;
    const Py_ssize_t n = b.b.len / 24;
    Py_ssize_t bad = -1;
    Py_BEGIN_ALLOW_THREADS
    const Py_ssize_t blk = 1024;
    for (Py_ssize_t i0 = 0; i0 < n && bad < 0; i0 += blk) {
        const Py_ssize_t i1 = i0 + blk < n ? i0 + blk : n;
        int any = 0;
        for (Py_ssize_t i = i0; i < i1; ++i) {
            const double n2 = v[3 * i] * v[3 * i] + v[3 * i + 1] * v[3 * i + 1] + v[3 * i + 2] * v[3 * i + 2];
            any |= !(n2 > 0.0 && n2 <= 1.7976931348623157e308);
        }
        if (any)
            for (Py_ssize_t i = i0; i < i1; ++i) {
                const double n2 = v[3 * i] * v[3 * i] + v[3 * i + 1] * v[3 * i + 1] + v[3 * i + 2] * v[3 * i + 2];
                if (!(n2 > 0.0 && n2 <= 1.7976931348623157e308)) {
                    bad = i;
                    break;
                }
            }
    }
    Py_END_ALLOW_THREADS
    rel_buf(&b);
    return PyLong_FromSsize_t(bad);
}

/* accel_init's bucket count on the distinct knots of a[0..na) and b[0..nb) merged (both ascending; b may be
 * NULL): the size of the cell-lookup index table_eval builds at every call */
static double accel_buckets(const double *a, int na, const double *b, int nb)
{
    int i = 0, j = 0, cnt = 0;
    double first = 0.0, prev = 0.0, dmin = INFINITY;
    while (i < na || j < nb) {
        const double q = (j >= nb || (i < na && a[i] <= b[j])) ? a[i++] : b[j++];
        if (cnt == 0) {
            first = q, cnt = 1;
        } else if (q > prev) {
            dmin = q - prev < dmin ? q - prev : dmin;
            ++cnt;
        }
        prev = q;
    }
    const double span = prev - first;
    dmin = dmin < span ? dmin : span;
    const double want = dmin > 0 ? 8.0 * span / dmin : 0.0;
    return want > 65536.0 ? 65536.0 : (want > 8.0 * cnt ? (double)(int)want : 8.0 * cnt);
}

/* auto's choice for a smaller call (sun above the horizon): the table when building the cells in the range
 * of the call's angles and evaluating them costs less than the direct path. CPU times [ns] fitted (least
 * squares of the relative error, non-negative) to 480 timed calls, one thread (benchmarks/bench_sky.py
 * --fit-auto: random calls of 1 to 55 channels, 8 to 5,000 directions and 256 to 20,000 values in clusters
 * 0.5 to 30 deg wide anywhere above the horizon, sun at 5 to 70 deg; the embedded dataset, the 61 MB
 * benchmark dataset and the tests' small one). Table: per (channel, configuration) its zenith and emphasis
 * factors at the padded merged knot columns in range, 1.0 per (column, R + 1), and per sun row their rank
 * sums and corner products, 0.104 per (column, row, R + 8); 0.46 per value, 13.6 per direction; 19.9 us a
 * call and 1.12 per bucket of the cell lookups' index (accel_init: up to 65,536 per knot set, 27-45 us on
 * the benchmark and embedded datasets). Direct, with its kept copy of the coefficients (a repeated state, as
 * calls in a sequence of sky states are): per (direction, configuration, 3 R + 4) and vector of channels,
 * AVX2 kernel 0.163 per four channels, AVX-512 kernel 0.242 per eight and 0.160 for a last four; per
 * (direction, configuration) 4.2 (AVX2) or 4.4 (AVX-512); per direction 38 or 46; 18.0 or 17.5 us a call.
 * Without AVX2 (not refitted): 0.22 per (value, configuration, 3 R + 4) and the AVX2 kernel's other terms.
 * Checked by benchmarks/bench_sky.py --auto-sweep (other calls). Both paths give the reference's values to
 * rounding. */
static int table_pays(const comp_t *m, const geom_t *geo, const double *dirs, Py_ssize_t n, int ncfg, int nc)
{
    double rg[4];
    angle_range(geo, dirs, n, rg);
    if (!(isfinite(rg[0]) && isfinite(rg[1]) && isfinite(rg[2]) && isfinite(rg[3]))) return 0;
    /* sun rows in range plus the margin table_build_signed adds; merged zenith/emphasis columns in range
     * (at most the sum of both knot sets' intervals), padded as the build pads them (whole vectors + 8) */
    const double rows = interval_of(rg[1], m->sb, m->ns) - interval_of(rg[0], m->sb, m->ns) + 3;
    const double zcols = interval_of(rg[3], m->zb, m->nz) - interval_of(rg[2], m->zb, m->nz);
    double cols = zcols + 3;
    if (m->emph) cols += interval_of(rg[3], m->eb, m->ne) - interval_of(rg[2], m->eb, m->ne);
    const int nup = (m->nz + (m->emph ? m->ne : 0) + 7) & ~3;
    const double pad = cols + 7 < nup ? cols + 7 : nup;
    const double R = m->rank, w = (double)nc * ncfg * pad, dn = (double)n;
    const double buckets = accel_buckets(m->sb, m->ns, NULL, 0) +
                           accel_buckets(m->zb, m->nz, m->emph ? m->eb : NULL, m->emph ? m->ne : 0);
    const double table = 1.0 * w * (R + 1) + 0.104 * w * rows * (R + 8) + 0.46 * dn * nc + 13.6 * dn + 19900.0 +
                         1.12 * buckets;
    const double per_cfg = dn * ncfg * (3 * R + 4); /* the kernel's work per channel vector */
    double direct = 0.22 * per_cfg * nc + 4.2 * dn * ncfg + 38.0 * dn + 18000.0;
#ifdef DIRECT_VEC
    if (direct_vec_ok()) {
        const int nc4 = 4 * ((nc + 3) / 4), c4 = nc4 & 4;
        if (direct_use_512())
            direct = 0.242 * per_cfg * ((nc4 - c4) / 8) + 0.160 * per_cfg * (c4 / 4) + 4.4 * dn * ncfg + 46.0 * dn +
                     17500.0;
        else
            direct = 0.163 * per_cfg * (nc4 / 4) + 4.2 * dn * ncfg + 38.0 * dn + 18000.0;
    }
#endif
    return table < direct;
}

/* transmittance(U, V, ddim, adim, nalt, rank, nch, pair_vis, pair_alt, pair_w, chi, dirs, altitude,
 *               distance, out, nthreads): squared interpolated sqrt-transmittance.
 * dirs: view directions (only their zenith angle matters); altitude: the altitude parameter [m]
 * (observer altitude + safety altitude); distance [m] (inf = to the top of the atmosphere). */
static PyObject *py_transmittance(PyObject *self, PyObject *args)
{
    PyObject *o[8];
    int ddim, adim, nalt, rank, nch, nthreads;
    double h, dist;
    if (!PyArg_ParseTuple(args, "OOiiiiiOOOOOddOi", &o[0], &o[1], &ddim, &adim, &nalt, &rank, &nch, &o[2],
                          &o[3], &o[4], &o[5], &o[6], &h, &dist, &o[7], &nthreads))
        return NULL;
    buf_t b[8];
    memset(b, 0, sizeof(b));
    const Py_ssize_t isz[7] = {4, 4, 8, 8, 8, 8, 8};
    const char *names[7] = {"U", "V", "pair_vis", "pair_alt", "pair_w", "channels", "dirs"};
    PyObject *ret = NULL;
    for (int i = 0; i < 7; ++i)
        if (get_buf(o[i], &b[i], 0, names[i], isz[i]) < 0) goto done;
    if (PyObject_GetBuffer(o[7], &b[7].b, PyBUF_WRITABLE | PyBUF_C_CONTIGUOUS | PyBUF_FORMAT) < 0) goto done;
    b[7].held = 1;
    {
        int np_ = (int)(b[2].b.len / 8), nc = (int)(b[5].b.len / 8);
        Py_ssize_t n = b[6].b.len / 24;
        int is_double = b[7].b.itemsize == 8;
        if ((b[7].b.itemsize != 4 && b[7].b.itemsize != 8) || b[7].b.len / b[7].b.itemsize != n * (Py_ssize_t)nc ||
            b[3].b.len / 8 != np_ || b[4].b.len / 8 != np_) {
            PyErr_SetString(PyExc_ValueError, "transmittance kernel: inconsistent array sizes");
            goto done;
        }
        trans_t T = {(const float *)b[0].b.buf, (const float *)b[1].b.buf, ddim, adim, nalt, rank, nch};
        const int64_t *pv = b[2].b.buf, *pa = b[3].b.buf, *chi = b[5].b.buf;
        const double *pw = b[4].b.buf, *dirs = b[6].b.buf;
        void *out = b[7].b.buf;
        Py_BEGIN_ALLOW_THREADS
        set_threads(nthreads);
        Py_ssize_t i;
#pragma omp parallel for schedule(static) if (n * (Py_ssize_t)nc * np_ >= PAR_MIN_WORK / 8)
        for (i = 0; i < n; ++i) {
            const double *v = dirs + 3 * i;
            double nv = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
            if (nv < DBL_EPSILON_) nv = DBL_EPSILON_;
            double theta = acos(clamp_unit(v[2] / nv));
            ip_t ap, dp;
            trans_location(theta, h, dist, adim, ddim, &ap, &dp);
            for (int k = 0; k < nc; ++k) {
                double s = 0.0;
                for (int p = 0; p < np_; ++p)
                    s += pw[p] * trans_reconstruct(&T, (int)pv[p], (int)pa[p], (int)chi[k], ap, dp);
                put(out, (size_t)i * nc + k, s * s, is_double);
            }
        }
        Py_END_ALLOW_THREADS
        ret = Py_None;
        Py_INCREF(ret);
    }
done:
    for (int i = 0; i < 8; ++i) rel_buf(&b[i]);
    return ret;
}

/* ------------------------------------------------------------------------------------------ */
/* baseline: a straight port of the reference loop, one direction and one channel per call     */

typedef struct {
    const double *vis, *alb, *alt, *ele;
    int nvis, nalb, nalt, nele;
} grids_t;

static double ref_interpolate(const comp_t *m, const grids_t *G, const ip_t *lv, size_t base_off[4],
                              int level, size_t cfg_off, int ch, ip_t g, ip_t a, ip_t z)
{
    /* levels: 0 visibility, 1 albedo, 2 altitude, 3 elevation */
    if (level == 4) return eval_config(m, cfg_off * m->nch + ch, g, a, z);
    const int sizes[4] = {G->nvis, G->nalb, G->nalt, G->nele};
    int lo = lv[level].idx, hi = lo + 1 < sizes[level] ? lo + 1 : sizes[level] - 1;
    double rl = ref_interpolate(m, G, lv, base_off, level + 1, cfg_off + lo * base_off[level], ch, g, a, z);
    if (lv[level].f < 1e-6) return rl;
    double rh = ref_interpolate(m, G, lv, base_off, level + 1, cfg_off + hi * base_off[level], ch, g, a, z);
    return (1 - lv[level].f) * rl + lv[level].f * rh;
}

/* reference_loop(sun, zen, emph, sb, zb, eb, rank, nch, vis, alb, alt, ele, dirs, state(alt, el, az,
 *                visibility, albedo), channels, out) -- single-threaded baseline */
static PyObject *py_reference_loop(PyObject *self, PyObject *args)
{
    PyObject *o[13];
    int rank, nch;
    double alt, el, az, vis, alb;
    if (!PyArg_ParseTuple(args, "OOOOOOiiOOOOO(ddddd)OO", &o[0], &o[1], &o[2], &o[3], &o[4], &o[5], &rank, &nch,
                          &o[6], &o[7], &o[8], &o[9], &o[10], &alt, &el, &az, &vis, &alb, &o[11], &o[12]))
        return NULL;
    buf_t b[13];
    memset(b, 0, sizeof(b));
    const Py_ssize_t isz[12] = {4, 4, 4, 8, 8, 8, 8, 8, 8, 8, 8, 8};
    PyObject *ret = NULL;
    for (int i = 0; i < 12; ++i)
        if (get_buf(o[i], &b[i], 0, "arg", isz[i]) < 0) goto done;
    if (get_buf(o[12], &b[12], 1, "out", 8) < 0) goto done;
    {
        comp_t m = {b[0].b.buf, b[1].b.buf, b[2].b.buf, b[3].b.buf, b[4].b.buf, b[5].b.buf,
                    (int)(b[3].b.len / 8), (int)(b[4].b.len / 8), (int)(b[5].b.len / 8), rank, 1, nch};
        grids_t G = {b[6].b.buf, b[7].b.buf, b[8].b.buf, b[9].b.buf, (int)(b[6].b.len / 8),
                     (int)(b[7].b.len / 8), (int)(b[8].b.len / 8), (int)(b[9].b.len / 8)};
        const double *dirs = b[10].b.buf;
        const int64_t *chi = b[11].b.buf;
        int nc = (int)(b[11].b.len / 8);
        Py_ssize_t n = b[10].b.len / 24;
        double *out = b[12].b.buf;
        if (b[12].b.len / 8 != n * nc) {
            PyErr_SetString(PyExc_ValueError, "reference_loop: inconsistent sizes");
            goto done;
        }
        size_t off[4];
        off[3] = 1;
        off[2] = (size_t)G.nele;
        off[1] = off[2] * G.nalt;
        off[0] = off[1] * G.nalb;
        Py_BEGIN_ALLOW_THREADS
        for (Py_ssize_t i = 0; i < n; ++i) {
            /* computeParameters per direction */
            geom_t geo;
            geom_init(&geo, alt, el, az);
            angles_t a = compute_angles(dirs + 3 * i, &geo, 1, 1);
            double elevation = 0.5 * M_PI - acos(clamp_unit(geo.s[2]));
            double altitude = geo.d - PLANET_RADIUS;
            if (altitude < 0) altitude = 0;
            for (int k = 0; k < nc; ++k) {
                /* skyRadiance(params, channel): everything looked up anew per call */
                ip_t g = knot_lookup(a.gamma, m.sb, m.ns);
                ip_t al = knot_lookup(elevation < 0 ? a.shadow : a.zero, m.zb, m.nz);
                ip_t z = knot_lookup(a.zero, m.eb, m.ne);
                ip_t lv[4];
                lv[0] = knot_lookup(vis, G.vis, G.nvis);
                lv[1] = knot_lookup(alb, G.alb, G.nalb);
                lv[2] = knot_lookup(altitude, G.alt, G.nalt);
                lv[3] = knot_lookup(elevation * 180.0 / M_PI, G.ele, G.nele);
                out[(size_t)i * nc + k] = ref_interpolate(&m, &G, lv, off, 0, 0, (int)chi[k], g, al, z);
            }
        }
        Py_END_ALLOW_THREADS
        ret = Py_None;
        Py_INCREF(ret);
    }
done:
    for (int i = 0; i < 13; ++i) rel_buf(&b[i]);
    return ret;
}

/* ------------------------------------------------------------------------------------------ */
/* renderer helpers                                                                           */

/* pixel centre coordinate of column/row j of an n-pixel image, in [-1, 1] */
static inline double px_coord(Py_ssize_t j, Py_ssize_t n) { return ((double)j + 0.5) / (double)n * 2.0 - 1.0; }

static inline int in_disc(Py_ssize_t i, Py_ssize_t j, Py_ssize_t n)
{
    double x = px_coord(j, n), y = -px_coord(i, n);
    return x * x + y * y <= 1.0;
}

/* Columns [j0, j1) of row i inside the unit disc (x^2 + y^2 <= 1 exactly as evaluated per pixel: the set is
 * contiguous because the computed x is monotone in j). Starts from the analytic chord, then adjusts. */
static void disc_span(Py_ssize_t i, Py_ssize_t n, Py_ssize_t *j0, Py_ssize_t *j1)
{
    double y = -px_coord(i, n), h2 = 1.0 - y * y;
    double h = h2 > 0 ? sqrt(h2) : 0.0;
    Py_ssize_t a = (Py_ssize_t)floor((1.0 - h) * 0.5 * n), b = (Py_ssize_t)ceil((1.0 + h) * 0.5 * n);
    if (a < 0) a = 0;
    if (a > n) a = n;
    if (b > n) b = n;
    if (b < a) b = a;
    while (a > 0 && in_disc(i, a - 1, n)) --a;
    while (a < n && !in_disc(i, a, n)) ++a;
    if (b < a) b = a;
    while (b < n && in_disc(i, b, n)) ++b;
    while (b > a && !in_disc(i, b - 1, n)) --b;
    *j0 = a;
    *j1 = b;
}

/* fisheye_counts(n, counts_out int64[n]): pixels of each image row inside the unit disc (x^2 + y^2 <= 1) */
static PyObject *py_fisheye_counts(PyObject *self, PyObject *args)
{
    Py_ssize_t n;
    PyObject *o;
    if (!PyArg_ParseTuple(args, "nO", &n, &o)) return NULL;
    buf_t b;
    if (get_buf(o, &b, 1, "counts", 8) < 0) return NULL;
    if (b.b.len / 8 != n) {
        rel_buf(&b);
        PyErr_SetString(PyExc_ValueError, "fisheye_counts: counts must have n entries");
        return NULL;
    }
    int64_t *cnt = b.b.buf;
    for (Py_ssize_t i = 0; i < n; ++i) {
        Py_ssize_t j0, j1;
        disc_span(i, n, &j0, &j1);
        cnt[i] = (int64_t)(j1 - j0);
    }
    rel_buf(&b);
    Py_RETURN_NONE;
}

/* fisheye(n, basis float64[9] (axis, right, up), row_start int64[n+1], dirs float64[m][3], pix int64[m]):
 * stereographic fisheye directions of the pixels inside the unit disc, row by row (theta = 2 atan(rho):
 * cos theta = (1 - rho^2) / (1 + rho^2), sin theta = 2 rho / (1 + rho^2)), and their flat pixel index. */
static PyObject *py_fisheye(PyObject *self, PyObject *args)
{
    Py_ssize_t n;
    PyObject *o[4];
    if (!PyArg_ParseTuple(args, "nOOOO", &n, &o[0], &o[1], &o[2], &o[3])) return NULL;
    buf_t b[4];
    memset(b, 0, sizeof(b));
    const Py_ssize_t isz[4] = {8, 8, 8, 8};
    const int wr[4] = {0, 0, 1, 1};
    PyObject *ret = NULL;
    for (int i = 0; i < 4; ++i)
        if (get_buf(o[i], &b[i], wr[i], "fisheye", isz[i]) < 0) goto done;
    {
        const double *B = b[0].b.buf;
        const int64_t *start = b[1].b.buf;
        double *dirs = b[2].b.buf;
        int64_t *pix = b[3].b.buf;
        Py_ssize_t m = b[3].b.len / 8;
        if (b[0].b.len / 8 != 9 || b[1].b.len / 8 != n + 1 || b[2].b.len / 24 != m || start[0] != 0 ||
            start[n] != m) {
            PyErr_SetString(PyExc_ValueError, "fisheye: inconsistent sizes");
            goto done;
        }
        for (Py_ssize_t i = 0; i < n; ++i)
            if (start[i + 1] < start[i]) {
                PyErr_SetString(PyExc_ValueError, "fisheye: row starts must ascend");
                goto done;
            }
        Py_BEGIN_ALLOW_THREADS
        Py_ssize_t i;
#pragma omp parallel for schedule(static) if (n * n >= PAR_MIN_WORK)
        for (i = 0; i < n; ++i) {
            double y = -px_coord(i, n);
            Py_ssize_t k = start[i], end = start[i + 1], j0, j1;
            disc_span(i, n, &j0, &j1);
            if (j1 - j0 != end - k) j0 = j1; /* counts from another resolution: write nothing */
            for (Py_ssize_t j = j0; j < j1; ++j) {
                double x = px_coord(j, n), r2 = x * x + y * y;
                double inv = 1.0 / (1.0 + r2), ct = (1.0 - r2) * inv, sx = 2.0 * x * inv, sy = 2.0 * y * inv;
                for (int c = 0; c < 3; ++c) dirs[3 * k + c] = ct * B[c] + sx * B[3 + c] + sy * B[6 + c];
                pix[k++] = (int64_t)(i * n + j);
            }
        }
        Py_END_ALLOW_THREADS
        ret = Py_None;
        Py_INCREF(ret);
    }
done:
    for (int i = 0; i < 4; ++i) rel_buf(&b[i]);
    return ret;
}

/* float32 -> IEEE half, round to nearest even (as numpy's astype(float16)); inf and NaN kept. */
static inline uint16_t f32_to_f16(float f)
{
    uint32_t x;
    memcpy(&x, &f, 4);
    uint32_t sign = (x >> 16) & 0x8000u, ax = x & 0x7fffffffu;
    if (ax >= 0x7f800000u) return (uint16_t)(sign | 0x7c00u | (ax > 0x7f800000u ? 0x200u : 0u));
    if (ax >= 0x477ff000u) return (uint16_t)(sign | 0x7c00u); /* rounds to >= 65520: inf */
    if (ax < 0x38800000u) {                                   /* below the smallest normal half */
        if (ax < 0x33000000u) return (uint16_t)sign;          /* below half the smallest subnormal */
        uint32_t e = ax >> 23, mant = (ax & 0x7fffffu) | 0x800000u;
        uint32_t shift = 126 - e;                             /* 14..24 */
        uint32_t h = mant >> shift, rem = mant & ((1u << shift) - 1), halfway = 1u << (shift - 1);
        if (rem > halfway || (rem == halfway && (h & 1u))) ++h;
        return (uint16_t)(sign | h);
    }
    uint32_t h = ((ax >> 13) - (112u << 10)), rem = ax & 0x1fffu;
    if (rem > 0x1000u || (rem == 0x1000u && (h & 1u))) ++h;
    return (uint16_t)(sign | h);
}

/* planar(values float32[npix][nc], out (float32 or uint16 half)[nc][npix]): channel planes for an image
 * file, transposed in cache-sized tiles, half floats rounded to nearest even. */
#if defined(__FLT16_MAX__) && defined(__x86_64__)
/* the compiler's conversion (IEEE round to nearest even; vcvtps2ph in the x86-64-v3 clone) */
static inline uint16_t to_half(float f)
{
    _Float16 h = (_Float16)f;
    uint16_t u;
    memcpy(&u, &h, 2);
    return u;
}
#else
#define to_half f32_to_f16
#endif

HOT static void planar_tile(const float *v, void *out, int half, Py_ssize_t npix, int nc, Py_ssize_t p0,
                            Py_ssize_t p1)
{
    /* pixels in order (sequential reads), one write stream per channel */
    if (half) {
        uint16_t *o = (uint16_t *)out;
        for (Py_ssize_t p = p0; p < p1; ++p)
            for (int k = 0; k < nc; ++k) o[(size_t)k * npix + p] = to_half(v[(size_t)p * nc + k]);
    } else {
        float *o = (float *)out;
        for (Py_ssize_t p = p0; p < p1; ++p)
            for (int k = 0; k < nc; ++k) o[(size_t)k * npix + p] = v[(size_t)p * nc + k];
    }
}

static PyObject *py_planar(PyObject *self, PyObject *args)
{
    PyObject *o[2];
    int nc;
    if (!PyArg_ParseTuple(args, "OOi", &o[0], &o[1], &nc)) return NULL;
    buf_t b[2];
    memset(b, 0, sizeof(b));
    PyObject *ret = NULL;
    if (get_buf(o[0], &b[0], 0, "values", 4) < 0) goto done;
    if (PyObject_GetBuffer(o[1], &b[1].b, PyBUF_WRITABLE | PyBUF_C_CONTIGUOUS | PyBUF_FORMAT) < 0) goto done;
    b[1].held = 1;
    {
        int half = b[1].b.itemsize == 2;
        Py_ssize_t nv = b[0].b.len / 4;
        if (nc < 1 || nv % nc || (b[1].b.itemsize != 2 && b[1].b.itemsize != 4) ||
            b[1].b.len / b[1].b.itemsize != nv) {
            PyErr_SetString(PyExc_ValueError, "planar: inconsistent sizes or output type");
            goto done;
        }
        Py_ssize_t npix = nv / nc, tile = 2048, ntile = (npix + tile - 1) / tile, t;
        const float *v = b[0].b.buf;
        void *out = b[1].b.buf;
        Py_BEGIN_ALLOW_THREADS
#pragma omp parallel for schedule(static) if (nv >= PAR_MIN_WORK)
        for (t = 0; t < ntile; ++t) {
            Py_ssize_t p0 = t * tile, p1 = p0 + tile < npix ? p0 + tile : npix;
            planar_tile(v, out, half, npix, nc, p0, p1);
        }
        Py_END_ALLOW_THREADS
        ret = Py_None;
        Py_INCREF(ret);
    }
done:
    for (int i = 0; i < 2; ++i) rel_buf(&b[i]);
    return ret;
}

/* OpenEXR scanline chunks (widesky's own encoder for the uncompressed and RLE cases; file layout in
 * skymodel/exrfile.py). A chunk is one scanline: for each channel in file order, the line's W pixels as
 * little-endian half or float32. RLE, as the OpenEXR format defines it: the line's bytes split into the
 * even-indexed then the odd-indexed ones, each byte replaced by its difference from the previous one
 * plus 128 (mod 256; the first kept), then runs coded as a signed count byte: c >= 0 repeats the next
 * byte c + 1 times, c < 0 copies the next -c bytes. A chunk that would not shrink is stored raw. */

/* bytes after the split and the difference (n even: 2- or 4-byte values), read straight from the line */
HOT static void exr_predict(const uint8_t *restrict in, size_t n, uint8_t *restrict out)
{
    size_t h = n / 2;
    out[0] = in[0];
    for (size_t j = 1; j < h; ++j) out[j] = (uint8_t)(in[2 * j] - in[2 * j - 2] + 128u);
    out[h] = (uint8_t)(in[1] - in[2 * h - 2] + 128u);
    for (size_t j = 1; j < h; ++j) out[h + j] = (uint8_t)(in[2 * j + 1] - in[2 * j - 1] + 128u);
}

static inline uint64_t load64(const uint8_t *p)
{
    uint64_t x;
    memcpy(&x, p, 8);
    return x;
}

/* run-length code n bytes; out needs n + n / 127 + 1 bytes, flag n bytes of scratch. Runs of 3 or more
 * equal bytes (at most 127) become (count - 1, byte); everything between them literal blocks of at most
 * 127 bytes. flag[j] = 1 where in[j] == in[j+1] (bit 0) and in[j] == in[j+1] == in[j+2] (bit 1), computed
 * in one vectorised pass; the scans then read 8 flags at a time (little-endian hosts). */
HOT static size_t exr_rle(const uint8_t *restrict in, size_t n, uint8_t *restrict out, uint8_t *restrict flag)
{
    if (n == 0) return 0;
    for (size_t j = 0; j + 2 < n; ++j) {
        uint8_t e1 = in[j] == in[j + 1], e2 = in[j + 1] == in[j + 2];
        flag[j] = (uint8_t)(e1 | ((e1 & e2) << 1));
    }
    if (n >= 2) flag[n - 2] = in[n - 2] == in[n - 1];
    flag[n - 1] = 0;
    const uint64_t ones = 0x0101010101010101ull, twos = 0x0202020202020202ull;
    size_t i = 0, o = 0;
    while (i < n) {
        if (flag[i] & 2) { /* a run: in[i] repeats while flag bit 0 holds, at most 127 bytes */
            size_t r = 0, rmax = n - i < 127 ? n - i : 127;
            while (r + 8 <= rmax) {
                uint64_t f = load64(flag + i + r) & ones;
                if (f != ones) {
                    r += (size_t)__builtin_ctzll(~f & ones) >> 3;
                    goto counted;
                }
                r += 8;
            }
            while (r < rmax && (flag[i + r] & 1)) ++r;
        counted:
            r = r + 1 < rmax ? r + 1 : rmax; /* the last equal byte has bit 0 clear */
            out[o++] = (uint8_t)(r - 1);
            out[o++] = in[i];
            i += r;
            continue;
        }
        /* a literal up to the next run start (bit 1) or 127 bytes */
        size_t j = i + 1, jmax = n - i < 127 ? n : i + 127;
        while (j + 8 <= jmax) {
            uint64_t f = load64(flag + j) & twos;
            if (f) {
                j += (size_t)__builtin_ctzll(f) >> 3;
                goto found;
            }
            j += 8;
        }
        while (j < jmax && !(flag[j] & 2)) ++j;
    found:
        out[o++] = (uint8_t)(-(int)(j - i));
        for (size_t k = i; k < j; ++k) out[o++] = in[k];
        i = j;
    }
    return o;
}

/* float32 -> half of n values: F16C (8 at a time) where the processor has it, else to_half */
#if defined(__GNUC__) && defined(__x86_64__)
#include <immintrin.h>
__attribute__((target("avx,f16c"))) static void halves_f16c(const float *restrict v, uint16_t *restrict h, size_t n)
{
    size_t j = 0;
    for (; j + 8 <= n; j += 8)
        _mm_storeu_si128((__m128i *)(h + j),
                         _mm256_cvtps_ph(_mm256_loadu_ps(v + j), _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC));
    for (; j < n; ++j) h[j] = f32_to_f16(v[j]);
}
#define HAVE_TRANSPOSE8 1
/* out[c][0..8) = in[r * stride + c] for r, c in 0..8: eight pixels' 8 channels to 8 channel runs (SSE2) */
static inline void transpose8_u16(const uint16_t *in, size_t stride, __m128i b[8])
{
    __m128i a[8], t[8], u[8];
    for (int r = 0; r < 8; ++r) a[r] = _mm_loadu_si128((const __m128i *)(in + r * stride));
    for (int r = 0; r < 4; ++r) {
        t[2 * r] = _mm_unpacklo_epi16(a[2 * r], a[2 * r + 1]);
        t[2 * r + 1] = _mm_unpackhi_epi16(a[2 * r], a[2 * r + 1]);
    }
    for (int q = 0; q < 2; ++q)
        for (int r = 0; r < 2; ++r) {
            u[4 * q + 2 * r] = _mm_unpacklo_epi32(t[4 * q + r], t[4 * q + r + 2]);
            u[4 * q + 2 * r + 1] = _mm_unpackhi_epi32(t[4 * q + r], t[4 * q + r + 2]);
        }
    for (int r = 0; r < 4; ++r) {
        b[2 * r] = _mm_unpacklo_epi64(u[r], u[r + 4]);
        b[2 * r + 1] = _mm_unpackhi_epi64(u[r], u[r + 4]);
    }
}
#endif

static void to_halves(const float *restrict v, uint16_t *restrict h, size_t n)
{
#if defined(__GNUC__) && defined(__x86_64__)
    static int f16c = -1;
    if (f16c < 0) f16c = __builtin_cpu_supports("f16c") && __builtin_cpu_supports("avx");
    if (f16c) {
        halves_f16c(v, h, n);
        return;
    }
#endif
    for (size_t j = 0; j < n; ++j) h[j] = to_half(v[j]);
}

/* one scanline's raw bytes: channel k of the file is plane src[k] (< nc: values, else rgb src[k] - nc, or
 * without rgb a copy of plane 0; rgb holds rs >= 3 values per pixel, the first 3 used), pos[s] the file
 * position of plane s. tmp holds w * (nc + rs) + 8 halves.
 * Returns the number of values that became inf or NaN as half floats. */
HOT static Py_ssize_t exr_gather(const float *restrict v, const float *restrict rgb, int rs, int nc, const int32_t *src,
                                 const int32_t *pos, int nk, Py_ssize_t w, int half, uint8_t *restrict raw,
                                 uint16_t *restrict tmp)
{
    Py_ssize_t bad = 0, nv = w * nc;
    if (!half) {
        for (int k = 0; k < nk; ++k) {
            int s = src[k], st = s < nc || !rgb ? nc : rs;
            const float *p = s < nc ? v + s : rgb ? rgb + (s - nc) : v;
            float *o = (float *)raw + (size_t)k * w;
            for (Py_ssize_t x = 0; x < w; ++x) o[x] = p[x * st];
        }
        return 0;
    }
    uint16_t *o = (uint16_t *)raw, *trgb = tmp + nv + 8;
    to_halves(v, tmp, (size_t)nv);
    for (Py_ssize_t j = 0; j < nv; ++j) bad += (tmp[j] & 0x7c00u) == 0x7c00u;
    if (rgb) {
        to_halves(rgb, trgb, (size_t)rs * w);
        for (int c = 0; c < 3; ++c) {
            uint16_t *q = o + (size_t)pos[nc + c] * w;
            for (Py_ssize_t x = 0; x < w; ++x) {
                q[x] = trgb[rs * x + c];
                bad += (q[x] & 0x7c00u) == 0x7c00u;
            }
        }
    }
    Py_ssize_t x = 0;
#ifdef HAVE_TRANSPOSE8
    for (; x + 8 <= w; x += 8)
        for (int s0 = 0; s0 < nc; s0 += 8) { /* the last group reads past the pixel (tmp has slack), keeps nc - s0 */
            __m128i b[8];
            transpose8_u16(tmp + x * nc + s0, (size_t)nc, b);
            for (int c = 0; c < 8 && s0 + c < nc; ++c) _mm_storeu_si128((__m128i *)(o + (size_t)pos[s0 + c] * w + x), b[c]);
        }
#endif
    for (; x < w; ++x)
        for (int s = 0; s < nc; ++s) o[(size_t)pos[s] * w + x] = tmp[x * nc + s];
    if (!rgb)
        for (int k = 0; k < nk; ++k)
            if (src[k] >= nc) memcpy(o + (size_t)k * w, o + (size_t)pos[0] * w, 2 * (size_t)w);
    return bad;
}

/* exr_lines(values float32[h][w][nc], rgb float32[h][w][3 or 4] or None, y0, h, w, nc, src int32[nc + 3], half, rle,
 *           out uint8[h][slot], sizes int64[h], nthreads)
 * h scanlines (the image's y0 .. y0 + h - 1): the chunk of each line y (int32 y0 + y, int32 data size, data)
 * at out[y], sizes[y] its length in bytes; src is a permutation of 0 .. nc + 2, the plane of each file
 * channel (see exr_gather). slot must hold 8 + line + line / 127 + 1 bytes (line = (nc + 3) * w * (2 or 4)).
 * Returns the number of values beyond the half range (half only). */
static PyObject *py_exr_lines(PyObject *self, PyObject *args)
{
    PyObject *o[5];
    int nc, half, rle, nthreads;
    Py_ssize_t h, w, y0;
    if (!PyArg_ParseTuple(args, "OOnnniOiiOOi", &o[0], &o[1], &y0, &h, &w, &nc, &o[2], &half, &rle, &o[3], &o[4],
                          &nthreads))
        return NULL;
    buf_t b[5];
    memset(b, 0, sizeof(b));
    const Py_ssize_t isz[5] = {4, 4, 4, 1, 8};
    const int wr[5] = {0, 0, 0, 1, 1};
    PyObject *ret = NULL;
    for (int i = 0; i < 5; ++i)
        if (get_buf(o[i], &b[i], wr[i], "exr_lines", isz[i]) < 0) goto done;
    {
        const float *v = b[0].b.buf, *rgb = b[1].b.buf;
        const int32_t *src = b[2].b.buf;
        int nk = (int)(b[2].b.len / 4);
        size_t line = (size_t)nk * (size_t)w * (half ? 2 : 4), slot = h > 0 ? (size_t)b[3].b.len / (size_t)h : 0;
        int ok = nc >= 1 && h >= 0 && w >= 1 && b[0].b.len / 4 == h * w * nc && b[4].b.len / 8 == h &&
                 slot >= 8 + line + line / 127 + 1;
        int rs = h * w > 0 ? (int)(b[1].b.len / 4 / (h * w)) : 3;
        ok = ok && (rgb == NULL || ((rs == 3 || rs == 4) && b[1].b.len / 4 == h * w * rs));
        int32_t pos[4096];
        ok = ok && nk == nc + 3 && nk <= 4096;
        for (int k = 0; ok && k < nk; ++k) pos[k] = -1;
        for (int k = 0; ok && k < nk; ++k) {
            ok = src[k] >= 0 && src[k] < nk && pos[src[k]] < 0;
            if (ok) pos[src[k]] = k;
        }
        if (!ok) {
            PyErr_SetString(PyExc_ValueError, "exr_lines: inconsistent sizes or channel sources");
            goto done;
        }
        uint8_t *out = b[3].b.buf;
        int64_t *sizes = b[4].b.buf;
        Py_ssize_t bad = 0;
        int nomem = 0;
        set_threads(nthreads);
        Py_BEGIN_ALLOW_THREADS
#pragma omp parallel reduction(+ : bad) reduction(|| : nomem) if (h * w * nk >= PAR_MIN_WORK)
        {
            uint8_t *raw = malloc(line), *pred = rle ? malloc(2 * line) : NULL;
            uint16_t *tmp = half ? malloc(2 * ((size_t)w * (nc + 4) + 16)) : NULL;
            if (!raw || (rle && !pred) || (half && !tmp)) nomem = 1;
            Py_ssize_t y;
#pragma omp for schedule(dynamic, 4)
            for (y = 0; y < h; ++y) {
                if (nomem) continue;
                uint8_t *chunk = out + (size_t)y * slot, *data = chunk + 8;
                bad += exr_gather(v + (size_t)y * w * nc, rgb ? rgb + (size_t)y * w * rs : NULL, rs, nc, src, pos, nk, w,
                                  half, raw, tmp);
                size_t n = line;
                if (rle) {
                    exr_predict(raw, line, pred);
                    n = exr_rle(pred, line, data, pred + line);
                }
                if (!rle || n >= line) {
                    memcpy(data, raw, line);
                    n = line;
                }
                int32_t hdr[2] = {(int32_t)(y0 + y), (int32_t)n};
                memcpy(chunk, hdr, 8);
                sizes[y] = (int64_t)(8 + n);
            }
            free(raw);
            free(pred);
            free(tmp);
        }
        Py_END_ALLOW_THREADS
        if (nomem) {
            PyErr_NoMemory();
            goto done;
        }
        ret = PyLong_FromSsize_t(bad);
    }
done:
    for (int i = 0; i < 5; ++i) rel_buf(&b[i]);
    return ret;
}

/* colour(values float32[n][nc], weights float32[nc][4], out float32[n][4], nthreads): out = values @ weights
 * (linear sRGB and CIE Y of each pixel in one pass), accumulated in float32 */
typedef float v4f __attribute__((vector_size(16)));

/* four pixels at a time: four independent accumulator chains of (r, g, b, Y) */
HOT static void colour_rows(const float *restrict v, const float *restrict wt, float *restrict out, int nc,
                            Py_ssize_t p0, Py_ssize_t p1)
{
    Py_ssize_t p = p0;
    for (; p + 4 <= p1; p += 4) {
        v4f a0 = {0}, a1 = {0}, a2 = {0}, a3 = {0};
        const float *x = v + (size_t)p * nc;
        for (int c = 0; c < nc; ++c) {
            v4f wc;
            memcpy(&wc, wt + 4 * c, 16);
            a0 += x[c] * wc;
            a1 += x[nc + c] * wc;
            a2 += x[2 * nc + c] * wc;
            a3 += x[3 * nc + c] * wc;
        }
        memcpy(out + 4 * (size_t)p, &a0, 16);
        memcpy(out + 4 * (size_t)p + 4, &a1, 16);
        memcpy(out + 4 * (size_t)p + 8, &a2, 16);
        memcpy(out + 4 * (size_t)p + 12, &a3, 16);
    }
    for (; p < p1; ++p) {
        v4f a = {0};
        for (int c = 0; c < nc; ++c) {
            v4f wc;
            memcpy(&wc, wt + 4 * c, 16);
            a += v[(size_t)p * nc + c] * wc;
        }
        memcpy(out + 4 * (size_t)p, &a, 16);
    }
}

static PyObject *py_colour(PyObject *self, PyObject *args)
{
    PyObject *o[3];
    int nthreads;
    if (!PyArg_ParseTuple(args, "OOOi", &o[0], &o[1], &o[2], &nthreads)) return NULL;
    buf_t b[3];
    memset(b, 0, sizeof(b));
    const int wr[3] = {0, 0, 1};
    PyObject *ret = NULL;
    for (int i = 0; i < 3; ++i)
        if (get_buf(o[i], &b[i], wr[i], "colour", 4) < 0) goto done;
    {
        Py_ssize_t nc = b[1].b.len / 16, n = b[2].b.len / 16, t, tile = 4096;
        if (nc < 1 || b[1].b.len != 16 * nc || b[0].b.len != 4 * n * nc) {
            PyErr_SetString(PyExc_ValueError, "colour: inconsistent sizes");
            goto done;
        }
        const float *v = b[0].b.buf, *wt = b[1].b.buf;
        float *out = b[2].b.buf;
        set_threads(nthreads);
        Py_BEGIN_ALLOW_THREADS
#pragma omp parallel for schedule(static) if (n * nc >= PAR_MIN_WORK)
        for (t = 0; t < (n + tile - 1) / tile; ++t)
            colour_rows(v, wt, out, (int)nc, t * tile, (t + 1) * tile < n ? (t + 1) * tile : n);
        Py_END_ALLOW_THREADS
        ret = Py_None;
        Py_INCREF(ret);
    }
done:
    for (int i = 0; i < 3; ++i) rel_buf(&b[i]);
    return ret;
}

/* encode8(linear float32[n][stride], m, scale, table uint8[65536], out uint8[n][m], nthreads): the first m
 * values of each pixel times scale, clipped to [0, 1] (NaN to 0), rounded to 16 bits and looked up in the
 * sRGB table: the 8-bit display image in one pass */
static PyObject *py_encode8(PyObject *self, PyObject *args)
{
    PyObject *o[3];
    int m, nthreads;
    float scale;
    if (!PyArg_ParseTuple(args, "OifOOi", &o[0], &m, &scale, &o[1], &o[2], &nthreads)) return NULL;
    buf_t b[3];
    memset(b, 0, sizeof(b));
    const Py_ssize_t isz[3] = {4, 1, 1};
    const int wr[3] = {0, 0, 1};
    PyObject *ret = NULL;
    for (int i = 0; i < 3; ++i)
        if (get_buf(o[i], &b[i], wr[i], "encode8", isz[i]) < 0) goto done;
    {
        Py_ssize_t n = m > 0 ? b[2].b.len / m : 0, stride = n > 0 ? b[0].b.len / 4 / n : 0, p;
        if (m < 1 || b[1].b.len != 65536 || b[2].b.len != n * m || stride < m || b[0].b.len != 4 * n * stride) {
            PyErr_SetString(PyExc_ValueError, "encode8: inconsistent sizes");
            goto done;
        }
        const float *v = b[0].b.buf;
        const uint8_t *table = b[1].b.buf;
        uint8_t *out = b[2].b.buf;
        set_threads(nthreads);
        Py_BEGIN_ALLOW_THREADS
#pragma omp parallel for schedule(static) if (n * m >= PAR_MIN_WORK)
        for (p = 0; p < n; ++p)
            for (int k = 0; k < m; ++k) {
                float x = v[p * stride + k] * scale;
                x = x > 0.f ? (x < 1.f ? x : 1.f) : 0.f;
                out[p * m + k] = table[(uint16_t)(x * 65535.f + 0.5f)];
            }
        Py_END_ALLOW_THREADS
        ret = Py_None;
        Py_INCREF(ret);
    }
done:
    for (int i = 0; i < 3; ++i) rel_buf(&b[i]);
    return ret;
}

/* ------------------------------------------------------------------------------------------ */
/* dataset decoding                                                                           */

/* Half -> float32 for the decoder. Two implementations that give the same bits for all 65,536 half
 * patterns (tests/test_dataset_decode.py checks it): F16C (vcvtph2ps, 8 values per instruction), picked at
 * run time where the processor and OS support it, and a 64k-entry table elsewhere. The conversion is exact
 * (every half is a float32); a signalling NaN comes out quiet (quiet bit set, payload kept), as vcvtph2ps
 * and the reference's float(double(half)) both give it. */
static float half_table[65536];
static void half_table_init(void)
{
    for (uint32_t h = 0; h < 65536; ++h) {
        uint32_t sgn = (h & 0x8000u) << 16, e = (h >> 10) & 0x1fu, m = h & 0x3ffu, x;
        float f;
        if (e == 0) {
            f = (float)m * 5.9604644775390625e-8f; /* m * 2^-24: zero or subnormal, exact */
            memcpy(&x, &f, 4);
            x |= sgn;
        } else if (e == 31) {
            x = sgn | 0x7f800000u | (m << 13) | (m ? 0x00400000u : 0u); /* inf, or NaN made quiet */
        } else {
            x = sgn | ((e + 112u) << 23) | (m << 13);
        }
        memcpy(&f, &x, 4);
        half_table[h] = f;
    }
}

static inline int finite_f(float f) { return isfinite(f); }

static inline uint16_t load_u16(const unsigned char *p)
{
    uint16_t v;
    memcpy(&v, p, 2);
    return v;
}

/* One radiance block: rank x (sun halves, zenithScale, zenith halves), then the emphasis halves; zenith
 * values are float32(double(half) / zenithScale), the division in double as the reference does it.
 * Returns 0, or the code of the first problem (1 scale, 2 sun, 3 zenith, 4 emphasis), checked in that
 * order rank by rank. Table version (any processor). */
static int decode_block_table(const unsigned char *blk, int rank, int ns, int nz, int ne, float *restrict so,
                              float *restrict zo, float *restrict eo)
{
    const size_t rank_bytes = 2 * (size_t)ns + 8 + 2 * (size_t)nz;
    for (int r = 0; r < rank; ++r) {
        const unsigned char *p = blk + (size_t)r * rank_bytes, *pz = p + 2 * (size_t)ns + 8;
        double scale;
        memcpy(&scale, p + 2 * (size_t)ns, 8);
        if (!isfinite(scale) || scale == 0.0) return 1;
        float *restrict s = so + (size_t)r * ns, *restrict z = zo + (size_t)r * nz;
        int bad = 0;
        for (int j = 0; j < ns; ++j) {
            s[j] = half_table[load_u16(p + 2 * (size_t)j)];
            bad |= !finite_f(s[j]);
        }
        if (bad) return 2;
        for (int j = 0; j < nz; ++j) {
            z[j] = (float)((double)half_table[load_u16(pz + 2 * (size_t)j)] / scale);
            bad |= !finite_f(z[j]);
        }
        if (bad) return 3;
    }
    const unsigned char *pe = blk + (size_t)rank * rank_bytes;
    int bad = 0;
    for (int j = 0; j < ne; ++j) {
        eo[j] = half_table[load_u16(pe + 2 * (size_t)j)];
        bad |= !finite_f(eo[j]);
    }
    return bad ? 4 : 0;
}

#if defined(__GNUC__) && defined(__x86_64__)
#include <immintrin.h>
#define HAVE_F16C_DECODE 1
#define F16C_FN __attribute__((target("avx,f16c"))) static inline

/* lanes of v that are inf or NaN: not (|v| <= FLT_MAX), unordered compares true */
F16C_FN __m256 nonfinite_ps(__m256 v)
{
    const __m256 abs_mask = _mm256_castsi256_ps(_mm256_set1_epi32(0x7fffffff));
    return _mm256_cmp_ps(_mm256_and_ps(v, abs_mask), _mm256_set1_ps(3.4028234663852886e38f), _CMP_NLE_UQ);
}

/* 8 halves (the first n valid, n <= 8; the others read as zeros) */
F16C_FN __m256 load8_halves(const unsigned char *p, int n)
{
    if (n == 8) return _mm256_cvtph_ps(_mm_loadu_si128((const __m128i *)p));
    uint16_t t[8] = {0, 0, 0, 0, 0, 0, 0, 0};
    memcpy(t, p, 2 * (size_t)n);
    return _mm256_cvtph_ps(_mm_loadu_si128((const __m128i *)t));
}

F16C_FN void store8(float *o, __m256 v, int n)
{
    if (n == 8) {
        _mm256_storeu_ps(o, v);
        return;
    }
    float t[8];
    _mm256_storeu_ps(t, v);
    memcpy(o, t, 4 * (size_t)n);
}

/* n halves to float32; returns nonzero if any is inf or NaN */
F16C_FN int halves_run(const unsigned char *p, float *restrict o, int n)
{
    __m256 bad = _mm256_setzero_ps();
    for (int j = 0; j < n; j += 8) {
        int k = n - j < 8 ? n - j : 8;
        __m256 v = load8_halves(p + 2 * (size_t)j, k);
        bad = _mm256_or_ps(bad, nonfinite_ps(v));
        store8(o + j, v, k);
    }
    return _mm256_movemask_ps(bad);
}

/* n halves to float32(double(half) / scale); returns nonzero if any result is inf or NaN */
F16C_FN int halves_scaled_run(const unsigned char *p, double scale, float *restrict o, int n)
{
    __m256 bad = _mm256_setzero_ps();
    const __m256d s = _mm256_set1_pd(scale);
    for (int j = 0; j < n; j += 8) {
        int k = n - j < 8 ? n - j : 8;
        __m256 v = load8_halves(p + 2 * (size_t)j, k);
        __m128 lo = _mm256_cvtpd_ps(_mm256_div_pd(_mm256_cvtps_pd(_mm256_castps256_ps128(v)), s));
        __m128 hi = _mm256_cvtpd_ps(_mm256_div_pd(_mm256_cvtps_pd(_mm256_extractf128_ps(v, 1)), s));
        __m256 r = _mm256_insertf128_ps(_mm256_castps128_ps256(lo), hi, 1);
        bad = _mm256_or_ps(bad, nonfinite_ps(r));
        store8(o + j, r, k);
    }
    return _mm256_movemask_ps(bad);
}

/* decode_block_table with F16C: the same values and the same return codes */
__attribute__((target("avx,f16c"))) static int decode_block_f16c(const unsigned char *blk, int rank, int ns, int nz,
                                                                  int ne, float *restrict so, float *restrict zo,
                                                                  float *restrict eo)
{
    const size_t rank_bytes = 2 * (size_t)ns + 8 + 2 * (size_t)nz;
    for (int r = 0; r < rank; ++r) {
        const unsigned char *p = blk + (size_t)r * rank_bytes;
        double scale;
        memcpy(&scale, p + 2 * (size_t)ns, 8);
        if (!isfinite(scale) || scale == 0.0) return 1;
        if (halves_run(p, so + (size_t)r * ns, ns)) return 2;
        if (halves_scaled_run(p + 2 * (size_t)ns + 8, scale, zo + (size_t)r * nz, nz)) return 3;
    }
    return halves_run(blk + (size_t)rank * rank_bytes, eo, ne) ? 4 : 0;
}

/* n halves to float32 with F16C (the test helper below) */
__attribute__((target("avx,f16c"))) static void halves_f16c_n(const uint16_t *h, float *o, size_t n)
{
    for (size_t j = 0; j < n; j += 8) {
        size_t k = n - j < 8 ? n - j : 8;
        store8(o + j, load8_halves((const unsigned char *)(h + j), (int)k), (int)k);
    }
}
#endif

/* which converter the decoder uses: 0 not decided yet, 1 table, 2 F16C */
static int decode_impl = 0;
static int decode_f16c_available(void)
{
#ifdef HAVE_F16C_DECODE
    __builtin_cpu_init();
    return __builtin_cpu_supports("avx") && __builtin_cpu_supports("f16c");
#else
    return 0;
#endif
}

typedef int (*decode_block_fn)(const unsigned char *, int, int, int, int, float *restrict, float *restrict,
                               float *restrict);
static decode_block_fn decode_block_pick(void)
{
    if (decode_impl == 0) decode_impl = decode_f16c_available() ? 2 : 1;
#ifdef HAVE_F16C_DECODE
    if (decode_impl == 2) return decode_block_f16c;
#endif
    return decode_block_table;
}

/* decode_radiance(raw, nch_file, chi, rank, ns, nz, ne, sun, zen, emph): radiance blocks of whole
 * configuration rows (raw: nrows x nch_file blocks of the file's layout) into float32 outputs for the
 * selected channels chi: sun [nrows][nsel][rank][ns], zen = float32(double(half) / zenithScale),
 * emph [nrows][nsel][ne]. Returns None, or (code, row, k) of the first bad block: 1 zero or non-finite
 * zenith scale, 2 non-finite sun, 3 non-finite zenith, 4 non-finite emphasis value. */
static PyObject *py_decode_radiance(PyObject *self, PyObject *args)
{
    PyObject *o[5];
    int nch, rank, ns, nz, ne;
    if (!PyArg_ParseTuple(args, "OiOiiiiOOO", &o[0], &nch, &o[1], &rank, &ns, &nz, &ne, &o[2], &o[3], &o[4]))
        return NULL;
    buf_t b[5];
    memset(b, 0, sizeof(b));
    const Py_ssize_t isz[5] = {1, 8, 4, 4, 4};
    const int wr[5] = {0, 0, 1, 1, 1};
    PyObject *ret = NULL;
    for (int i = 0; i < 5; ++i)
        if (get_buf(o[i], &b[i], wr[i], "decode_radiance", isz[i]) < 0) goto done;
    {
        const size_t rank_bytes = 2 * (size_t)ns + 8 + 2 * (size_t)nz;
        const size_t block = (size_t)rank * rank_bytes + 2 * (size_t)ne;
        const Py_ssize_t nsel = b[1].b.len / 8;
        const int64_t *chi = b[1].b.buf;
        if (nch < 1 || rank < 1 || ns < 1 || nz < 1 || ne < 1 || b[0].b.len % (block * nch)) {
            PyErr_SetString(PyExc_ValueError, "decode_radiance: inconsistent sizes");
            goto done;
        }
        const Py_ssize_t nrows = b[0].b.len / (block * nch);
        if (b[2].b.len / 4 != nrows * nsel * rank * ns || b[3].b.len / 4 != nrows * nsel * rank * nz ||
            b[4].b.len / 4 != nrows * nsel * ne) {
            PyErr_SetString(PyExc_ValueError, "decode_radiance: output sizes");
            goto done;
        }
        for (Py_ssize_t k = 0; k < nsel; ++k)
            if (chi[k] < 0 || chi[k] >= nch) {
                PyErr_SetString(PyExc_ValueError, "decode_radiance: channel index");
                goto done;
            }
        const unsigned char *raw = b[0].b.buf;
        float *sun = b[2].b.buf, *zen = b[3].b.buf, *emph = b[4].b.buf;
        /* One thread: the work is memory-bound and the caller reads the next chunk between calls, so a
         * parallel region per chunk left its idle threads spinning (2.5x the CPU time measured with
         * benchmarks/bench_open.py, no faster). */
        Py_ssize_t bad = -1, nq = nrows * nsel;
        int code = 0;
        const decode_block_fn dec = decode_block_pick();
        Py_BEGIN_ALLOW_THREADS
        for (Py_ssize_t q = 0; q < nq; ++q) {
            Py_ssize_t row = q / nsel, k = q % nsel;
            const unsigned char *blk = raw + ((size_t)row * nch + (size_t)chi[k]) * block;
            code = dec(blk, rank, ns, nz, ne, sun + (size_t)q * rank * ns, zen + (size_t)q * rank * nz,
                       emph + (size_t)q * ne);
            if (code) {
                bad = q;
                break;
            }
        }
        Py_END_ALLOW_THREADS
        if (bad >= 0)
            ret = Py_BuildValue("inn", code, bad / nsel, bad % nsel);
        else {
            ret = Py_None;
            Py_INCREF(ret);
        }
    }
done:
    for (int i = 0; i < 5; ++i) rel_buf(&b[i]);
    return ret;
}

/* decode_polarisation(raw, nch_file, chi, rank, nps, npz, psun, pzen): float32 polarisation blocks of
 * whole configuration rows into psun [nrows][nsel][rank][nps] and pzen [..][npz]. Returns None or
 * (row, k) of the first block with a non-finite value. */
static PyObject *py_decode_polarisation(PyObject *self, PyObject *args)
{
    PyObject *o[4];
    int nch, rank, nps, npz;
    if (!PyArg_ParseTuple(args, "OiOiiiOO", &o[0], &nch, &o[1], &rank, &nps, &npz, &o[2], &o[3])) return NULL;
    buf_t b[4];
    memset(b, 0, sizeof(b));
    const Py_ssize_t isz[4] = {1, 8, 4, 4};
    const int wr[4] = {0, 0, 1, 1};
    PyObject *ret = NULL;
    for (int i = 0; i < 4; ++i)
        if (get_buf(o[i], &b[i], wr[i], "decode_polarisation", isz[i]) < 0) goto done;
    {
        const size_t block = (size_t)rank * 4 * ((size_t)nps + npz);
        const Py_ssize_t nsel = b[1].b.len / 8;
        const int64_t *chi = b[1].b.buf;
        if (nch < 1 || rank < 1 || nps < 1 || npz < 1 || b[0].b.len % (block * nch)) {
            PyErr_SetString(PyExc_ValueError, "decode_polarisation: inconsistent sizes");
            goto done;
        }
        const Py_ssize_t nrows = b[0].b.len / (block * nch), nq = nrows * nsel;
        if (b[2].b.len / 4 != nq * rank * nps || b[3].b.len / 4 != nq * rank * npz) {
            PyErr_SetString(PyExc_ValueError, "decode_polarisation: output sizes");
            goto done;
        }
        for (Py_ssize_t k = 0; k < nsel; ++k)
            if (chi[k] < 0 || chi[k] >= nch) {
                PyErr_SetString(PyExc_ValueError, "decode_polarisation: channel index");
                goto done;
            }
        const unsigned char *raw = b[0].b.buf;
        float *ps = b[2].b.buf, *pz = b[3].b.buf;
        Py_ssize_t bad_all = -1;
        Py_BEGIN_ALLOW_THREADS
        for (Py_ssize_t q = 0; q < nq; ++q) { /* one thread, as decode_radiance */
            Py_ssize_t row = q / nsel, k = q % nsel;
            const unsigned char *blk = raw + ((size_t)row * nch + (size_t)chi[k]) * block;
            int ok = 1;
            for (int r = 0; r < rank; ++r) {
                float *so = ps + ((size_t)q * rank + r) * nps, *zo = pz + ((size_t)q * rank + r) * npz;
                const unsigned char *p = blk + (size_t)r * 4 * ((size_t)nps + npz);
                memcpy(so, p, 4 * (size_t)nps);
                memcpy(zo, p + 4 * (size_t)nps, 4 * (size_t)npz);
                for (int j = 0; j < nps; ++j) ok &= finite_f(so[j]);
                for (int j = 0; j < npz; ++j) ok &= finite_f(zo[j]);
            }
            if (!ok) {
                bad_all = q;
                break;
            }
        }
        Py_END_ALLOW_THREADS
        if (bad_all >= 0)
            ret = Py_BuildValue("nn", bad_all / nsel, bad_all % nsel);
        else {
            ret = Py_None;
            Py_INCREF(ret);
        }
    }
done:
    for (int i = 0; i < 4; ++i) rel_buf(&b[i]);
    return ret;
}

/* ------------------------------------------------------------------------------------------ */
/* the project's C port of the reference loader (benchmark baseline and cross-check)          */
/*
 * reference_load(path): the loading loop of the public reference implementation's
 * PragueSkyModel::initialize (readRadiance, readTransmittance, readPolarisation, full load; Wilkie et al.
 * 2021, Vevoda et al. 2022), ported to C from its structure for benchmarks/bench_open.py and the decoder's
 * cross-check test. As the reference does it: stdio fread segment by segment (per configuration and rank
 * the sun halves, the zenith scale, the zenith halves, then the configuration's emphasis halves, each into a
 * small temporary), every half converted on its own to double by building the double's high word (sign,
 * exponent rebiased from 15 to 1023, mantissa; a subnormal normalised one shift at a time), then cast to
 * float32 (zenith values divided by the scale first) into a freshly allocated vector that is zero-filled
 * first, as std::vector::resize does; transmittance U and V, and each polarisation segment, fread straight
 * into their zero-filled vectors. One thread, plain malloc (no huge-page advice). Returns (rad, U, V, pol or
 * None), bytearrays of float32 in the reference's memory layout: rad per configuration [rank][nSun sun
 * values, nZen zenith values] then nEmph emphasis values; pol per configuration [rankPol][nPSun, nPZen].
 * Not used by the package at run time.
 */
static double ref_double_from_half(uint16_t h)
{
    uint32_t hi = (uint32_t)(h & 0x8000u) << 16, mag = h & 0x7fffu;
    if (mag) {
        /* exponent bias 15 -> 1023 (1008 << 20 in the high word once the half sits 10 bits up); for inf and
         * NaN twice that, which makes the exponent field all ones */
        hi |= mag >= 0x7c00u ? 0x7e000000u : 0x3f000000u;
        for (; mag < 0x400u; mag <<= 1) hi -= 0x100000u; /* subnormal: one exponent step per shift */
        hi += mag << 10;
    }
    uint64_t bits = (uint64_t)hi << 32;
    double d;
    memcpy(&d, &bits, 8);
    return d;
}

/* a count (>= minimum) and that many f64 into a new array */
static int ref_counted(FILE *f, int minimum, long long fsize, double **out, int *n)
{
    if (fread(n, sizeof(int), 1, f) != 1 || *n < minimum || (long long)*n * 8 > fsize) return -1;
    *out = malloc(sizeof(double) * (size_t)*n);
    return *out && fread(*out, sizeof(double), (size_t)*n, f) == (size_t)*n ? 0 : -1;
}

/* a zero-filled float32 vector of n values as a bytearray (NULL and an exception when out of memory) */
static PyObject *ref_vector(size_t n, float **data)
{
    PyObject *o = PyByteArray_FromStringAndSize(NULL, (Py_ssize_t)(n * sizeof(float)));
    if (!o) return NULL;
    *data = (float *)PyByteArray_AS_STRING(o);
    memset(*data, 0, n * sizeof(float));
    return o;
}

static PyObject *py_reference_load(PyObject *self, PyObject *args)
{
    PyObject *path_obj = NULL;
    if (!PyArg_ParseTuple(args, "O&", PyUnicode_FSConverter, &path_obj)) return NULL;
    const char *path = PyBytes_AS_STRING(path_obj);
    FILE *f = fopen(path, "rb");
    if (!f) {
        PyErr_SetFromErrnoWithFilename(PyExc_OSError, path);
        Py_DECREF(path_obj);
        return NULL;
    }
    long long fsize = 0;
    if (fseek(f, 0, SEEK_END) == 0) fsize = ftell(f);
    rewind(f);
    PyObject *rad = NULL, *U = NULL, *V = NULL, *pol = NULL, *ret = NULL;
    double *grid[7] = {NULL, NULL, NULL, NULL, NULL, NULL, NULL}; /* vis, alb, alt, ele, sun, zen, emph */
    double *pgrid[2] = {NULL, NULL};
    float *tgrid = NULL;
    uint16_t *temp = NULL;
    int n[7], channels = 0, rank = 0;
    double channel_start, channel_width;
    const char *field = NULL;
    /* radiance metadata */
    for (int i = 0; i < 4 && !field; ++i)
        if (ref_counted(f, 1, fsize, &grid[i], &n[i]) < 0) field = "radiance grids";
    if (!field && (fread(&channels, sizeof(int), 1, f) != 1 || channels < 1)) field = "channels";
    if (!field && (fread(&channel_start, sizeof(double), 1, f) != 1 || fread(&channel_width, sizeof(double), 1, f) != 1))
        field = "channelStart/channelWidth";
    if (!field && (fread(&rank, sizeof(int), 1, f) != 1 || rank < 1)) field = "rankRad";
    for (int i = 4; i < 7 && !field; ++i)
        if (ref_counted(f, 2, fsize, &grid[i], &n[i]) < 0) field = "radiance breaks";
    if (field) goto fail;
    {
        const size_t configs = (size_t)channels * n[3] * n[2] * n[1] * n[0];
        const int ns = n[4], nz = n[5], ne = n[6];
        const size_t per_cfg = (size_t)rank * (ns + nz) + ne;
        const size_t cfg_bytes = (size_t)rank * (2 * (size_t)(ns + nz) + 8) + 2 * (size_t)ne;
        if ((double)configs * (double)cfg_bytes > (double)fsize) {
            field = "radiance coefficients (file too short)";
            goto fail;
        }
        float *data;
        if (!(rad = ref_vector(configs * per_cfg, &data))) goto done;
        int mx = ns > nz ? ns : nz;
        if (ne > mx) mx = ne;
        if (!(temp = malloc(sizeof(uint16_t) * (size_t)mx))) {
            PyErr_NoMemory();
            goto done;
        }
        Py_BEGIN_ALLOW_THREADS
        size_t off = 0;
        for (size_t c = 0; c < configs && !field; ++c) {
            for (int r = 0; r < rank; ++r) {
                if (fread(temp, sizeof(uint16_t), (size_t)ns, f) != (size_t)ns) {
                    field = "sunCoefsRad";
                    break;
                }
                for (int i = 0; i < ns; ++i) data[off++] = (float)ref_double_from_half(temp[i]);
                double scale;
                if (fread(&scale, sizeof(double), 1, f) != 1) {
                    field = "zenithScaleRad";
                    break;
                }
                if (fread(temp, sizeof(uint16_t), (size_t)nz, f) != (size_t)nz) {
                    field = "zenithCoefsRad";
                    break;
                }
                for (int i = 0; i < nz; ++i) data[off++] = (float)(ref_double_from_half(temp[i]) / scale);
            }
            if (field) break;
            if (fread(temp, sizeof(uint16_t), (size_t)ne, f) != (size_t)ne) {
                field = "emphCoefsRad";
                break;
            }
            for (int i = 0; i < ne; ++i) data[off++] = (float)ref_double_from_half(temp[i]);
        }
        Py_END_ALLOW_THREADS
        if (field) goto fail;

        /* transmittance */
        int tdim[5]; /* dDim, aDim, nVisT, nAltT, rankT */
        for (int i = 0; i < 5 && !field; ++i)
            if (fread(&tdim[i], sizeof(int), 1, f) != 1 || tdim[i] < 1 || tdim[i] > fsize) field = "transmittance header";
        if (field) goto fail;
        int nt = tdim[2] > tdim[3] ? tdim[2] : tdim[3];
        if (!(tgrid = malloc(sizeof(float) * (size_t)nt))) {
            PyErr_NoMemory();
            goto done;
        }
        if (fread(tgrid, sizeof(float), (size_t)tdim[3], f) != (size_t)tdim[3] ||
            fread(tgrid, sizeof(float), (size_t)tdim[2], f) != (size_t)tdim[2]) {
            field = "altitudesTrans/visibilitiesTrans";
            goto fail;
        }
        const size_t nu = (size_t)tdim[0] * tdim[1] * tdim[4] * tdim[3];
        const size_t nv = (size_t)tdim[2] * tdim[4] * channels * tdim[3];
        if ((double)(nu + nv) * 4.0 > (double)fsize) {
            field = "transmittance coefficients (file too short)";
            goto fail;
        }
        float *du, *dv;
        if (!(U = ref_vector(nu, &du)) || !(V = ref_vector(nv, &dv))) goto done;
        if (fread(du, sizeof(float), nu, f) != nu || fread(dv, sizeof(float), nv, f) != nv) {
            field = "datasetTransU/V";
            goto fail;
        }

        /* polarisation (absent when the file ends here) */
        int prank = 0, np[2];
        if (fread(&prank, sizeof(int), 1, f) == 1) {
            for (int i = 0; i < 2 && !field; ++i)
                if (ref_counted(f, 1, fsize, &pgrid[i], &np[i]) < 0) field = "polarisation breaks";
            if (field) goto fail;
            const size_t per = (size_t)prank * (np[0] + np[1]);
            if (prank < 1 || (double)configs * (double)per * 4.0 > (double)fsize) {
                field = "polarisation coefficients (file too short)";
                goto fail;
            }
            float *dp;
            if (!(pol = ref_vector(configs * per, &dp))) goto done;
            Py_BEGIN_ALLOW_THREADS
            size_t poff = 0;
            for (size_t c = 0; c < configs && !field; ++c)
                for (int r = 0; r < prank; ++r) {
                    if (fread(dp + poff, sizeof(float), (size_t)np[0], f) != (size_t)np[0]) {
                        field = "sunCoefsPol";
                        break;
                    }
                    poff += (size_t)np[0];
                    if (fread(dp + poff, sizeof(float), (size_t)np[1], f) != (size_t)np[1]) {
                        field = "zenithCoefsPol";
                        break;
                    }
                    poff += (size_t)np[1];
                }
            Py_END_ALLOW_THREADS
            if (field) goto fail;
        } else {
            pol = Py_None;
            Py_INCREF(pol);
        }
        ret = PyTuple_Pack(4, rad, U, V, pol);
        goto done;
    }
fail:
    PyErr_Format(PyExc_ValueError, "reference_load: %s: cannot read %s", path, field);
done:
    fclose(f);
    for (int i = 0; i < 7; ++i) free(grid[i]);
    free(pgrid[0]);
    free(pgrid[1]);
    free(tgrid);
    free(temp);
    Py_XDECREF(rad);
    Py_XDECREF(U);
    Py_XDECREF(V);
    Py_XDECREF(pol);
    Py_DECREF(path_obj);
    return ret;
}

/* half_to_float(raw uint16, out float32, impl): every half of raw into out by one converter: 1 the table,
 * 2 F16C (ValueError where the processor lacks it), 3 the reference loader's float(double from half). For
 * the test that they agree on all 65,536 patterns. */
static PyObject *py_half_to_float(PyObject *self, PyObject *args)
{
    PyObject *o[2];
    int impl;
    if (!PyArg_ParseTuple(args, "OOi", &o[0], &o[1], &impl)) return NULL;
    buf_t b[2];
    memset(b, 0, sizeof(b));
    PyObject *ret = NULL;
    if (get_buf(o[0], &b[0], 0, "raw", 2) < 0 || get_buf(o[1], &b[1], 1, "out", 4) < 0) goto done;
    {
        size_t n = (size_t)b[0].b.len / 2;
        const uint16_t *raw = b[0].b.buf;
        float *out = b[1].b.buf;
        if ((size_t)b[1].b.len / 4 != n || impl < 1 || impl > 3 || (impl == 2 && !decode_f16c_available())) {
            PyErr_SetString(PyExc_ValueError, "half_to_float: out must hold one float32 per half; impl 1 table, "
                                              "2 F16C (where available), 3 reference");
            goto done;
        }
        if (impl == 1)
            for (size_t i = 0; i < n; ++i) out[i] = half_table[raw[i]];
        else if (impl == 3)
            for (size_t i = 0; i < n; ++i) out[i] = (float)ref_double_from_half(raw[i]);
#ifdef HAVE_F16C_DECODE
        else
            halves_f16c_n(raw, out, n);
#endif
        ret = Py_None;
        Py_INCREF(ret);
    }
done:
    for (int i = 0; i < 2; ++i) rel_buf(&b[i]);
    return ret;
}

/* decode_impl(impl): the converter decode_radiance uses from now on (0 automatic, 1 table, 2 F16C);
 * returns the one in use before the call (1 or 2). For tests and benchmarks. */
static PyObject *py_decode_impl(PyObject *self, PyObject *args)
{
    int impl;
    if (!PyArg_ParseTuple(args, "i", &impl)) return NULL;
    if (impl < 0 || impl > 2 || (impl == 2 && !decode_f16c_available())) {
        PyErr_SetString(PyExc_ValueError, "decode_impl: 0 automatic, 1 table, 2 F16C (where available)");
        return NULL;
    }
    decode_block_pick();
    int before = decode_impl;
    decode_impl = impl;
    decode_block_pick();
    return PyLong_FromLong(before);
}

/* direct_impl(impl): the direct path's chunk kernel from now on (0 automatic, 1 AVX2, 2 AVX-512 where
 * available); returns the one in use before the call (1 or 2; 0 where the vector path is not compiled in or
 * the processor lacks AVX2/FMA). For tests and benchmarks. */
static PyObject *py_direct_impl(PyObject *self, PyObject *args)
{
    int impl;
    if (!PyArg_ParseTuple(args, "i", &impl)) return NULL;
#ifdef DIRECT_VEC
    if (impl < 0 || impl > 2 || (impl >= 1 && !direct_vec_ok()) || (impl == 2 && !direct_512_available())) {
        PyErr_SetString(PyExc_ValueError, "direct_impl: 0 automatic, 1 AVX2, 2 AVX-512 (where available)");
        return NULL;
    }
    if (!direct_vec_ok()) return PyLong_FromLong(0);
    direct_use_512();
    int before = direct_impl;
    direct_impl = impl;
    direct_use_512();
    return PyLong_FromLong(before);
#else
    if (impl != 0) {
        PyErr_SetString(PyExc_ValueError, "direct_impl: 0 automatic (no vector direct path in this build)");
        return NULL;
    }
    return PyLong_FromLong(0);
#endif
}

static PyObject *py_has_openmp(PyObject *self, PyObject *args)
{
#ifdef WIDESKY_OPENMP
    return PyLong_FromLong(omp_get_max_threads());
#else
    return PyLong_FromLong(0);
#endif
}

/* ------------------------------------------------------------------------------------------ */
/* per-configuration tables, kept by the caller (the integrator's time series)                */
/*
 * The radiance of a sky state is sum_c w_c max(0, f_c(gamma, zero)) over its (at most 16) corner
 * configurations (a configuration: one visibility, albedo, altitude and elevation knot), each clamped
 * on its own. The daytime table of ONE configuration with weight 1 depends on nothing else: not on
 * the sun position (which only maps a direction to (gamma, zero)) nor on the state's weights. The
 * integrator's sky states (thousands per year) share a few hundred configurations, so it builds each
 * configuration's table once (radiance_config_table), keeps them, and evaluates every step as the
 * weighted sum of its corners' tables at the step's own geometry (radiance_config_eval): the same sum
 * as the merged table of py_radiance, in a different order (exact to rounding).
 */

/* radiance_config_table(sun, zen, emph, sb, zb, eb, rank, nch, cfg_base (1,), chi, tab_out)
 * tab_out: float32 of (ns-1)*(nu-1)*6*ncp values, ncp = nc rounded up to a multiple of 8 (nu: the merged zenith and emphasis knots).
 * Returns None when a merged cell is narrower than TABLE_MIN_CELL (the caller uses the exact
 * direct path), else (mix_start int32 bytes, mix_ch int32 bytes, mix_coef float64 bytes). */
static PyObject *py_radiance_config_table(PyObject *self, PyObject *args)
{
    PyObject *o[11];
    int rank, nch;
    if (!PyArg_ParseTuple(args, "OOOOOOiiOOO", &o[0], &o[1], &o[2], &o[3], &o[4], &o[5], &rank, &nch, &o[6],
                          &o[7], &o[8]))
        return NULL;
    buf_t b[9];
    memset(b, 0, sizeof(b));
    const Py_ssize_t isz[9] = {4, 4, 4, 8, 8, 8, 8, 8, 4};
    const char *names[9] = {"sun", "zen", "emph", "sun_breaks", "zen_breaks", "emph_breaks", "cfg_base",
                            "channels", "tab_out"};
    PyObject *ret = NULL;
    for (int i = 0; i < 9; ++i)
        if (get_buf(o[i], &b[i], i == 8, names[i], isz[i]) < 0) goto done;
    if (!b[2].held || !b[5].held || b[6].b.len != 8) {
        PyErr_SetString(PyExc_ValueError, "radiance_config_table: radiance (with emphasis), one configuration");
        goto done;
    }
    {
        int ns = (int)(b[3].b.len / 8), nz = (int)(b[4].b.len / 8), ne = (int)(b[5].b.len / 8);
        int nc = (int)(b[7].b.len / 8);
        comp_t m = {(const float *)b[0].b.buf, (const float *)b[1].b.buf, (const float *)b[2].b.buf,
                    (const double *)b[3].b.buf, (const double *)b[4].b.buf, (const double *)b[5].b.buf,
                    ns, nz, ne, rank, 1, nch};
        const double one = 1.0;
        table_t t;
        int err;
        Py_BEGIN_ALLOW_THREADS
        set_threads(1);
        err = table_build(&t, &m, (const int64_t *)b[6].b.buf, &one, 1, (const int64_t *)b[7].b.buf, nc);
        Py_END_ALLOW_THREADS
        if (err == 1) {
            Py_INCREF(Py_None);
            ret = Py_None;
            goto done;
        }
        if (err) {
            PyErr_NoMemory();
            goto done;
        }
        size_t need = (size_t)(ns - 1) * (t.nu - 1) * 6 * (((size_t)nc + 7) & ~(size_t)7);
        if ((size_t)(b[8].b.len / 4) != need) {
            table_free(&t);
            PyErr_Format(PyExc_ValueError, "radiance_config_table: tab_out has %zd values, expected %zu",
                         b[8].b.len / 8, need);
            goto done;
        }
        /* rows padded to a multiple of 8 channels (whole vectors in the evaluation; the padding is 0) */
        float *dst = (float *)b[8].b.buf;
        const size_t ncp = ((size_t)nc + 7) & ~(size_t)7;
        memset(dst, 0, need * sizeof(float));
        for (size_t r = 0; r < (size_t)(ns - 1) * (t.nu - 1) * 6; ++r)
            for (int k = 0; k < nc; ++k) dst[r * ncp + k] = (float)t.tab[r * nc + k];
        int ncell = (ns - 1) * (t.nu - 1);
        ret = Py_BuildValue("(y#y#y#)", (const char *)t.mix_start, (Py_ssize_t)(sizeof(int) * (ncell + 1)),
                            (const char *)t.mix_ch, (Py_ssize_t)(sizeof(int) * t.nmix),
                            (const char *)t.mix_coef, (Py_ssize_t)(sizeof(double) * 6 * t.nmix));
        table_free(&t);
    }
done:
    for (int i = 0; i < 9; ++i) rel_buf(&b[i]);
    return ret;
}

typedef struct {
    const float *tab;
    const int *mix_start, *mix_ch;
    const double *mix_coef;
} ctab_t;

/* A step's corner configurations merged on one cell: M = sum over the corners of weight x the cell's folded
 * polynomial rows (6 x nc float32, nc the padded channel count). Every direction of the step that falls in the
 * cell is then one polynomial of M (6 x nc multiply-adds instead of K times that): the same terms as summing
 * each corner's polynomial, in another order, in float32 as the tables are kept. */
typedef float cv8f __attribute__((vector_size(32)));                  /* eight floats (GCC vector extension) */
typedef float cv8f_u __attribute__((vector_size(32), aligned(4)));    /* the same, any alignment */

HOT static void cmerge_cell(const ctab_t *tabs, const int64_t *ci, const double *w, int K, int nc, size_t cell,
                            float *restrict M)
{
    const size_t len = 6 * (size_t)nc;
    const float *rowp[16];
    float wf[16];
    int n = 0;
    for (int c = 0; c < K && n < 16; ++c)
        if (w[c] != 0.0) {
            rowp[n] = tabs[ci[c]].tab + cell * len;
            wf[n++] = (float)w[c];
        }
    /* eight values at a time summed over the corners in a register (the corners' rows streamed side by side) */
    for (size_t k0 = 0; k0 < len; k0 += 8) {
        cv8f a = {0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f};
        for (int c = 0; c < n; ++c) a += wf[c] * *(const cv8f_u *)(rowp[c] + k0);
        *(cv8f_u *)(M + k0) = a;
    }
}

/* one direction from its cell's merged rows M, plus each corner's mixed terms (clamped on their own, in double) */
HOT static void ceval_merged(const float *restrict M, const ctab_t *tabs, const int64_t *ci, const double *w, int K,
                             int nc, size_t cell, double g, double z, float *restrict acc)
{
    const float fg = (float)g, fz = (float)z, fgz = (float)(g * z), fz2 = (float)(z * z), fgz2 = (float)(g * z * z);
    const double gz = g * z, z2 = z * z, gz2 = gz * z;
    for (int k = 0; k < nc; ++k)
        acc[k] = M[k] + fg * M[nc + k] + fz * M[2 * nc + k] + fgz * M[3 * nc + k] + fz2 * M[4 * nc + k] +
                 fgz2 * M[5 * nc + k];
    for (int c = 0; c < K; ++c) {
        if (w[c] == 0.0) continue;
        const ctab_t *t = tabs + ci[c];
        for (int e = t->mix_start[cell]; e < t->mix_start[cell + 1]; ++e) {
            const double *c6 = t->mix_coef + 6 * (size_t)e;
            double v = c6[0] + g * c6[1] + z * c6[2] + gz * c6[3] + z2 * c6[4] + gz2 * c6[5];
            if (v > 0) acc[t->mix_ch[e]] += (float)(w[c] * v);
        }
    }
}

/* grouped output: o[k] += wi x acc[k] (double) */
HOT static void cacc_row(double *restrict o, const float *restrict acc, double wi, int nc)
{
    for (int k = 0; k < nc; ++k) o[k] += wi * acc[k];
}

/* radiance_config_eval(tables, sb, u, step_cfg (T, K) int64, step_w (T, K) float64, geo (T, 3) float64
 *                      (observer altitude [m], solar elevation [rad], azimuth [rad from +x toward +y]),
 *                      dirs (T, N, 3) or (N, 3) float64, out float64, nthreads[, rows (N,) int64, wts (N,)])
 * tables: sequence of (tab float32, mix_start int32, mix_ch int32, mix_coef float64) from
 * radiance_config_table; step_cfg indexes it. Without rows: out (T, N, nc), one row per direction; with
 * rows and wts: out (T, n_rows, nc) = sum over directions i of wts[i] x radiance into row rows[i] (patch
 * means without writing every sample). dirs (N, 3): the same directions for every step. Daytime only (the
 * caller keeps steps whose sun is below the horizon at the view point on the other paths). */
static PyObject *py_radiance_config_eval(PyObject *self, PyObject *args)
{
    PyObject *tabs_obj, *o[9];
    o[7] = o[8] = Py_None;
    int nthreads;
    if (!PyArg_ParseTuple(args, "OOOOOOOOi|OO", &tabs_obj, &o[0], &o[1], &o[2], &o[3], &o[4], &o[5], &o[6],
                          &nthreads, &o[7], &o[8]))
        return NULL;
    PyObject *seq = PySequence_Fast(tabs_obj, "tables must be a sequence");
    if (!seq) return NULL;
    Py_ssize_t ntab = PySequence_Fast_GET_SIZE(seq);
    buf_t *tb = calloc((size_t)(4 * ntab + 1), sizeof(buf_t));
    ctab_t *ct = calloc((size_t)(ntab + 1), sizeof(ctab_t));
    buf_t b[9];
    memset(b, 0, sizeof(b));
    PyObject *ret = NULL;
    if (!tb || !ct) {
        PyErr_NoMemory();
        goto done;
    }
    const Py_ssize_t tsz[4] = {4, 4, 4, 8};
    for (Py_ssize_t i = 0; i < ntab; ++i) {
        PyObject *item = PySequence_Fast_GET_ITEM(seq, i);
        if (!PyTuple_Check(item) || PyTuple_GET_SIZE(item) != 4) {
            PyErr_SetString(PyExc_TypeError, "each table is a 4-tuple");
            goto done;
        }
        for (int j = 0; j < 4; ++j)
            if (get_buf(PyTuple_GET_ITEM(item, j), &tb[4 * i + j], 0, "table", tsz[j]) < 0) goto done;
        ct[i].tab = (const float *)tb[4 * i].b.buf;
        ct[i].mix_start = (const int *)tb[4 * i + 1].b.buf;
        ct[i].mix_ch = (const int *)tb[4 * i + 2].b.buf;
        ct[i].mix_coef = (const double *)tb[4 * i + 3].b.buf;
    }
    const char *names[9] = {"sun_breaks", "u", "step_cfg", "step_w", "geo", "dirs", "out", "rows", "wts"};
    for (int i = 0; i < 9; ++i)
        if (get_buf(o[i], &b[i], i == 6, names[i], 8) < 0) goto done;
    if (!b[6].held || b[7].held != b[8].held) {
        PyErr_SetString(PyExc_ValueError, "radiance_config_eval: out required; rows and wts together");
        goto done;
    }
    {
        const int ns = (int)(b[0].b.len / 8), nu = (int)(b[1].b.len / 8);
        const Py_ssize_t T = b[4].b.len / 24;
        if (T <= 0 || b[2].b.len != b[3].b.len || b[2].b.len % (8 * T) || ns < 2 || nu < 2) {
            PyErr_SetString(PyExc_ValueError, "radiance_config_eval: inconsistent array sizes");
            goto done;
        }
        const int K = (int)(b[2].b.len / 8 / T);
        if (K > 16) {
            PyErr_SetString(PyExc_ValueError, "radiance_config_eval: at most 16 configurations per step");
            goto done;
        }
        const int grouped = b[7].held;
        const int64_t *rows = grouped ? (const int64_t *)b[7].b.buf : NULL;
        const double *wts = grouped ? (const double *)b[8].b.buf : NULL;
        Py_ssize_t N, nrow;
        int shared;
        if (grouped) {
            N = b[7].b.len / 8;
            if (b[8].b.len != b[7].b.len || N <= 0) {
                PyErr_SetString(PyExc_ValueError, "radiance_config_eval: one row and weight per direction");
                goto done;
            }
        } else {
            N = 0;
        }
        if (!grouped) {
            /* (T, N, 3) directions, out (T, N, nc) */
            shared = 0;
            if (b[5].b.len % (24 * T)) {
                PyErr_SetString(PyExc_ValueError, "radiance_config_eval: dirs are not (T, N, 3)");
                goto done;
            }
            N = b[5].b.len / 24 / T;
            nrow = N;
        } else {
            shared = b[5].b.len == 24 * N;
            if (!shared && b[5].b.len != 24 * N * T) {
                PyErr_SetString(PyExc_ValueError, "radiance_config_eval: dirs are neither (N, 3) nor (T, N, 3)");
                goto done;
            }
            nrow = 0;
            for (Py_ssize_t i = 0; i < N; ++i) nrow = rows[i] + 1 > nrow ? rows[i] + 1 : nrow;
            for (Py_ssize_t i = 0; i < N; ++i)
                if (rows[i] < 0) {
                    PyErr_SetString(PyExc_ValueError, "radiance_config_eval: negative row");
                    goto done;
                }
        }
        const Py_ssize_t nval = b[6].b.len / 8;
        if (N <= 0 || nrow <= 0 || nval % (T * nrow)) {
            PyErr_SetString(PyExc_ValueError, "radiance_config_eval: out does not hold (T, rows, nc) values");
            goto done;
        }
        const int nc = (int)(nval / (T * nrow));
        const int ncp = (nc + 7) & ~7;
        const size_t tab_len = (size_t)(ns - 1) * (nu - 1) * 6 * ncp;
        const int64_t *sc = (const int64_t *)b[2].b.buf;
        for (Py_ssize_t i = 0; i < T * K; ++i)
            if (sc[i] < 0 || sc[i] >= ntab) {
                PyErr_SetString(PyExc_ValueError, "radiance_config_eval: configuration index outside the tables");
                goto done;
            }
        for (Py_ssize_t i = 0; i < ntab; ++i) {
            const Py_ssize_t ncell = (Py_ssize_t)(ns - 1) * (nu - 1);
            if ((size_t)(tb[4 * i].b.len / 4) != tab_len || tb[4 * i + 1].b.len / 4 != ncell + 1) {
                PyErr_SetString(PyExc_ValueError, "radiance_config_eval: a table of another shape");
                goto done;
            }
            const int *ms = ct[i].mix_start;
            const Py_ssize_t nmix = tb[4 * i + 2].b.len / 4;
            if (ms[0] != 0 || ms[ncell] != nmix || tb[4 * i + 3].b.len / 48 != nmix) {
                PyErr_SetString(PyExc_ValueError, "radiance_config_eval: inconsistent mixed terms");
                goto done;
            }
            for (Py_ssize_t c = 0; c < ncell; ++c)
                if (ms[c + 1] < ms[c]) {
                    PyErr_SetString(PyExc_ValueError, "radiance_config_eval: inconsistent mixed terms");
                    goto done;
                }
            for (Py_ssize_t e = 0; e < nmix; ++e)
                if (ct[i].mix_ch[e] < 0 || ct[i].mix_ch[e] >= nc) {
                    PyErr_SetString(PyExc_ValueError, "radiance_config_eval: a mixed term's channel outside nc");
                    goto done;
                }
        }
        const double *geo_in = (const double *)b[4].b.buf, *dirs = (const double *)b[5].b.buf;
        const double *sw = (const double *)b[3].b.buf;
        double *out = (double *)b[6].b.buf;
        int fail = 0;
        Py_BEGIN_ALLOW_THREADS
        set_threads(nthreads);
        accel_t ag, az;
        memset(&ag, 0, sizeof(ag));
        memset(&az, 0, sizeof(az));
        if (accel_init(&ag, (const double *)b[0].b.buf, ns) || accel_init(&az, (const double *)b[1].b.buf, nu))
            fail = 1;
        /* directions shared by all steps at one observer altitude: their zenith cell and the unit vectors
         * once (the zero angle does not depend on the sun), only gamma per step */
        int same_alt = shared;
        for (Py_ssize_t t = 1; t < T && same_alt; ++t) same_alt = geo_in[3 * t] == geo_in[0];
        int *pre_iz = NULL;
        double *pre_z = NULL, *pre_v = NULL;
        if (!fail && same_alt) {
            pre_iz = malloc(sizeof(int) * (size_t)N);
            pre_z = malloc(sizeof(double) * (size_t)N);
            pre_v = malloc(sizeof(double) * 3 * (size_t)N);
            if (!pre_iz || !pre_z || !pre_v) {
                fail = 1;
            } else {
                geom_t g0;
                geom_init(&g0, geo_in[0], geo_in[1], geo_in[2]);
                for (Py_ssize_t i = 0; i < N; ++i) {
                    const double *v = dirs + 3 * i;
                    angles_t a = compute_angles(v, &g0, 0, 0);
                    pre_iz[i] = accel_cell(&az, a.zero, &pre_z[i]);
                    double nv = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
                    if (nv < DBL_EPSILON_) nv = DBL_EPSILON_;
                    for (int j = 0; j < 3; ++j) pre_v[3 * i + j] = v[j] / nv;
                }
            }
        }
        if (!fail) {
            /* steps in batches of SB: every (step, direction)'s cell first, then the batch cell by cell (a counting
             * sort), so each cell's corner rows are read from memory once per batch and stay in cache while the
             * batch's steps that look into that cell merge their corners on it (cmerge_cell, once per step and
             * cell) and evaluate their directions there. Each value depends only on its own step and direction. */
            const size_t ncell = (size_t)(ns - 1) * (nu - 1), mlen = 6 * (size_t)ncp;
            Py_ssize_t SB = N >= 65536 ? 1 : 65536 / N;
            if (SB > 64) SB = 64;
            const Py_ssize_t nbatch = (T + SB - 1) / SB;
#pragma omp parallel reduction(|| : fail) if (T * N * (Py_ssize_t)nc * K >= PAR_MIN_WORK)
            {
                const size_t cap = (size_t)SB * (size_t)N;
                float *acc = malloc(sizeof(float) * (size_t)ncp);
                float *mrg = malloc(sizeof(float) * mlen);
                size_t *cnt = calloc(ncell + 1, sizeof(size_t));
                size_t *ord = malloc(sizeof(size_t) * cap);
                int *cellof = malloc(sizeof(int) * cap);
                double *gzv = malloc(sizeof(double) * 2 * cap);
                if (!acc || !mrg || !cnt || !ord || !cellof || !gzv) fail = 1;
                Py_ssize_t bt;
#pragma omp for schedule(dynamic, 1)
                for (bt = 0; bt < nbatch; ++bt) {
                    if (fail) continue;
                    const Py_ssize_t t0 = bt * SB, t1 = t0 + SB < T ? t0 + SB : T;
                    const size_t nent = (size_t)(t1 - t0) * (size_t)N;
                    for (Py_ssize_t t = t0; t < t1; ++t) {
                        geom_t geo;
                        geom_init(&geo, geo_in[3 * t], geo_in[3 * t + 1], geo_in[3 * t + 2]);
                        if (grouped) {
                            double *ot = out + (size_t)t * nrow * nc;
                            for (Py_ssize_t i = 0; i < nrow * nc; ++i) ot[i] = 0.0;
                        }
                        const size_t e0 = (size_t)(t - t0) * (size_t)N;
                        for (Py_ssize_t i = 0; i < N; ++i) {
                            double g, z;
                            int ig, iz;
                            if (pre_iz) {
                                const double *v = pre_v + 3 * i;
                                ig = accel_cell(&ag, acos(clamp_unit(v[0] * geo.s[0] + v[1] * geo.s[1] + v[2] * geo.s[2])),
                                                &g);
                                iz = pre_iz[i];
                                z = pre_z[i];
                            } else {
                                const double *v = dirs + 3 * (shared ? i : (size_t)t * N + i);
                                angles_t a = compute_angles(v, &geo, 0, 0);
                                ig = accel_cell(&ag, a.gamma, &g);
                                iz = accel_cell(&az, a.zero, &z);
                            }
                            const int cell = ig * (nu - 1) + iz;
                            cellof[e0 + i] = cell;
                            gzv[2 * (e0 + i)] = g;
                            gzv[2 * (e0 + i) + 1] = z;
                            cnt[cell + 1]++;
                        }
                    }
                    for (size_t c = 0; c < ncell; ++c) cnt[c + 1] += cnt[c];          /* cnt[c]: first entry of cell c */
                    for (size_t e = 0; e < nent; ++e) ord[cnt[cellof[e]]++] = e;     /* now cnt[c]: past its last */
                    size_t p = 0;
                    for (size_t c = 0; c < ncell; ++c) {
                        Py_ssize_t tprev = -1;
                        for (const size_t end = cnt[c]; p < end; ++p) {
                            const size_t e = ord[p];
                            const Py_ssize_t tl = (Py_ssize_t)(e / (size_t)N), i = (Py_ssize_t)(e % (size_t)N);
                            const Py_ssize_t t = t0 + tl;
                            const int64_t *ci = sc + (size_t)t * K;
                            const double *wt = sw + (size_t)t * K;
                            if (tl != tprev) {                   /* entries of one cell come step by step */
                                cmerge_cell(ct, ci, wt, K, ncp, c, mrg);
                                tprev = tl;
                            }
                            ceval_merged(mrg, ct, ci, wt, K, ncp, c, gzv[2 * e], gzv[2 * e + 1], acc);
                            double *ot = out + (size_t)t * nrow * nc;
                            if (grouped) {
                                cacc_row(ot + (size_t)rows[i] * nc, acc, wts[i], nc);
                            } else {
                                double *o2 = ot + (size_t)i * nc;
                                for (int k = 0; k < nc; ++k) o2[k] = acc[k];
                            }
                        }
                    }
                    memset(cnt, 0, sizeof(size_t) * (ncell + 1));
                }
                free(acc);
                free(mrg);
                free(cnt);
                free(ord);
                free(cellof);
                free(gzv);
            }
        }
        free(pre_iz);
        free(pre_z);
        free(pre_v);
        free(ag.start);
        free(az.start);
        Py_END_ALLOW_THREADS
        if (fail) {
            PyErr_NoMemory();
            goto done;
        }
        Py_INCREF(Py_None);
        ret = Py_None;
    }
done:
    for (int i = 0; i < 9; ++i) rel_buf(&b[i]);
    if (tb)
        for (Py_ssize_t i = 0; i < 4 * ntab; ++i) rel_buf(&tb[i]);
    free(tb);
    free(ct);
    Py_DECREF(seq);
    return ret;
}

static PyMethodDef methods[] = {
    {"radiance", py_radiance, METH_VARARGS, "Sky radiance or polarisation kernel (see skymodel.evaluate)."},
    {"transmittance", py_transmittance, METH_VARARGS, "Transmittance kernel (see skymodel.evaluate)."},
    {"check_dirs", py_check_dirs, METH_VARARGS, "Index of the first non-finite or zero direction, or -1."},
    {"reference_loop", py_reference_loop, METH_VARARGS,
     "Baseline: straight port of the reference loop, one direction and channel per call, one thread."},
    {"fisheye_counts", py_fisheye_counts, METH_VARARGS, "Pixels per image row inside the fisheye disc."},
    {"fisheye", py_fisheye, METH_VARARGS, "Stereographic fisheye directions of the disc's pixels."},
    {"planar", py_planar, METH_VARARGS, "Pixel-interleaved float32 to channel planes (float32 or half)."},
    {"colour", py_colour, METH_VARARGS, "Per-pixel linear sRGB and CIE Y of a spectral image (values @ weights)."},
    {"encode8", py_encode8, METH_VARARGS, "Linear values to 8-bit sRGB through a 16-bit table."},
    {"exr_lines", py_exr_lines, METH_VARARGS, "OpenEXR scanline chunks (uncompressed or RLE) of an image."},
    {"decode_radiance", py_decode_radiance, METH_VARARGS, "Decode radiance blocks into float32 factors."},
    {"decode_polarisation", py_decode_polarisation, METH_VARARGS, "Decode polarisation blocks (float32)."},
    {"reference_load", py_reference_load, METH_VARARGS,
     "The project's C port of the reference loader's loop (benchmark baseline; float32 in its layout)."},
    {"half_to_float", py_half_to_float, METH_VARARGS, "Halves to float32 by one converter (1 table, 2 F16C, 3 ref)."},
    {"decode_impl", py_decode_impl, METH_VARARGS, "Select the decoder's half converter (0 auto, 1 table, 2 F16C)."},
    {"direct_impl", py_direct_impl, METH_VARARGS, "Select the direct path's kernel (0 auto, 1 AVX2, 2 AVX-512)."},
    {"radiance_config_table", py_radiance_config_table, METH_VARARGS,
     "Daytime radiance table of one configuration (weight 1), for radiance_config_eval."},
    {"radiance_config_eval", py_radiance_config_eval, METH_VARARGS,
     "Radiance of many sky states as weighted sums of their configurations' tables."},
    {"openmp_threads", py_has_openmp, METH_NOARGS, "Maximum OpenMP threads (0 when built without OpenMP)."},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef moddef = {PyModuleDef_HEAD_INIT, "_core",
                                    "Hot kernels of the widesky Prague Sky Model evaluator.", -1, methods};

PyMODINIT_FUNC PyInit__core(void)
{
    half_table_init();
#ifdef WIDESKY_OPENMP
    default_threads = omp_get_max_threads();
#endif
    return PyModule_Create(&moddef);
}
