/*
 * widesky skymodel._montecarlo: the hot loop of the Monte Carlo reference solver
 * (skymodel/generator/montecarlo.py validates every argument and documents the method).
 *
 * Backward path tracing of Stokes vectors (I, Q, U, V) from an observer through a layered atmosphere of
 * homogeneous spherical shells (or plane-parallel slabs), next-event estimation toward the sun at every
 * scattering and ground vertex, Rayleigh (with depolarisation) and tabulated aerosol scattering matrices,
 * Lambertian ground. K spectral components share each path (hero wavelengths): the path is sampled with one
 * component chosen per sample (sample index mod K) and every component's contribution is weighted by the
 * one-sample multiple-importance balance heuristic f_k / (1/K sum_j p_j) over the path densities of all K.
 *
 * First order by quadrature (``quad`` mode, views that escape to space): the singly scattered Stokes vector is
 * integrated deterministically along the view ray (sub-intervals of at most ``qstep`` km, split at layer
 * boundaries and at the edge of the Earth's shadow; optical depth to the observer and to the sun interpolated
 * linearly in each sub-interval, the exponential integrated exactly), and the sampled paths carry only orders >= 2:
 * their first vertex is drawn from a mixture, independent of the hero, of the components' forced free-path densities
 * and their single-scattering integrands (scattering x attenuation x sun transmittance: the sunlit part of the ray
 * at twilight), weighted by the mixture density, without next-event estimation at that vertex. Every later free
 * path along a ray that crosses the Earth's shadow (widened by HLIT) is drawn from the mixture of the forced free
 * path and the same conditioned on the part outside the shadow (a share QLIT each), so that vertices land where
 * next-event estimation finds the sun; the hero weights use every component's mixture density.
 *
 * Array in, array out, the GIL released, OpenMP over view directions. Random streams (xoshiro256** seeded by
 * splitmix64), two modes, results independent of threads in both:
 * - independent (corr = 0): every direction has its own stream, seeded from (seed, direction);
 * - correlated (corr = 1, common random numbers): every vertex of every path has its own stream, seeded from
 *   (seed, path index, scattering order) and the same for every direction, and every sampled direction takes its
 *   azimuth in a frame that moves continuously with the view: around the view direction the caller's sampling
 *   frame (sframes), after a scattering the polarisation reference a_cur (the new scattering plane's), around
 *   the ground normal perpendicular(normal) (the normal stays near the observer's zenith) and after a ground
 *   reflection the azimuthal tangent of that frame. Path i of every direction then starts from the same random
 *   numbers and a discrete branch (layer, Rayleigh or aerosol, roulette) desynchronises only that vertex, so the
 *   estimate is piecewise continuous in the view direction: the same noise per direction, far less from one
 *   direction to the next.
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

#define MAXSEG 1024
#define FOUR_PI 12.566370614359172
#define ROULETTE 0.05
#define MAXQ 2048
#ifndef QMIX
#define QMIX 0.75 /* share of the forced free-path densities in the first-vertex mixture */
#endif
#ifndef HLIT
#define HLIT 6.0 /* [km] the sunlit part of a ray for the free-path mixture: outside the shadow of a sphere this much above the ground (the sun seen through less than the densest air) */
#endif
#ifndef QLIT
#define QLIT 0.5 /* share of the plain forced free path where a ray crosses the Earth's shadow */
#endif

/* ------------------------------------------------------------------------------------------ */
/* random numbers                                                                             */

typedef struct {
    uint64_t s[4];
} rng_t;

static inline uint64_t splitmix64(uint64_t *x)
{
    uint64_t z = (*x += 0x9E3779B97F4A7C15ULL);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    return z ^ (z >> 31);
}

static void rng_seed(rng_t *r, uint64_t seed, uint64_t stream)
{
    uint64_t x = seed ^ (stream * 0xD1B54A32D192ED03ULL + 0x2545F4914F6CDD1DULL);
    for (int i = 0; i < 4; ++i) r->s[i] = splitmix64(&x);
}

/* stream of vertex ``order`` of path ``path`` (correlated mode) */
static void rng_seed_vertex(rng_t *r, uint64_t seed, uint64_t path, uint64_t order)
{
    uint64_t x = seed ^ 0x6A09E667F3BCC909ULL, y = path;
    x ^= splitmix64(&y);
    y = order ^ 0xBB67AE8584CAA73BULL;
    x += splitmix64(&y);
    for (int i = 0; i < 4; ++i) r->s[i] = splitmix64(&x);
}

static inline uint64_t rotl(uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }

static inline double rnd(rng_t *r) /* uniform [0, 1) */
{
    uint64_t *s = r->s;
    uint64_t res = rotl(s[1] * 5, 7) * 9, t = s[1] << 17;
    s[2] ^= s[0];
    s[3] ^= s[1];
    s[1] ^= s[2];
    s[0] ^= s[3];
    s[2] ^= t;
    s[3] = rotl(s[3], 45);
    return (double)(res >> 11) * 0x1.0p-53;
}

/* ------------------------------------------------------------------------------------------ */
/* vectors                                                                                    */

