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
 *           configuration (the reference's work, reorganised).
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

static void radiance_direct(const comp_t *m, const geom_t *geo, const int64_t *cfg_base,
                            const double *cfg_w, int ncfg, const int64_t *chi, int nc,
                            const double *dirs, Py_ssize_t n, void *out, int is_double, double sign,
                            const int64_t *rows)
{
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
    a->nbk = 8 * n;
    a->b0 = b[0];
    double span = b[n - 1] - b[0];
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

typedef struct {
    const comp_t *m;
    const int64_t *cfg_base;
    const double *cfg_w;
    int ncfg, nc, nu, ncell_u;
    const int64_t *chi;
    const double *u;
    const double *zat, *eat;
    table_t *t;
} build_ctx_t;

/* One row of sun cells: S at sun knots i and i+1 (ra, rb), then 8 corner-product sums per cell
 * acc[p][j], p = (e0|e1) x (S00|S01|S10|S11), accumulated over the configurations that cannot change
 * sign inside the cell; the others go to the mixed list (clamped terms) or are dropped (<= 0). */
HOT static int build_row(const build_ctx_t *X, int i, mixlist_t *mix, double *restrict ra, double *restrict rb,
                         double *restrict acc)
{
    const comp_t *m = X->m;
    const int nu = X->nu, ncell_u = X->ncell_u, nc = X->nc, R = m->rank, ns = m->ns;
    const double dg = m->sb[i + 1] - m->sb[i];
    const double *u = X->u;
    for (int k = 0; k < nc; ++k) {
        memset(acc, 0, sizeof(double) * 8 * (size_t)ncell_u);
        for (int c = 0; c < X->ncfg; ++c) {
            const double w = X->cfg_w[c];
            size_t q = (size_t)c * nc + k;
            size_t cfg = (size_t)X->cfg_base[c] * m->nch + (size_t)X->chi[k];
            const float *sun = m->sun + cfg * (size_t)R * ns;
            for (int j = 0; j < nu; ++j) ra[j] = rb[j] = 0.0;
            for (int r = 0; r < R; ++r) {
                const double s0 = sun[(size_t)r * ns + i], s1 = sun[(size_t)r * ns + i + 1];
                const double *restrict zr = X->zat + (q * R + r) * nu;
                for (int j = 0; j < nu; ++j) {
                    ra[j] += s0 * zr[j];
                    rb[j] += s1 * zr[j];
                }
            }
            const double *restrict er = X->eat + q * nu;
            int row_safe = 1;
            if (m->clamp) {
                double smin = ra[0], smax = ra[0], emin = er[0], emax = er[0];
                for (int j = 0; j < nu; ++j) {
                    double lo = ra[j] < rb[j] ? ra[j] : rb[j], hi = ra[j] < rb[j] ? rb[j] : ra[j];
                    smin = lo < smin ? lo : smin;
                    smax = hi > smax ? hi : smax;
                    emin = er[j] < emin ? er[j] : emin;
                    emax = er[j] > emax ? er[j] : emax;
                }
                row_safe = (smin >= 0 && emin >= 0) || (smax <= 0 && emax <= 0);
            }
            double *restrict a0 = acc, *restrict a1 = acc + ncell_u, *restrict a2 = acc + 2 * ncell_u;
            double *restrict a3 = acc + 3 * ncell_u, *restrict a4 = acc + 4 * ncell_u;
            double *restrict a5 = acc + 5 * ncell_u, *restrict a6 = acc + 6 * ncell_u;
            double *restrict a7 = acc + 7 * ncell_u;
            if (row_safe) {
                for (int j = 0; j < ncell_u; ++j) {
                    const double e0 = w * er[j], e1 = w * er[j + 1];
                    a0[j] += e0 * ra[j];
                    a1[j] += e0 * ra[j + 1];
                    a2[j] += e0 * rb[j];
                    a3[j] += e0 * rb[j + 1];
                    a4[j] += e1 * ra[j];
                    a5[j] += e1 * ra[j + 1];
                    a6[j] += e1 * rb[j];
                    a7[j] += e1 * rb[j + 1];
                }
                continue;
            }
            for (int j = 0; j < ncell_u; ++j) {
                const double S00 = ra[j], S01 = ra[j + 1], S10 = rb[j], S11 = rb[j + 1];
                const double e0 = er[j], e1v = er[j + 1];
                double smin = fmin(fmin(S00, S01), fmin(S10, S11));
                double smax = fmax(fmax(S00, S01), fmax(S10, S11));
                double emin = fmin(e0, e1v), emax = fmax(e0, e1v);
                if ((smin >= 0 && emin >= 0) || (smax <= 0 && emax <= 0)) {
                    const double we0 = w * e0, we1 = w * e1v;
                    a0[j] += we0 * S00;
                    a1[j] += we0 * S01;
                    a2[j] += we0 * S10;
                    a3[j] += we0 * S11;
                    a4[j] += we1 * S00;
                    a5[j] += we1 * S01;
                    a6[j] += we1 * S10;
                    a7[j] += we1 * S11;
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
        const double ig = 1.0 / dg;
        for (int j = 0; j < ncell_u; ++j) {
            const double ix = 1.0 / (u[j + 1] - u[j]);
            const double x00 = acc[j], x01 = acc[ncell_u + j], x10 = acc[2 * ncell_u + j];
            const double x11 = acc[3 * ncell_u + j], y00 = acc[4 * ncell_u + j];
            const double y01 = acc[5 * ncell_u + j], y10 = acc[6 * ncell_u + j];
            const double y11 = acc[7 * ncell_u + j];
            double *T = X->t->tab + ((size_t)(i * ncell_u + j)) * 6 * nc + k;
            T[0] = x00;
            T[nc] = (x10 - x00) * ig;
            T[2 * nc] = ((x01 - x00) + (y00 - x00)) * ix;
            T[3 * nc] = ((x11 - x10 - x01 + x00) + (y10 - x10) - (y00 - x00)) * ig * ix;
            T[4 * nc] = ((y01 - x01) - (y00 - x00)) * ix * ix;
            T[5 * nc] = ((y11 - x11) - (y10 - x10) - (y01 - x01) + (y00 - x00)) * ig * ix * ix;
        }
    }
    return 0;
}

/* Build the per-cell polynomial table for a fixed sky state (sun above the horizon). Returns 0 on
 * success, -1 on allocation failure, 1 when a cell is too narrow (use the direct path). */
static int table_build(table_t *t, const comp_t *m, const int64_t *cfg_base, const double *cfg_w,
                       int ncfg, const int64_t *chi, int nc)
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
    /* zenith and emphasis knots closer than TABLE_MIN_CELL make a cell whose polynomial coefficients grow
     * as 1/width^2 (they may overflow): leave such a sky state to the direct path, which is exact */
    for (int j = 0; j + 1 < nu; ++j)
        if (t->u[j + 1] - t->u[j] < TABLE_MIN_CELL) {
            free(t->u);
            t->u = NULL;
            return 1;
        }

    /* values of every zenith factor and of the emphasis at the merged knots:
     * zat[((c * nc + k) * R + r) * nu + j], eat[(c * nc + k) * nu + j] */
    size_t nzat = (size_t)ncfg * nc * R * nu, neat = (size_t)ncfg * nc * nu;
    double *zat = malloc(sizeof(double) * nzat);
    double *eat = malloc(sizeof(double) * neat);
    ip_t *zl = malloc(sizeof(ip_t) * nu), *el = malloc(sizeof(ip_t) * nu);
    t->tab = ws_acquire((size_t)ncell * 6 * nc);
    t->mix_start = calloc((size_t)ncell + 1, sizeof(int));
    mixlist_t *rows = calloc((size_t)(ns - 1), sizeof(mixlist_t));
    int fail = !zat || !eat || !zl || !el || !t->tab || !t->mix_start || !rows;
    if (!fail) {
        for (int j = 0; j < nu; ++j) {
            zl[j] = knot_lookup(t->u[j], m->zb, m->nz);
            if (m->emph) el[j] = knot_lookup(t->u[j], m->eb, m->ne);
        }
        Py_ssize_t q, nq = (Py_ssize_t)ncfg * nc;
#pragma omp parallel for schedule(static) if (nq * R * nu >= PAR_MIN_WORK)
        for (q = 0; q < nq; ++q) {
            int c = (int)(q / nc), k = (int)(q % nc);
            size_t cfg = (size_t)cfg_base[c] * m->nch + (size_t)chi[k];
            const float *zen = m->zen + cfg * (size_t)R * m->nz;
            for (int r = 0; r < R; ++r)
                for (int j = 0; j < nu; ++j)
                    zat[((size_t)q * R + r) * nu + j] = pl_eval(zen + (size_t)r * m->nz, zl[j]);
            for (int j = 0; j < nu; ++j)
                eat[(size_t)q * nu + j] = m->emph ? pl_eval(m->emph + cfg * (size_t)m->ne, el[j]) : 1.0;
        }
        build_ctx_t X = {m, cfg_base, cfg_w, ncfg, nc, nu, ncell_u, chi, t->u, zat, eat, t};
        int row_fail = 0;
        int i;
#pragma omp parallel for schedule(dynamic, 1) reduction(|| : row_fail) if ((Py_ssize_t)ns * nc * ncfg * R * nu >= PAR_MIN_WORK)
        for (i = 0; i < ns - 1; ++i) {
            double *buf = malloc(sizeof(double) * (2 * (size_t)nu + 8 * (size_t)ncell_u));
            if (!buf || build_row(&X, i, &rows[i], buf, buf + nu, buf + 2 * nu)) row_fail = 1;
            free(buf);
        }
        fail = row_fail;
    }
    if (!fail) {
        /* CSR of the mixed terms by cell */
        size_t total = 0;
        for (int i = 0; i < ns - 1; ++i) total += rows[i].n;
        t->nmix = (Py_ssize_t)total;
        t->mix_ch = malloc(sizeof(int) * (total ? total : 1));
        t->mix_coef = malloc(sizeof(double) * 6 * (total ? total : 1));
        int *fill = calloc((size_t)ncell, sizeof(int));
        if (!t->mix_ch || !t->mix_coef || !fill) fail = 1;
        if (!fail) {
            for (int i = 0; i < ns - 1; ++i)
                for (int e = 0; e < rows[i].n; ++e) t->mix_start[rows[i].cell[e] + 1]++;
            for (int c = 0; c < ncell; ++c) t->mix_start[c + 1] += t->mix_start[c];
            for (int i = 0; i < ns - 1; ++i)
                for (int e = 0; e < rows[i].n; ++e) {
                    int cell = rows[i].cell[e];
                    int pos = t->mix_start[cell] + fill[cell]++;
                    t->mix_ch[pos] = rows[i].ch[e];
                    memcpy(t->mix_coef + 6 * (size_t)pos, rows[i].coef + 6 * (size_t)e, 6 * sizeof(double));
                }
        }
        free(fill);
    }
    if (rows)
        for (int i = 0; i < ns - 1; ++i) {
            free(rows[i].cell);
            free(rows[i].ch);
            free(rows[i].coef);
        }
    free(rows);
    free(zat);
    free(eat);
    free(zl);
    free(el);
    if (fail) {
        table_free(t);
        return -1;
    }
    return 0;
}

/* Evaluate one direction from its cell and local offsets. */
static inline void eval_one(const table_t *t, int cell, double g, double z, double *restrict acc)
{
    const int nc = t->nc;
    const double *restrict T = t->tab + (size_t)cell * 6 * nc;
    const double gz = g * z, z2 = z * z, gz2 = gz * z;
    for (int k = 0; k < nc; ++k)
        acc[k] = T[k] + g * T[nc + k] + z * T[2 * nc + k] + gz * T[3 * nc + k] + z2 * T[4 * nc + k] +
                 gz2 * T[5 * nc + k];
    for (int e = t->mix_start[cell]; e < t->mix_start[cell + 1]; ++e) {
        const double *c6 = t->mix_coef + 6 * (size_t)e;
        double v = c6[0] + g * c6[1] + z * c6[2] + gz * c6[3] + z2 * c6[4] + gz2 * c6[5];
        if (v > 0) acc[t->mix_ch[e]] += v;
    }
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

/* Evaluate directions [i0, i1) in their given order (an image's order keeps neighbouring directions,
 * which mostly share a cell, together). */
HOT static void eval_chunk(const table_t *t, const accel_t *ag, const accel_t *az, const geom_t *geo,
                           const double *dirs, Py_ssize_t i0, Py_ssize_t i1, void *out, int is_double,
                           double sign, double *restrict acc, const int64_t *rows)
{
    const int ncell_u = t->nu - 1;
    for (Py_ssize_t i = i0; i < i1; ++i) {
        angles_t a = compute_angles(dirs + 3 * i, geo, 0, 0);
        double g, z;
        int ig = accel_cell(ag, a.gamma, &g);
        int iz = accel_cell(az, a.zero, &z);
        eval_one(t, ig * ncell_u + iz, g, z, acc);
        store_row(out, OUT_ROW(rows, i), t->nc, acc, is_double, sign);
    }
}

static int table_eval(const table_t *t, const geom_t *geo, const double *dirs, Py_ssize_t n, void *out,
                      int is_double, double sign, const int64_t *rows)
{
    accel_t ag, az;
    if (accel_init(&ag, t->sb, t->ns)) return -1;
    if (accel_init(&az, t->u, t->nu)) {
        free(ag.start);
        return -1;
    }
    const Py_ssize_t chunk = 256;
    Py_ssize_t nchunks = (n + chunk - 1) / chunk, c;
    int fail = 0;
#pragma omp parallel reduction(|| : fail) if (n * (Py_ssize_t)t->nc >= PAR_MIN_WORK / 8)
    {
        double *acc = malloc(sizeof(double) * (t->nc > 0 ? t->nc : 1));
        if (!acc) fail = 1;
#pragma omp for schedule(static)
        for (c = 0; c < nchunks; ++c) {
            if (!acc) continue;
            Py_ssize_t i0 = c * chunk, i1 = i0 + chunk < n ? i0 + chunk : n;
            eval_chunk(t, &ag, &az, geo, dirs, i0, i1, out, is_double, sign, acc, rows);
        }
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
    double *K = malloc(sizeof(double) * (size_t)ns * nz * cn); /* [i][j][c][k] corner products */
    double *E = malloc(sizeof(double) * (size_t)ne * cn);      /* [l][c][k] emphasis at its knots */
    tw_dir_t *d = malloc(sizeof(tw_dir_t) * (n ? n : 1));
    int32_t *slot = malloc(sizeof(int32_t) * (size_t)ncell3);
    int64_t *cells = NULL;
    double *tab = NULL;
    int *mix_start = NULL, *mix_ch = NULL;
    double *mix_coef = NULL;
    mixlist_t *lists = NULL;
    Py_ssize_t nvis = 0, nmix = 0;
    if (!K || !E || !d || !slot || accel_init(&ag, m->sb, ns) || accel_init(&as, m->zb, nz) ||
        accel_init(&ae, m->eb, ne)) {
        fail = -1;
        goto out;
    }
    {
        Py_ssize_t q, nq = (Py_ssize_t)cn;
#pragma omp parallel for schedule(static) if (nq * ns * nz * R >= PAR_MIN_WORK)
        for (q = 0; q < nq; ++q) {
            int c = (int)(q / nc), k = (int)(q % nc);
            size_t cfg = (size_t)cfg_base[c] * m->nch + (size_t)chi[k];
            const float *sun = m->sun + cfg * (size_t)R * ns, *zen = m->zen + cfg * (size_t)R * nz;
            for (int i = 0; i < ns; ++i)
                for (int j = 0; j < nz; ++j) {
                    double acc = 0.0;
                    for (int r = 0; r < R; ++r) acc += (double)sun[(size_t)r * ns + i] * (double)zen[(size_t)r * nz + j];
                    K[((size_t)i * nz + j) * cn + q] = acc;
                }
            for (int l = 0; l < ne; ++l) E[(size_t)l * cn + q] = (double)m->emph[cfg * (size_t)ne + l];
        }
    }
    {
        Py_ssize_t i;
#pragma omp parallel for schedule(static) if (n >= 4096)
        for (i = 0; i < n; ++i) {
            angles_t a = compute_angles(dirs + 3 * i, geo, 0, 1);
            int ig = accel_cell(&ag, a.gamma, &d[i].g);
            int is = accel_cell(&as, a.shadow, &d[i].s);
            int iz = accel_cell(&ae, a.zero, &d[i].z);
            d[i].key = ((int64_t)ig * cz + is) * ce + iz;
        }
    }
    for (int64_t c = 0; c < ncell3; ++c) slot[c] = -1;
    for (Py_ssize_t i = 0; i < n; ++i)
        if (slot[d[i].key] < 0) slot[d[i].key] = (int32_t)nvis++;
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
            const double *K00 = K + ((size_t)ig * nz + is) * cn, *K01 = K + ((size_t)ig * nz + is + 1) * cn;
            const double *K10 = K + ((size_t)(ig + 1) * nz + is) * cn, *K11 = K + ((size_t)(ig + 1) * nz + is + 1) * cn;
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
        Py_ssize_t i;
#pragma omp parallel if (n * (Py_ssize_t)nc >= PAR_MIN_WORK / 8)
        {
            double *acc = malloc(sizeof(double) * (nc > 0 ? nc : 1));
#pragma omp for schedule(static)
            for (i = 0; i < n; ++i) {
                if (!acc) continue;
                const int v = slot[d[i].key];
                const double g = d[i].g, sv = d[i].s, z = d[i].z, gs = g * sv;
                const double *restrict T = tab + (size_t)v * 8 * nc;
                for (int k = 0; k < nc; ++k)
                    acc[k] = T[k] + g * T[nc + k] + sv * T[2 * nc + k] + gs * T[3 * nc + k] +
                             z * (T[4 * nc + k] + g * T[5 * nc + k] + sv * T[6 * nc + k] + gs * T[7 * nc + k]);
                for (int e = mix_start[v]; e < mix_start[v + 1]; ++e) {
                    const double *c8 = mix_coef + 8 * (size_t)e;
                    double x = c8[0] + g * c8[1] + sv * c8[2] + gs * c8[3] + z * (c8[4] + g * c8[5] + sv * c8[6] + gs * c8[7]);
                    if (x > 0) acc[mix_ch[e]] += x;
                }
                store_row(out, OUT_ROW(rows, i), nc, acc, is_double, 1.0);
            }
            if (!acc) fail = -1;
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
        int twilight = use_table && m.emph && geo.use_shadow;
        int err = 0;
        Py_ssize_t nmix = 0, nvisited = 0;
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
                                is_double, sign, rows);
            }
        } else if (use_table) {
            table_t t;
            err = table_build(&t, &m, (const int64_t *)b[6].b.buf, (const double *)b[7].b.buf, ncfg,
                              (const int64_t *)b[8].b.buf, nc);
            if (err == 1) { /* ill-conditioned cell: the direct path instead */
                err = 0;
                use_table = 0;
                radiance_direct(&m, &geo, (const int64_t *)b[6].b.buf, (const double *)b[7].b.buf, ncfg,
                                (const int64_t *)b[8].b.buf, nc, (const double *)b[9].b.buf, n, b[10].b.buf,
                                is_double, sign, rows);
            } else if (!err) {
                nmix = t.nmix;
                err = table_eval(&t, &geo, (const double *)b[9].b.buf, n, b[10].b.buf, is_double, sign, rows);
                table_free(&t);
            }
        } else {
            radiance_direct(&m, &geo, (const int64_t *)b[6].b.buf, (const double *)b[7].b.buf, ncfg,
                            (const int64_t *)b[8].b.buf, nc, (const double *)b[9].b.buf, n, b[10].b.buf,
                            is_double, sign, rows);
        }
        Py_END_ALLOW_THREADS
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
            x = sgn | 0x7f800000u | (m << 13);
        } else {
            x = sgn | ((e + 112u) << 23) | (m << 13);
        }
        memcpy(&f, &x, 4);
        half_table[h] = f;
    }
}

static inline int finite_f(float f) { return isfinite(f); }

#if defined(__FLT16_MAX__) && defined(__x86_64__)
typedef _Float16 half_t; /* the compiler converts (vcvtph2ps in the x86-64-v3 clone, vectorised) */
#define HALF_TO_FLOAT(p, j) ((float)(p)[j])
#else
typedef uint16_t half_t;
#define HALF_TO_FLOAT(p, j) (half_table[(p)[j]])
#endif

/* One radiance block: rank x (sun halves, zenithScale, zenith halves), then the emphasis halves. Returns
 * 0, or the code of the first problem (1 scale, 2 sun, 3 zenith, 4 emphasis). */
HOT static int decode_block(const unsigned char *blk, int rank, int ns, int nz, int ne, float *restrict so,
                            float *restrict zo, float *restrict eo)
{
    const size_t rank_bytes = 2 * (size_t)ns + 8 + 2 * (size_t)nz;
    for (int r = 0; r < rank; ++r) {
        const unsigned char *p = blk + (size_t)r * rank_bytes;
        double scale;
        memcpy(&scale, p + 2 * (size_t)ns, 8);
        if (!isfinite(scale) || scale == 0.0) return 1;
        const half_t *hs = (const half_t *)p, *hz = (const half_t *)(p + 2 * (size_t)ns + 8);
        float *restrict s = so + (size_t)r * ns, *restrict z = zo + (size_t)r * nz;
        int bad = 0;
        for (int j = 0; j < ns; ++j) {
            s[j] = HALF_TO_FLOAT(hs, j);
            bad |= !finite_f(s[j]);
        }
        if (bad) return 2;
        for (int j = 0; j < nz; ++j) {
            z[j] = (float)((double)HALF_TO_FLOAT(hz, j) / scale);
            bad |= !finite_f(z[j]);
        }
        if (bad) return 3;
    }
    const half_t *he = (const half_t *)(blk + (size_t)rank * rank_bytes);
    int bad = 0;
    for (int j = 0; j < ne; ++j) {
        eo[j] = HALF_TO_FLOAT(he, j);
        bad |= !finite_f(eo[j]);
    }
    return bad ? 4 : 0;
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
        Py_ssize_t bad_all = -1, nq = nrows * nsel, q;
        int code_all = 0;
        Py_BEGIN_ALLOW_THREADS
#pragma omp parallel for schedule(static) if (nq * rank * (ns + nz) >= PAR_MIN_WORK)
        for (q = 0; q < nq; ++q) {
            Py_ssize_t bad = -1;
            int code = 0;
            Py_ssize_t row = q / nsel, k = q % nsel;
            const unsigned char *blk = raw + ((size_t)row * nch + (size_t)chi[k]) * block;
            code = decode_block(blk, rank, ns, nz, ne, sun + (size_t)q * rank * ns, zen + (size_t)q * rank * nz,
                                emph + (size_t)q * ne);
            if (code) bad = q;
            if (bad >= 0) {
#pragma omp critical(widesky_decode_bad)
                if (bad_all < 0 || bad < bad_all) {
                    bad_all = bad;
                    code_all = code;
                }
            }
        }
        Py_END_ALLOW_THREADS
        Py_ssize_t bad = bad_all;
        int code = code_all;
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
        Py_ssize_t bad_all = -1, q;
        Py_BEGIN_ALLOW_THREADS
#pragma omp parallel for schedule(static) if (nq * rank * (nps + npz) >= PAR_MIN_WORK)
        for (q = 0; q < nq; ++q) {
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
#pragma omp critical(widesky_decode_bad)
                if (bad_all < 0 || q < bad_all) bad_all = q;
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

/* Baseline of the loader benchmark (benchmarks/bench_open.py): every half of a buffer converted on its own,
 * as a scalar decoder does it (sign, exponent and mantissa fields, ldexp; IEEE zero, subnormals, inf, NaN),
 * into float32, one thread: the per-value work any loader that keeps float32 arrays must do at least. */
static float half_scalar(uint16_t h)
{
    int e = (h >> 10) & 31, m = h & 1023;
    double v = e == 0 ? ldexp((double)m, -24) : e == 31 ? (m ? NAN : INFINITY) : ldexp((double)(m | 1024), e - 25);
    return (float)((h >> 15) ? -v : v);
}

static PyObject *py_reference_halves(PyObject *self, PyObject *args)
{
    PyObject *o[2];
    if (!PyArg_ParseTuple(args, "OO", &o[0], &o[1])) return NULL;
    buf_t b[2];
    memset(b, 0, sizeof(b));
    PyObject *ret = NULL;
    if (get_buf(o[0], &b[0], 0, "raw", 2) < 0 || get_buf(o[1], &b[1], 1, "out", 4) < 0) goto done;
    {
        Py_ssize_t n = b[0].b.len / 2;
        if (b[1].b.len / 4 != n) {
            PyErr_SetString(PyExc_ValueError, "reference_halves: out must hold one float32 per half");
            goto done;
        }
        const uint16_t *raw = b[0].b.buf;
        float *out = b[1].b.buf;
        Py_BEGIN_ALLOW_THREADS
        for (Py_ssize_t i = 0; i < n; ++i) out[i] = half_scalar(raw[i]);
        Py_END_ALLOW_THREADS
        ret = Py_None;
        Py_INCREF(ret);
    }
done:
    for (int i = 0; i < 2; ++i) rel_buf(&b[i]);
    return ret;
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

/* one direction: sum over the step's configurations of weight x the configuration's clamped value
 * (the folded polynomials in float32 arithmetic, as the tables are kept; the mixed terms in double) */
HOT static void ceval_dir(const ctab_t *tabs, const int64_t *ci, const double *w, int K, int nc, size_t cell,
                          double g, double z, float *restrict acc)
{
    /* nc: the padded channel count (a multiple of 8) */
    const float fg = (float)g, fz = (float)z, fgz = (float)(g * z), fz2 = (float)(z * z), fgz2 = (float)(g * z * z);
    const double gz = g * z, z2 = z * z, gz2 = gz * z;
    for (int k = 0; k < nc; ++k) acc[k] = 0.0f;
    for (int c = 0; c < K; ++c) {
        const float wc = (float)w[c];
        if (w[c] == 0.0) continue;
        const ctab_t *t = tabs + ci[c];
        const float *restrict T = t->tab + cell * 6 * (size_t)nc;
        for (int k = 0; k < nc; ++k)
            acc[k] += wc * (T[k] + fg * T[nc + k] + fz * T[2 * nc + k] + fgz * T[3 * nc + k] + fz2 * T[4 * nc + k] +
                            fgz2 * T[5 * nc + k]);
        for (int e = t->mix_start[cell]; e < t->mix_start[cell + 1]; ++e) {
            const double *c6 = t->mix_coef + 6 * (size_t)e;
            double v = c6[0] + g * c6[1] + z * c6[2] + gz * c6[3] + z2 * c6[4] + gz2 * c6[5];
            if (v > 0) acc[t->mix_ch[e]] += (float)(w[c] * v);
        }
    }
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
            Py_ssize_t t;
#pragma omp parallel for schedule(dynamic, 4) reduction(|| : fail) if (T * N * (Py_ssize_t)nc * K >= PAR_MIN_WORK)
            for (t = 0; t < T; ++t) {
                float *acc = malloc(sizeof(float) * (size_t)ncp);
                if (!acc) {
                    fail = 1;
                    continue;
                }
                geom_t geo;
                geom_init(&geo, geo_in[3 * t], geo_in[3 * t + 1], geo_in[3 * t + 2]);
                double *ot = out + (size_t)t * nrow * nc;
                if (grouped)
                    for (Py_ssize_t i = 0; i < nrow * nc; ++i) ot[i] = 0.0;
                for (Py_ssize_t i = 0; i < N; ++i) {
                    double g, z;
                    int ig, iz;
                    if (pre_iz) {
                        const double *v = pre_v + 3 * i;
                        ig = accel_cell(&ag, acos(clamp_unit(v[0] * geo.s[0] + v[1] * geo.s[1] + v[2] * geo.s[2])), &g);
                        iz = pre_iz[i];
                        z = pre_z[i];
                    } else {
                        const double *v = dirs + 3 * (shared ? i : (size_t)t * N + i);
                        angles_t a = compute_angles(v, &geo, 0, 0);
                        ig = accel_cell(&ag, a.gamma, &g);
                        iz = accel_cell(&az, a.zero, &z);
                    }
                    ceval_dir(ct, sc + (size_t)t * K, sw + (size_t)t * K, K, ncp, (size_t)ig * (nu - 1) + iz, g, z,
                              acc);
                    if (grouped) {
                        double *o2 = ot + (size_t)rows[i] * nc;
                        const double wi = wts[i];
                        for (int k = 0; k < nc; ++k) o2[k] += wi * acc[k];
                    } else {
                        double *o2 = ot + (size_t)i * nc;
                        for (int k = 0; k < nc; ++k) o2[k] = acc[k];
                    }
                }
                free(acc);
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
    {"reference_halves", py_reference_halves, METH_VARARGS,
     "Baseline: every half converted on its own by a scalar decoder, one thread (loader benchmark)."},
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