static inline double dot(const double *a, const double *b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

static inline void cross(const double *a, const double *b, double *c)
{
    c[0] = a[1] * b[2] - a[2] * b[1];
    c[1] = a[2] * b[0] - a[0] * b[2];
    c[2] = a[0] * b[1] - a[1] * b[0];
}

static inline void normalize(double *a)
{
    double n = sqrt(dot(a, a));
    a[0] /= n;
    a[1] /= n;
    a[2] /= n;
}

/* any unit vector perpendicular to unit d */
static inline void perpendicular(const double *d, double *p)
{
    double t[3] = {0, 0, 0};
    t[fabs(d[0]) < 0.6 ? 0 : (fabs(d[1]) < 0.6 ? 1 : 2)] = 1.0;
    cross(d, t, p);
    normalize(p);
}

/* unit vector at cosine mu from unit d, azimuth phi around it */
static inline void rotate_dir(const double *d, double mu, double phi, double *out)
{
    double u[3], v[3];
    perpendicular(d, u);
    cross(d, u, v);
    double s = sqrt(fmax(0.0, 1.0 - mu * mu)), cp = cos(phi), sp = sin(phi);
    for (int i = 0; i < 3; ++i) out[i] = mu * d[i] + s * (cp * u[i] + sp * v[i]);
    normalize(out);
}

/* unit vector at cosine mu from unit d, azimuth phi from the reference u (perpendicular to d, re-orthogonalised) */
static inline void rotate_dir_ref(const double *d, const double *uref, double mu, double phi, double *out)
{
    double u[3], v[3], c = dot(uref, d);
    for (int i = 0; i < 3; ++i) u[i] = uref[i] - c * d[i];
    normalize(u);
    cross(d, u, v);
    double s = sqrt(fmax(0.0, 1.0 - mu * mu)), cp = cos(phi), sp = sin(phi);
    for (int i = 0; i < 3; ++i) out[i] = mu * d[i] + s * (cp * u[i] + sp * v[i]);
    normalize(out);
}

/* ------------------------------------------------------------------------------------------ */
/* geometry: shells (or slabs) between radii[0..L]                                           */

typedef struct {
    const double *radii; /* (L+1,) [km] from the planet centre (spherical) or altitude (planar) */
    int L;
    int planar;
} geom_t;

typedef struct {
    int layer[MAXSEG];
    double len[MAXSEG];
    int n;
    int end; /* -1 ground, +1 top of atmosphere */
} path_t;

/* Trace the straight ray x + t d (unit d) from layer l to the ground or the top; store segment lengths. */
static void trace_ray(const geom_t *g, const double *x, const double *d, int l, path_t *p)
{
    double pos[3] = {x[0], x[1], x[2]};
    p->n = 0;
    p->end = 1;
    while (p->n < MAXSEG) {
        double t;
        int next;
        if (g->planar) {
            double z = pos[2];
            if (d[2] > 0) {
                t = (g->radii[l + 1] - z) / d[2];
                next = l + 1;
            } else if (d[2] < 0) {
                t = (g->radii[l] - z) / d[2];
                next = l - 1;
            } else {
                t = 1e30;
                next = g->L; /* horizontal in a slab: exits nowhere; treat as escaping after a huge length */
            }
            if (t < 0) t = 0;
        } else {
            double b = dot(pos, d), rr = dot(pos, pos);
            double ro = g->radii[l + 1], ri = g->radii[l];
            next = l + 1;
            t = -b + sqrt(fmax(b * b - (rr - ro * ro), 0.0));
            if (b < 0) {
                double disc = b * b - (rr - ri * ri);
                if (disc >= 0) {
                    t = -b - sqrt(disc);
                    next = l - 1;
                }
            }
            if (t < 0) t = 0;
        }
        p->layer[p->n] = l;
        p->len[p->n] = t;
        p->n++;
        if (next < 0) {
            p->end = -1;
            return;
        }
        if (next >= g->L) {
            p->end = 1;
            return;
        }
        for (int i = 0; i < 3; ++i) pos[i] += t * d[i];
        l = next;
    }
}

/* ------------------------------------------------------------------------------------------ */
/* optics                                                                                     */

typedef struct {
    int K, L, C, G, NA;
    const double *ext, *sca_r, *sca_a; /* (L, K) [km-1] */
    const double *ray;                 /* (K, 2) Rayleigh Delta, Delta' (Hansen & Travis 1974 eq. 2.15) */
    const double *amu;                 /* (NA,) cos(Theta) grid, increasing from -1 to 1 */
    const double *atab;                /* (G, NA, 4) aerosol P11, P12, P33, P34 (mean of P11 over 4 pi = 1) */
    const double *acdf;                /* (G, NA) cumulative integral of P11 over mu (ends at 2) */
    const int32_t *ctab;               /* (K,) aerosol table of each component */
    const double *albedo;              /* (K,) */
    const int32_t *cch;                /* (K,) output channel of each component */
    const double *cw;                  /* (K,) weight of each component in its channel */
    int polarised;
    int nbins; /* >= 1: output cch[k] + min(ground reflections of the path so far, nbins - 1) (1: no binning) */
} optics_t;

/* Rayleigh scattering matrix elements at cosine mu: P11, P12, P33, P44 (P22 = P11 - (1 - Delta)) */
static inline void rayleigh_z(double mu, double dl, double dp, double *z)
{
    double a = 0.75 * dl;
    z[0] = a * (1 + mu * mu) + (1 - dl);  /* P11 */
    z[1] = a * (mu * mu - 1);             /* P12 */
    z[2] = a * (1 + mu * mu);             /* P22 */
    z[3] = 1.5 * dl * mu;                 /* P33 */
    z[4] = 0.0;                           /* P34 */
    z[5] = 1.5 * dl * dp * mu;            /* P44 */
}

/* locate mu in the aerosol grid: index i with amu[i] <= mu < amu[i+1] and fraction */
static inline int grid_find(const double *grid, int n, double mu, double *f)
{
    if (mu <= grid[0]) {
        *f = 0;
        return 0;
    }
    if (mu >= grid[n - 1]) {
        *f = 1;
        return n - 2;
    }
    int lo = 0, hi = n - 1;
    while (hi - lo > 1) {
        int m = (lo + hi) >> 1;
        if (grid[m] <= mu)
            lo = m;
        else
            hi = m;
    }
    *f = (mu - grid[lo]) / (grid[lo + 1] - grid[lo]);
    return lo;
}

/* aerosol matrix (P11, P12, P22 = P11, P33, P34, P44 = P33: spheres) of table g at grid cell (i, f) */
static inline void aerosol_z(const optics_t *o, int g, int i, double f, double *z)
{
    const double *a = o->atab + ((size_t)g * o->NA + i) * 4, *b = a + 4;
    z[0] = a[0] + f * (b[0] - a[0]);
    z[1] = a[1] + f * (b[1] - a[1]);
    z[2] = z[0];
    z[3] = a[2] + f * (b[2] - a[2]);
    z[4] = a[3] + f * (b[3] - a[3]);
    z[5] = z[3];
}

/* sample mu from the piecewise-linear aerosol P11 of table g (exactly the density aerosol_z gives) */
static double sample_aerosol_mu(const optics_t *o, int g, rng_t *r)
{
    const double *cdf = o->acdf + (size_t)g * o->NA;
    double u = rnd(r) * cdf[o->NA - 1];
    int lo = 0, hi = o->NA - 1;
    while (hi - lo > 1) {
        int m = (lo + hi) >> 1;
        if (cdf[m] <= u)
            lo = m;
        else
            hi = m;
    }
    double x0 = o->amu[lo], h = o->amu[lo + 1] - x0;
    double p0 = o->atab[((size_t)g * o->NA + lo) * 4], p1 = o->atab[((size_t)g * o->NA + lo + 1) * 4];
    double m = u - cdf[lo]; /* mass to cover inside the cell: p0 s + (p1 - p0) s^2 / (2 h) = m */
    double s, a = (p1 - p0) / (2 * h);
    if (fabs(a) * h < 1e-12 * (fabs(p0) + 1e-300))
        s = m / p0;
    else {
        double disc = p0 * p0 + 4 * a * m;
        s = 2 * m / (p0 + sqrt(fmax(disc, 0.0)));
    }
    if (s < 0) s = 0;
    if (s > h) s = h;
    return x0 + s;
}

static double sample_rayleigh_mu(double dl, rng_t *r)
{
    double pmax = 1 + 0.5 * dl;
    for (;;) {
        double mu = 2 * rnd(r) - 1;
        if (rnd(r) * pmax <= 0.75 * dl * (1 + mu * mu) + (1 - dl)) return mu;
    }
}

/* Scattering operator of component k in layer l at cosine mu: z6 = (beta_r Z_r + beta_a Z_a) / (4 pi)
 * [km-1 sr-1] as (P11, P12, P22, P33, P34, P44); returns the direction pdf of component k [sr-1]. */
static inline double scatter_op(const optics_t *o, int l, int k, double mu, int ai, double af, double *z6)
{
    double zr[6], za[6];
    double br = o->sca_r[(size_t)l * o->K + k], ba = o->sca_a[(size_t)l * o->K + k];
    rayleigh_z(mu, o->ray[2 * k], o->ray[2 * k + 1], zr);
    if (ba > 0)
        aerosol_z(o, o->ctab[k], ai, af, za);
    else
        memset(za, 0, sizeof(za));
    for (int i = 0; i < 6; ++i) z6[i] = (br * zr[i] + ba * za[i]) / FOUR_PI;
    double bs = br + ba;
    return bs > 0 ? z6[0] / bs : 0.0;
}

/* ------------------------------------------------------------------------------------------ */
/* Stokes algebra: M (4x4, row-major) maps a Stokes vector in the current frame to the observer's frame */

/* cos 2psi, sin 2psi of the rotation from frame (a1, b1 = w x a1) to frame a2 (both perpendicular to w) */
static inline void rot2(const double *a1, const double *b1, const double *a2, double *c2, double *s2)
{
    double c = dot(a1, a2), s = dot(b1, a2), n = c * c + s * s;
    if (n < 1e-300) {
        *c2 = 1;
        *s2 = 0;
        return;
    }
    *c2 = (c * c - s * s) / n;
    *s2 = 2 * c * s / n;
}

/* M <- M L(c2, s2) Z, L = [[1,0,0,0],[0,c,s,0],[0,-s,c,0],[0,0,0,1]], Z from z6 (block form), times f */
static inline void mul_lz(double *M, double c2, double s2, const double *z, double f, int polarised)
{
    for (int i = 0; i < 4; ++i) {
        double *m = M + 4 * i;
        double a0 = m[0], a1 = m[1] * c2 - m[2] * s2, a2 = m[1] * s2 + m[2] * c2, a3 = m[3];
        if (polarised) {
            m[0] = f * (a0 * z[0] + a1 * z[1]);
            m[1] = f * (a0 * z[1] + a1 * z[2]);
            m[2] = f * (a2 * z[3] - a3 * z[4]);
            m[3] = f * (a2 * z[4] + a3 * z[5]);
        } else {
            m[0] = f * a0 * z[0];
            m[1] = m[2] = m[3] = 0;
        }
    }
}

/* ------------------------------------------------------------------------------------------ */
/* one view direction                                                                         */

typedef struct {
    const geom_t *g;
    const optics_t *o;
    const double *sun; /* unit vector toward the sun */
    double obs_r;      /* observer radius (spherical) or altitude (planar) [km] */
    int obs_layer;
    long n_samples;
    int max_order;
    uint64_t seed;
    int quad;     /* 1: first order by quadrature along escaping view rays, sampled paths from order 2 */
    double qstep; /* [km] longest quadrature sub-interval */
    int corr;     /* 1: correlated streams (common random numbers; header comment) */
} job_t;

typedef struct {
    double *M;    /* (K, 16) */
    double *r;    /* (K,) path density of component k over that of the hero */
    double *tau;  /* (K,) */
    double *tot;  /* (K,) */
    double *acc;  /* (C, 4) per-sample contribution */
    double *ss;   /* (C, 4) first order by quadrature of the current direction (quad mode) */
    double *ta, *tb, *pl; /* (K,) each: optical depth to the shadow's edges, sunlit probability (quad mode) */
    int bounces;  /* ground reflections of the current path so far */
    path_t path, sunp;
    /* quadrature of the first order along the view ray: nq sub-intervals [qt[j], qt[j+1]] in layer ql[j] */
    int nq;
    double qt[MAXQ + 1];
    int ql[MAXQ];
    double *qtv;  /* (MAXQ + 1, K) optical depth from the observer to qt[j] */
    double *qa0;  /* (MAXQ, K) log of attenuation x sun transmittance at the sub-interval's start */
    double *qa1;  /* (MAXQ, K) ... and end */
    double *qcw;  /* (MAXQ, K) cumulative scattering-weighted integral (the single-scattering density's cdf) */
    double *qG;   /* (K,) its total */
    double *qT;   /* (K,) optical depth of the whole view ray */
} work_t;

/* output row of component k for light that has been reflected ``extra`` more times by the ground */
static inline int out_row(const optics_t *o, const work_t *w, int k, int extra)
{
    int b = w->bounces + extra;
    return o->cch[k] + (b < o->nbins - 1 ? b : o->nbins - 1);
}

static inline double clamp_exp(double x) { return exp(x > 700 ? 700 : (x < -745 ? -745 : x)); }

/* optical depth of component k along the stored path, up to segment n (whole) and a part of segment n */
static void path_tau(const optics_t *o, const path_t *p, int nfull, int lpart, double part, double *tau)
{
    for (int k = 0; k < o->K; ++k) tau[k] = 0;
    for (int s = 0; s < nfull; ++s) {
        const double *e = o->ext + (size_t)p->layer[s] * o->K;
        for (int k = 0; k < o->K; ++k) tau[k] += p->len[s] * e[k];
    }
    if (part > 0) {
        const double *e = o->ext + (size_t)lpart * o->K;
        for (int k = 0; k < o->K; ++k) tau[k] += part * e[k];
    }
}

/* next-event estimate toward the sun from a scattering vertex (x, layer l) with backward direction d */
static void nee_scatter(const job_t *jb, work_t *w, const double *x, int l, const double *d, const double *a_cur,
                        double denom)
{
    const optics_t *o = jb->o;
    trace_ray(jb->g, x, jb->sun, l, &w->sunp);
    if (w->sunp.end < 0) return;
    path_tau(o, &w->sunp, w->sunp.n, 0, 0, w->tot);
    double win[3] = {-jb->sun[0], -jb->sun[1], -jb->sun[2]}, wout[3] = {-d[0], -d[1], -d[2]};
    double mu = dot(jb->sun, d), n[3], p_out[3], c2 = 1, s2 = 0;
    cross(win, wout, n);
    if (dot(n, n) > 1e-24) {
        normalize(n);
        cross(n, wout, p_out);
        rot2(p_out, n, a_cur, &c2, &s2);
    }
    int ai = 0;
    double af = 0;
    ai = grid_find(o->amu, o->NA, mu, &af);
    for (int k = 0; k < o->K; ++k) {
        double z6[6], t = clamp_exp(-w->tot[k]);
        if (t < 1e-300) continue;
        scatter_op(o, l, k, mu, ai, af, z6);
        const double *M = w->M + 16 * k;
        /* S = M L Z e1: only the first column of L Z is needed: (P11, c2 P12, -s2 P12, 0) */
        double f = t * o->cw[k] / denom;
        double col[4] = {z6[0], c2 * z6[1], -s2 * z6[1], 0};
        if (!o->polarised) col[1] = col[2] = 0;
        double *acc = w->acc + 4 * out_row(o, w, k, 0);
        for (int i = 0; i < 4; ++i)
            acc[i] += f * (M[4 * i] * col[0] + M[4 * i + 1] * col[1] + M[4 * i + 2] * col[2]);
    }
}

static void nee_ground(const job_t *jb, work_t *w, const double *x, const double *nrm, double denom)
{
    const optics_t *o = jb->o;
    double cs = dot(nrm, jb->sun);
    if (cs <= 0) return;
    trace_ray(jb->g, x, jb->sun, 0, &w->sunp);
    if (w->sunp.end < 0) return;
    path_tau(o, &w->sunp, w->sunp.n, 0, 0, w->tot);
    for (int k = 0; k < o->K; ++k) {
        double t = clamp_exp(-w->tot[k]);
        double f = t * o->albedo[k] / M_PI * cs * o->cw[k] / denom;
        const double *M = w->M + 16 * k;
        double *acc = w->acc + 4 * out_row(o, w, k, 1);
        for (int i = 0; i < 4; ++i) acc[i] += f * M[4 * i];
    }
}

/* ------------------------------------------------------------------------------------------ */
/* first order by quadrature along the view ray (quad mode)                                   */

#define QGMIN 1e-280

/* integral over [0, h] of exp(a0 + (a1 - a0) s / h) ds, for a0, a1 <= ~700 */
static inline double explin_int(double a0, double a1, double h)
{
    double d = fabs(a1 - a0), m = fmax(a0, a1);
    if (m < -745) return 0.0;
    if (d < 1e-9) return h * exp(0.5 * (a0 + a1));
    return h * exp(m) * (-expm1(-d)) / d;
}

/* s in [0, h] drawn with density proportional to exp((a1 - a0) s / h) */
static inline double explin_sample(double a0, double a1, double h, double u)
{
    double d = a1 - a0;
    if (fabs(d) < 1e-9) return u * h;
    if (d > 700) d = 700;
    double s = d > 0 ? h * (1.0 + log(u + (1.0 - u) * exp(-d)) / d) : h * log1p(u * expm1(d)) / d;
    return s < 0 ? 0 : (s > h ? h : s);
}

/* distances t > 0 along x0 + t d where the ray crosses the edge of the Earth's shadow (cylinder of the ground
 * radius around the sun's axis, on the night side); returns how many (0..2), ascending */
static int shadow_edges(const geom_t *g, const double *sun, const double *x0, const double *d, double *roots)
{
    if (g->planar) return 0;
    double xs = dot(x0, sun), ds = dot(d, sun), xp[3], dp[3];
    for (int i = 0; i < 3; ++i) {
        xp[i] = x0[i] - xs * sun[i];
        dp[i] = d[i] - ds * sun[i];
    }
    double A = dot(dp, dp), B = 2 * dot(xp, dp), nx = sqrt(dot(xp, xp)), R = g->radii[0];
    double C = (nx - R) * (nx + R), disc = B * B - 4 * A * C;
    if (A < 1e-300 || disc < 0) return 0;
    double q = -0.5 * (B + copysign(sqrt(disc), B)), r[2] = {q / A, q != 0 ? C / q : q / A};
    if (r[0] > r[1]) {
        double t = r[0];
        r[0] = r[1];
        r[1] = t;
    }
    int n = 0;
    for (int i = 0; i < 2; ++i)
        if (r[i] > 0 && xs + r[i] * ds < 0 && (n == 0 || r[i] > roots[0])) roots[n++] = r[i];
    return n;
}

/* optical depth to the sun from point p in layer l into tau (K,); returns 0 when the planet is in the way */
static int sun_tau(const job_t *jb, work_t *w, const double *p, int l, double *tau)
{
    trace_ray(jb->g, p, jb->sun, l, &w->sunp);
    if (w->sunp.end < 0) return 0;
    path_tau(jb->o, &w->sunp, w->sunp.n, 0, 0, tau);
    return 1;
}

/* Set up the quadrature of the escaping view ray vp (from x0 along d, observer frame a) and add its singly
 * scattered Stokes vectors (per unit solar irradiance) to ss (C, 4). */
static void quad_setup(const job_t *jb, work_t *w, const double *x0, const double *d, const double *a,
                       const path_t *vp, double *ss)
{
    const optics_t *o = jb->o;
    const int K = o->K;
    double roots[2], total = 0;
    int nr = shadow_edges(jb->g, jb->sun, x0, d, roots);
    for (int s = 0; s < vp->n; ++s) total += vp->len[s];
    double step = fmax(jb->qstep, total / (MAXQ - 2 * vp->n - 8));
    /* geometry of the single scattering (the same at every point: the sun is at infinity) */
    double win[3] = {-jb->sun[0], -jb->sun[1], -jb->sun[2]}, wout[3] = {-d[0], -d[1], -d[2]};
    double mu = dot(jb->sun, d), n[3], p_out[3], c2 = 1, s2 = 0, af = 0;
    cross(win, wout, n);
    if (dot(n, n) > 1e-24) {
        normalize(n);
        cross(n, wout, p_out);
        rot2(p_out, n, a, &c2, &s2);
    }
    int ai = grid_find(o->amu, o->NA, mu, &af);
    double *ta = w->tau, *tb = w->tot, *jseg = w->r; /* scratch (K,) each */
    int nq = 0;
    double t_seg = 0;
    for (int k = 0; k < K; ++k) {
        w->qtv[k] = 0;
        w->qG[k] = 0;
    }
    for (int s = 0; s < vp->n; ++s) {
        int l = vp->layer[s];
        double len = vp->len[s], t_end = t_seg + len;
        int m = (int)ceil(len / step);
        if (m < 1) m = 1;
        for (int k = 0; k < K; ++k) jseg[k] = 0;
        double t0 = t_seg;
        int ir = 0;
        while (ir < nr && roots[ir] <= t_seg) ++ir;
        for (int i = 1; i <= m; ++i) {
            double t1 = i == m ? t_end : t_seg + len * i / m;
            for (;;) {
                double tb1 = t1; /* a shadow edge before t1 closes a sub-interval first */
                if (ir < nr && roots[ir] < t1) tb1 = roots[ir++];
                double h = tb1 - t0;
                if (h <= 1e-9 || nq >= MAXQ) {
                    if (tb1 == t1) break;
                    continue;
                }
                double del = fmin(1e-6 + 1e-6 * h, 0.25 * h), p0[3], p1[3];
                for (int c = 0; c < 3; ++c) {
                    p0[c] = x0[c] + (t0 + del) * d[c];
                    p1[c] = x0[c] + (tb1 - del) * d[c];
                }
                int lit0 = sun_tau(jb, w, p0, l, ta), lit1 = sun_tau(jb, w, p1, l, tb);
                const double *ext = o->ext + (size_t)l * K;
                double *tv0 = w->qtv + (size_t)nq * K, *tv1 = tv0 + K;
                double *qa0 = w->qa0 + (size_t)nq * K, *qa1 = w->qa1 + (size_t)nq * K;
                double *cw = w->qcw + (size_t)nq * K;
                for (int k = 0; k < K; ++k) {
                    tv1[k] = tv0[k] + ext[k] * h;
                    double a0 = lit0 ? -(tv0[k] + ta[k]) : -1e300, a1 = lit1 ? -(tv1[k] + tb[k]) : -1e300;
                    if (!lit0 && lit1) a0 = a1 - 30; /* one end in the shadow: a steep fall instead of a jump */
                    if (lit0 && !lit1) a1 = a0 - 30;
                    qa0[k] = a0;
                    qa1[k] = a1;
                    double J = (lit0 || lit1) ? explin_int(a0, a1, h) : 0.0;
                    jseg[k] += J;
                    w->qG[k] += (o->sca_r[(size_t)l * K + k] + o->sca_a[(size_t)l * K + k]) * J;
                    cw[k] = w->qG[k];
                }
                w->qt[nq] = t0;
                w->ql[nq] = l;
                ++nq;
                t0 = tb1;
                if (tb1 == t1) break;
            }
        }
        for (int k = 0; k < K; ++k) {
            if (jseg[k] <= 0) continue;
            double z6[6];
            scatter_op(o, l, k, mu, ai, af, z6);
            double f = jseg[k] * o->cw[k], *acc = ss + 4 * o->cch[k];
            acc[0] += f * z6[0];
            if (o->polarised) {
                acc[1] += f * c2 * z6[1];
                acc[2] += f * (-s2) * z6[1];
            }
        }
        t_seg = t_end;
    }
    w->qt[nq] = t_seg;
    w->nq = nq;
    for (int k = 0; k < K; ++k) w->qT[k] = w->qtv[(size_t)nq * K + k];
}

/* First vertex of a path of order >= 2 on the view ray (quad mode): t from the hero-independent mixture
 * q(t) = 1/K sum_k [QMIX p_free,k(t) + (1 - QMIX) p_ss,k(t)]; sets x, multiplies M_k by exp(-tau_k(t)) / q(t);
 * returns the layer (or -1). */
static int quad_first(const job_t *jb, work_t *w, rng_t *rng, const double *x0, const double *d, double *x)
{
    const optics_t *o = jb->o;
    const int K = o->K, nq = w->nq;
    if (nq < 1) return -1;
    int k1 = (int)(rnd(rng) * K), j;
    if (k1 >= K) k1 = K - 1;
    double u = rnd(rng), t;
    if (rnd(rng) < QMIX || w->qG[k1] <= QGMIN) {
        double q = -expm1(-w->qT[k1]);
        if (q <= 0) return -1;
        double target = -log1p(-u * q);
        int lo = 0, hi = nq;
        while (hi - lo > 1) {
            int mid = (lo + hi) >> 1;
            if (w->qtv[(size_t)mid * K + k1] <= target)
                lo = mid;
            else
                hi = mid;
        }
        j = lo;
        double e = o->ext[(size_t)w->ql[j] * K + k1];
        t = w->qt[j] + (e > 0 ? (target - w->qtv[(size_t)j * K + k1]) / e : 0);
    } else {
        double target = u * w->qG[k1];
        int lo = -1, hi = nq - 1; /* first j with cdf[j] > target */
        while (hi - lo > 1) {
            int mid = (lo + hi) >> 1;
            if (w->qcw[(size_t)mid * K + k1] > target)
                hi = mid;
            else
                lo = mid;
        }
        j = hi;
        t = w->qt[j] + explin_sample(w->qa0[(size_t)j * K + k1], w->qa1[(size_t)j * K + k1],
                                     w->qt[j + 1] - w->qt[j], rnd(rng));
    }
    double t0 = w->qt[j], h = w->qt[j + 1] - t0;
    if (t < t0) t = t0;
    if (t > t0 + h) t = t0 + h;
    int l = w->ql[j];
    const double *ext = o->ext + (size_t)l * K;
    double q = 0;
    for (int k = 0; k < K; ++k) {
        double tv = w->qtv[(size_t)j * K + k] + ext[k] * (t - t0), att = clamp_exp(-tv);
        double qf = -expm1(-w->qT[k]), pe = qf > 0 ? ext[k] * att / qf : 0, ps = pe;
        if (w->qG[k] > QGMIN) {
            double a0 = w->qa0[(size_t)j * K + k], a1 = w->qa1[(size_t)j * K + k];
            double a = h > 0 ? a0 + (a1 - a0) * (t - t0) / h : a0;
            ps = (o->sca_r[(size_t)l * K + k] + o->sca_a[(size_t)l * K + k]) * clamp_exp(a) / w->qG[k];
        }
        q += QMIX * pe + (1 - QMIX) * ps;
        w->tau[k] = att;
    }
    q /= K;
    if (!(q > 0)) return -1;
    for (int k = 0; k < K; ++k) {
        double f = w->tau[k] / q, *M = w->M + 16 * k;
        for (int i = 0; i < 16; ++i) M[i] *= f;
    }
    for (int c = 0; c < 3; ++c) x[c] = x0[c] + t * d[c];
    return l;
}


/* The part [sa, sb] (distances along x + t d, 0 <= t <= len) in the shadow of a sphere HLIT above the ground
 * (the Earth's shadow widened by the air that dims grazing sunlight most); 0 if none. */
static int shadow_span(const job_t *jb, const double *x, const double *d, double len, double *sa, double *sb)
{
    const double *sun = jb->sun;
    if (jb->g->planar) return 0;
    double xs = dot(x, sun), ds = dot(d, sun), xp[3], dp[3];
    for (int i = 0; i < 3; ++i) {
        xp[i] = x[i] - xs * sun[i];
        dp[i] = d[i] - ds * sun[i];
    }
    double A = dot(dp, dp), B = 2 * dot(xp, dp), nx = sqrt(dot(xp, xp)), R = jb->g->radii[0] + HLIT;
    double C = (nx - R) * (nx + R), disc = B * B - 4 * A * C;
    if (A < 1e-12 || disc <= 0) return 0;
    double q = -0.5 * (B + copysign(sqrt(disc), B)), r0 = q / A, r1 = q != 0 ? C / q : q / A;
    if (r0 > r1) {
        double t = r0;
        r0 = r1;
        r1 = t;
    }
    double lo = fmax(r0, 0.0), hi = fmin(r1, len);
    if (ds > 0)
        hi = fmin(hi, -xs / ds);
    else if (ds < 0)
        lo = fmax(lo, -xs / ds);
    else if (xs >= 0)
        return 0;
    if (hi - lo <= 1e-9) return 0;
    *sa = lo;
    *sb = hi;
    return 1;
}

/* optical depth of every component from the start of the stored path to distance dist along it */
static void tau_at(const optics_t *o, const path_t *p, double dist, double *tau)
{
    for (int k = 0; k < o->K; ++k) tau[k] = 0;
    for (int s = 0; s < p->n && dist > 0; ++s) {
        double t = fmin(dist, p->len[s]);
        const double *e = o->ext + (size_t)p->layer[s] * o->K;
        for (int k = 0; k < o->K; ++k) tau[k] += t * e[k];
        dist -= t;
    }
}

#define LITMIN 1e-12

static void trace_direction(const job_t *jb, work_t *w, const double *view, const double *frame,
                            const double *sframe, long dir, double *sum, double *sumsq)
{
    const optics_t *o = jb->o;
    const geom_t *g = jb->g;
    const int K = o->K, C = o->C;
    rng_t rng;
    const int corr = jb->corr;
    if (!corr) rng_seed(&rng, jb->seed, (uint64_t)dir);
    const double x_obs[3] = {0, 0, jb->obs_r};
    int quad = 0;
    memset(w->ss, 0, sizeof(double) * 4 * C);
    if (jb->quad) {
        trace_ray(g, x_obs, view, jb->obs_layer, &w->path);
        if (w->path.end > 0) {
            quad = 1;
            quad_setup(jb, w, x_obs, view, frame, &w->path, w->ss);
        }
    }
    for (long smp = 0; smp < jb->n_samples; ++smp) {
        int h = (int)(smp % K);
        memcpy(w->acc, w->ss, sizeof(double) * 4 * C); /* the first order by quadrature (zero otherwise) */
        w->bounces = 0;
        for (int k = 0; k < K; ++k) {
            double *M = w->M + 16 * k;
            memset(M, 0, sizeof(double) * 16);
            M[0] = M[5] = M[10] = M[15] = 1.0;
            w->r[k] = 1.0;
        }
        double x[3] = {0, 0, jb->obs_r}, d[3] = {view[0], view[1], view[2]}, a_cur[3] = {frame[0], frame[1],
                                                                                               frame[2]};
        int l = jb->obs_layer;
        for (int order = 0; order < jb->max_order; ++order) {
            int lc;
            /* correlated streams: this vertex's own stream, and the uniforms of its discrete choices drawn first in
             * a fixed order, so that a branch taken differently in another direction leaves the others in step */
            double U[7];
            if (corr) {
                rng_seed_vertex(&rng, jb->seed, (uint64_t)smp, (uint64_t)order);
                for (int i = 0; i < 7; ++i) U[i] = rnd(&rng);
            }
#define RND(i) (corr ? U[i] : rnd(&rng))
            if (quad && order == 0) {
                lc = l = quad_first(jb, w, &rng, x_obs, d, x);
                if (l < 0) break;
            } else {
            trace_ray(g, x, d, l, &w->path);
            path_t *p = &w->path;
            path_tau(o, p, p->n, 0, 0, w->tot);
            double T_h = w->tot[h];
            int forced = p->end > 0;
            double target, norm_h = 1.0, sa = 0, sb = 0;
            /* quad mode, a ray through the Earth's shadow: the free path is drawn from a mixture of the forced
             * free path (QLIT) and the same conditioned on the sunlit part; pl (K,) that part's probability */
            int shade = 0;
            if (jb->quad) {
                double len = 0;
                for (int q = 0; q < p->n; ++q) len += p->len[q];
                shade = shadow_span(jb, x, d, len, &sa, &sb);
            }
            if (shade) {
                tau_at(o, p, sa, w->ta);
                tau_at(o, p, sb, w->tb);
                for (int k = 0; k < K; ++k) {
                    double m = -expm1(-w->ta[k]) + fmax(clamp_exp(-w->tb[k]) - clamp_exp(-w->tot[k]), 0.0);
                    double qk = -expm1(-w->tot[k]);
                    w->pl[k] = forced ? (qk > 0 ? m / qk : 0) : m;
                }
            }
            if (shade && w->pl[h] > LITMIN && RND(0) >= QLIT) {
                double m1 = -expm1(-w->ta[h]), eb = clamp_exp(-w->tb[h]);
                double m2 = fmax(eb - clamp_exp(-T_h), 0.0), v = RND(1) * (m1 + m2);
                target = v < m1 ? -log1p(-v) : -log(fmax(eb - (v - m1), 1e-300));
                if (target > T_h) target = T_h;
                if (forced) norm_h = -expm1(-T_h);
                if (!forced && target >= T_h) target = nextafter(T_h, 0);
            } else if (forced) {
                /* escaping rays contribute nothing: force the collision, weight by 1 - exp(-T) */
                double q = -expm1(-T_h);
                if (q <= 0) break;
                target = -log1p(-RND(1) * q);
                norm_h = q;
            } else {
                target = -log(1.0 - RND(1));
            }
            if (!forced && target >= T_h) {
                /* reached the ground */
                double denom = 0, mh = (shade && w->pl[h] > LITMIN) ? QLIT : 1.0;
                for (int k = 0; k < K; ++k) {
                    double f = clamp_exp(T_h - w->tot[k]), mk = (shade && w->pl[k] > LITMIN) ? QLIT : 1.0;
                    w->r[k] *= f * mk / mh;
                    f /= mh;
                    double *M = w->M + 16 * k;
                    for (int i = 0; i < 16; ++i) M[i] *= f;
                    denom += w->r[k];
                }
                denom /= K;
                double dist = 0;
                for (int s = 0; s < p->n; ++s) dist += p->len[s];
                for (int i = 0; i < 3; ++i) x[i] += dist * d[i];
                double nrm[3] = {0, 0, 1};
                if (!g->planar) {
                    nrm[0] = x[0];
                    nrm[1] = x[1];
                    nrm[2] = x[2];
                    normalize(nrm);
                    double rg = g->radii[0]; /* snap onto the ground sphere */
                    for (int i = 0; i < 3; ++i) x[i] = rg * nrm[i];
                } else {
                    x[2] = g->radii[0];
                }
                nee_ground(jb, w, x, nrm, denom);
                /* Lambertian reflection: cosine-weighted direction, M <- albedo M E11 (depolarising) */
                double mu = sqrt(RND(5)), phi = 2 * M_PI * RND(6);
                if (corr) {
                    double u[3], v[3];
                    perpendicular(nrm, u);
                    cross(nrm, u, v);
                    rotate_dir_ref(nrm, u, mu, phi, d);
                    for (int i = 0; i < 3; ++i) a_cur[i] = -sin(phi) * u[i] + cos(phi) * v[i]; /* azimuthal tangent */
                } else {
                    rotate_dir(nrm, mu, phi, d);
                }
                double tmax = 0;
                for (int k = 0; k < K; ++k) {
                    double *M = w->M + 16 * k;
                    for (int i = 0; i < 4; ++i) {
                        M[4 * i] *= o->albedo[k];
                        M[4 * i + 1] = M[4 * i + 2] = M[4 * i + 3] = 0;
                    }
                    tmax = fmax(tmax, fabs(M[0]));
                }
                if (!corr) perpendicular(d, a_cur);
                w->bounces++;
                l = 0;
                if (tmax / denom <= 0) break;
                if (order >= 2 && tmax / denom < ROULETTE) {
                    double q = tmax / denom / ROULETTE;
                    if (RND(4) >= q) break;
                    for (int k = 0; k < 16 * K; ++k) w->M[k] /= q;
                }
                continue;
            }
            /* collision inside segment s */
            int s = 0;
            double acc_tau = 0, part = 0;
            for (s = 0; s < p->n; ++s) {
                double dt = p->len[s] * o->ext[(size_t)p->layer[s] * K + h];
                if (acc_tau + dt >= target || s == p->n - 1) {
                    double e = o->ext[(size_t)p->layer[s] * K + h];
                    part = e > 0 ? (target - acc_tau) / e : 0;
                    if (part > p->len[s]) part = p->len[s];
                    if (part < 0) part = 0;
                    break;
                }
                acc_tau += dt;
            }
            lc = p->layer[s];
            path_tau(o, p, s, lc, part, w->tau);
            double dist = part;
            for (int q = 0; q < s; ++q) dist += p->len[q];
            for (int i = 0; i < 3; ++i) x[i] += dist * d[i];
            l = lc;
            const double *ext = o->ext + (size_t)lc * K;
            int lit = !(shade && dist > sa && dist < sb);
#define LITMIX(k) ((shade && w->pl[k] > LITMIN) ? QLIT + (1 - QLIT) * lit / w->pl[k] : 1.0)
            double ph = ext[h] / norm_h * LITMIX(h); /* hero density up to exp(-tau_h), factored out below */
            double denom = 0;
            for (int k = 0; k < K; ++k) {
                double e = clamp_exp(w->tau[h] - w->tau[k]);
                double pk = ext[k] * e * LITMIX(k);
                if (forced) {
                    double qk = -expm1(-w->tot[k]);
                    pk = qk > 0 ? pk / qk : 0;
                }
                w->r[k] *= pk / ph;
                double f = e / ph;
                double *M = w->M + 16 * k;
                for (int i = 0; i < 16; ++i) M[i] *= f;
                denom += w->r[k];
            }
            denom /= K;
            nee_scatter(jb, w, x, l, d, a_cur, denom);
            }
            /* sample the next direction from the hero's phase function */
            double br = o->sca_r[(size_t)lc * K + h], ba = o->sca_a[(size_t)lc * K + h];
            if (br + ba <= 0) break;
            double mu = (RND(2) * (br + ba) < br) ? sample_rayleigh_mu(o->ray[2 * h], &rng)
                                                     : sample_aerosol_mu(o, o->ctab[h], &rng);
            double dn[3];
            if (corr)
                rotate_dir_ref(d, order == 0 ? sframe : a_cur, mu, 2 * M_PI * U[3], dn);
            else
                rotate_dir(d, mu, 2 * M_PI * rnd(&rng), dn);
            mu = dot(dn, d);
            if (mu > 1) mu = 1;
            if (mu < -1) mu = -1;
            double win[3] = {-dn[0], -dn[1], -dn[2]}, wout[3] = {-d[0], -d[1], -d[2]}, nv[3], p_out[3], p_in[3];
            double c2 = 1, s2 = 0;
            cross(win, wout, nv);
            if (dot(nv, nv) > 1e-24) {
                normalize(nv);
                cross(nv, wout, p_out);
                cross(nv, win, p_in);
                rot2(p_out, nv, a_cur, &c2, &s2);
            } else {
                /* forward or backward: the scattering plane is arbitrary; keep the current frame */
                cross(wout, a_cur, nv);
                p_in[0] = a_cur[0];
                p_in[1] = a_cur[1];
                p_in[2] = a_cur[2];
                if (mu < 0) { /* backscatter reverses the propagation: keep a right-handed (a, w x a) */
                    p_in[0] = -a_cur[0];
                    p_in[1] = -a_cur[1];
                    p_in[2] = -a_cur[2];
                }
            }
            int ai;
            double af;
            ai = grid_find(o->amu, o->NA, mu, &af);
            double z6[6], qh = 0;
            double zs[6];
            qh = scatter_op(o, lc, h, mu, ai, af, zs);
            if (qh <= 0) break;
            double tmax = 0, denom = 0;
            for (int k = 0; k < K; ++k) {
                double qk = scatter_op(o, lc, k, mu, ai, af, z6);
                w->r[k] *= qk / qh;
                mul_lz(w->M + 16 * k, c2, s2, z6, 1.0 / qh, o->polarised);
                denom += w->r[k];
                tmax = fmax(tmax, fabs(w->M[16 * k]));
            }
            denom /= K;
            d[0] = dn[0];
            d[1] = dn[1];
            d[2] = dn[2];
            a_cur[0] = p_in[0];
            a_cur[1] = p_in[1];
            a_cur[2] = p_in[2];
            if (denom <= 0 || tmax <= 0) break;
            if (order >= 2 && tmax / denom < ROULETTE) {
                double q = tmax / denom / ROULETTE;
                if (RND(4) >= q) break;
                for (int k = 0; k < 16 * K; ++k) w->M[k] /= q;
            }
        }
#undef RND
        for (int i = 0; i < 4 * C; ++i) {
            sum[i] += w->acc[i];
            sumsq[i] += w->acc[i] * w->acc[i];
        }
    }
}

/* ------------------------------------------------------------------------------------------ */
/* Python interface                                                                           */

typedef struct {
    Py_buffer b;
    int held;
} buf_t;

static int get_buf(PyObject *o, buf_t *bb, int writable, const char *name, Py_ssize_t itemsize, Py_ssize_t n)
{
    if (PyObject_GetBuffer(o, &bb->b, (writable ? PyBUF_WRITABLE : 0) | PyBUF_C_CONTIGUOUS | PyBUF_FORMAT) < 0)
        return -1;
    bb->held = 1;
    if (bb->b.itemsize != itemsize || bb->b.len != n * itemsize) {
        PyErr_Format(PyExc_ValueError, "%s: expected %zd items of %zd bytes, got %zd bytes of items of %zd", name,
                     n, itemsize, bb->b.len, bb->b.itemsize);
        return -1;
    }
    return 0;
}

#define NB 17

/* trace(radii, planar, ext, sca_r, sca_a, ray, amu, atab, acdf, ctab, albedo, cch, cw, n_channels, sun,
 *       obs_r, obs_layer, views, frames, n_samples, seed, max_order, polarised, nthreads, sum, sumsq, nbins
 *       [, quad=0, qstep=2.0, sframes=None])
 * shapes: radii (L+1,), ext/sca_r/sca_a (L, K), ray (K, 2), amu (NA,), atab (G, NA, 4), acdf (G, NA),
 * ctab (K,) int32, albedo (K,), cch (K,) int32, cw (K,), sun (3,), views/frames (N, 3),
 * sum/sumsq (N, C, 4) float64, accumulated in place; nbins >= 1 output rows per channel (cch[k] + nbins - 1 < C)
 * split by the number of ground reflections before the light reaches the observer (the last row holds the rest);
 * quad: first order by quadrature along escaping view rays with sub-intervals of at most qstep [km];
 * sframes (N, 3), unit vectors perpendicular to the views: correlated streams with these azimuth references around
 * the view directions (None: independent streams). */
static PyObject *py_trace(PyObject *self, PyObject *args)
{
    (void)self;
    PyObject *o[NB];
    int planar, nch, obs_layer, max_order, polarised, nthreads, L, K, G, NA, nbins;
    long nsamp;
    double obs_r;
    unsigned long long seed;
    int N, quad = 0;
    double qstep = 2.0;
    PyObject *osf = Py_None;
    if (!PyArg_ParseTuple(args, "iiiiiOiOOOOOOOOOOOiOdiOOlKiiiOOi|idO", &L, &K, &G, &NA, &planar, &o[0], &nch, &o[1],
                          &o[2], &o[3], &o[4], &o[5], &o[6], &o[7], &o[8], &o[9], &o[10], &o[11], &N, &o[12],
                          &obs_r, &obs_layer, &o[13], &o[14], &nsamp, &seed, &max_order, &polarised, &nthreads,
                          &o[15], &o[16], &nbins, &quad, &qstep, &osf))
        return NULL;
    buf_t b[NB], bsf;
    memset(b, 0, sizeof(b));
    memset(&bsf, 0, sizeof(bsf));
    PyObject *ret = NULL;
    if (L < 1 || K < 1 || G < 1 || NA < 2 || nch < 1 || N < 0 || nsamp < 1 || obs_layer < 0 || obs_layer >= L ||
        max_order < 1 || nbins < 1 || !(qstep > 0)) {
        PyErr_SetString(PyExc_ValueError, "montecarlo trace: invalid sizes");
        return NULL;
    }
    const Py_ssize_t n[NB] = {L + 1, (Py_ssize_t)L * K, (Py_ssize_t)L * K, (Py_ssize_t)L * K, 2 * K, NA,
                              (Py_ssize_t)G * NA * 4, (Py_ssize_t)G * NA, K, K, K, K, 3, 3 * N, 3 * N,
                              N * nch * 4, N * nch * 4};
    const Py_ssize_t isz[NB] = {8, 8, 8, 8, 8, 8, 8, 8, 4, 8, 4, 8, 8, 8, 8, 8, 8};
    const char *names[NB] = {"radii", "ext", "sca_r", "sca_a", "ray", "amu", "atab", "acdf", "ctab", "albedo",
                             "cch", "cw", "sun", "views", "frames", "sum", "sumsq"};
    /* argument order in o[]: 0 radii, 1 ext, 2 sca_r, 3 sca_a, 4 ray, 5 amu, 6 atab, 7 acdf, 8 ctab,
     * 9 albedo, 10 cch, 11 cw, 12 sun, 13 views, 14 frames, 15 sum, 16 sumsq */
    for (int i = 0; i < NB; ++i)
        if (get_buf(o[i], &b[i], i >= 15, names[i], isz[i], n[i]) < 0) goto done;
    if (osf != Py_None && get_buf(osf, &bsf, 0, "sframes", 8, 3 * (Py_ssize_t)N) < 0) goto done;
    {
        const int32_t *ctab = (const int32_t *)b[8].b.buf, *cch = (const int32_t *)b[10].b.buf;
        for (int k = 0; k < K; ++k)
            if (ctab[k] < 0 || ctab[k] >= G || cch[k] < 0 || cch[k] + nbins - 1 >= nch) {
                PyErr_SetString(PyExc_ValueError, "montecarlo trace: component table or channel out of range");
                goto done;
            }
        geom_t g = {(const double *)b[0].b.buf, L, planar};
        optics_t op = {K, L, nch, G, NA, (const double *)b[1].b.buf, (const double *)b[2].b.buf,
                       (const double *)b[3].b.buf, (const double *)b[4].b.buf, (const double *)b[5].b.buf,
                       (const double *)b[6].b.buf, (const double *)b[7].b.buf, ctab, (const double *)b[9].b.buf,
                       cch, (const double *)b[11].b.buf, polarised, nbins};
        job_t jb = {&g, &op, (const double *)b[12].b.buf, obs_r, obs_layer, nsamp, max_order, (uint64_t)seed,
                    quad != 0, qstep, osf != Py_None};
        const double *views = (const double *)b[13].b.buf, *frames = (const double *)b[14].b.buf;
        const double *sframes = jb.corr ? (const double *)bsf.b.buf : frames;
        double *sum = (double *)b[15].b.buf, *sumsq = (double *)b[16].b.buf;
        int err = 0;
        Py_BEGIN_ALLOW_THREADS
#ifdef WIDESKY_OPENMP
        if (nthreads > 0) omp_set_num_threads(nthreads);
#pragma omp parallel
#endif
        {
            work_t *w = (work_t *)malloc(sizeof(work_t));
            size_t nq = jb.quad ? (size_t)K * (4 * MAXQ + 3) : 0;
            double *mem = w ? (double *)malloc(sizeof(double) * ((size_t)K * 22 + 8 * (size_t)nch + nq)) : NULL;
            if (!mem) {
#ifdef WIDESKY_OPENMP
#pragma omp atomic write
#endif
                err = 1;
            } else {
                w->M = mem;
                w->r = mem + 16 * (size_t)K;
                w->tau = w->r + K;
                w->tot = w->tau + K;
                w->acc = w->tot + K;
                w->ss = w->acc + 4 * (size_t)nch;
                w->qtv = w->ss + 4 * (size_t)nch; /* (MAXQ + 1) K */
                w->qa0 = w->qtv + (size_t)(MAXQ + 1) * K;
                w->qa1 = w->qa0 + (size_t)MAXQ * K;
                w->qcw = w->qa1 + (size_t)MAXQ * K;
                w->qG = w->qcw + (size_t)MAXQ * K;
                w->qT = w->qG + K;
                w->ta = (jb.quad ? w->qT : w->ss + 4 * (size_t)nch - K) + K;
                w->tb = w->ta + K;
                w->pl = w->tb + K;
            }
#ifdef WIDESKY_OPENMP
#pragma omp for schedule(dynamic, 1)
#endif
            for (Py_ssize_t i = 0; i < N; ++i)
                if (mem)
                    trace_direction(&jb, w, views + 3 * i, frames + 3 * i, sframes + 3 * i, (long)i,
                                    sum + (size_t)i * nch * 4, sumsq + (size_t)i * nch * 4);
            free(mem);
            free(w);
        }
        Py_END_ALLOW_THREADS
        (void)nthreads;
        if (err) {
            PyErr_NoMemory();
            goto done;
        }
        Py_INCREF(Py_None);
        ret = Py_None;
    }
done:
    for (int i = 0; i < NB; ++i)
        if (b[i].held) PyBuffer_Release(&b[i].b);
    if (bsf.held) PyBuffer_Release(&bsf.b);
    return ret;
}

static PyMethodDef methods[] = {
    {"trace", py_trace, METH_VARARGS, "Backward Monte Carlo tracing of Stokes vectors (see montecarlo.py)."},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef moddef = {PyModuleDef_HEAD_INIT, "_montecarlo",
                                    "Monte Carlo reference solver kernel (widesky).", -1, methods};

PyMODINIT_FUNC PyInit__montecarlo(void) { return PyModule_Create(&moddef); }
