/*
 * sim_rate.c — step rate and acceleration estimates with quantisation bounds
 * (see sim_rate.h for the model and the definitions).
 */
#include <math.h>
#include <string.h>
#include "sim_rate.h"

static double dmin(double a, double b) { return a < b ? a : b; }
static double dmax(double a, double b) { return a > b ? a : b; }

/* [nlo, nhi] / [dlo, dhi] with 0 < dlo <= dhi. */
static void idiv(double nlo, double nhi, double dlo, double dhi, double *lo, double *hi)
{
    double c[4] = { nlo / dlo, nlo / dhi, nhi / dlo, nhi / dhi };
    *lo = dmin(dmin(c[0], c[1]), dmin(c[2], c[3]));
    *hi = dmax(dmax(c[0], c[1]), dmax(c[2], c[3]));
}

int pk_rate_speed_bounds(int64_t n, uint64_t dt, double qa, double qb, double tau, uint32_t tick_hz,
                         struct pk_rate_speed *out)
{
    if (dt == 0u)
        return -1;
    double hz = (double)tick_hz, an = fabs((double)n), L = (double)dt;
    out->v = an / L * hz;
    out->lo = dmax(0.0, an - qa - qb) / (L + 2.0 * tau) * hz;
    out->hi = L > 2.0 * tau ? (an + qa + qb) / (L - 2.0 * tau) * hz : INFINITY;
    out->t = 0;
    return 0;
}

/* Signed mean velocity of one window and its bounds, steps per tick. */
static int vel_bounds(int64_t n, double L, double qs, double tau, double *v, double *lo, double *hi)
{
    if (!(L > 2.0 * tau))
        return -1;
    *v = (double)n / L;
    idiv((double)n - qs, (double)n + qs, L - 2.0 * tau, L + 2.0 * tau, lo, hi);
    return 0;
}

/* Acceleration from two windows given as v, bounds (per tick) and the centre
 * distance D (ticks, uncertain by tau), in steps/s^2. */
static void accel_from(double v1, double v1lo, double v1hi, double v2, double v2lo, double v2hi, double D,
                       double tau, double hz, struct pk_rate_accel *out)
{
    double lo, hi;
    idiv(v2lo - v1hi, v2hi - v1lo, D - tau, D + tau, &lo, &hi);
    out->a = (v2 - v1) / D * hz * hz;
    out->lo = lo * hz * hz;
    out->hi = hi * hz * hz;
    out->lo_abs = lo > 0.0 ? out->lo : hi < 0.0 ? -out->hi : 0.0;
}

int pk_rate_accel_bounds(int64_t n1, int64_t n2, uint64_t ta, uint64_t tb, uint64_t tc, double qa,
                         double qb, double qc, double tau, uint32_t tick_hz, struct pk_rate_accel *out)
{
    double v1, l1, h1, v2, l2, h2;
    if (tb < ta || tc < tb)
        return -1;
    if (vel_bounds(n1, (double)(tb - ta), qa + qb, tau, &v1, &l1, &h1) != 0 ||
        vel_bounds(n2, (double)(tc - tb), qb + qc, tau, &v2, &l2, &h2) != 0)
        return -1;
    double D = (double)(tc - ta) / 2.0;
    if (!(D > tau))
        return -1;
    accel_from(v1, l1, h1, v2, l2, h2, D, tau, (double)tick_hz, out);
    out->t = tb;
    return 0;
}

void pk_rate_init(struct pk_rate *r, const struct pk_rate_cfg *cfg)
{
    memset(r, 0, sizeof *r);
    r->cfg = *cfg;
    if (r->cfg.acc_steps == 0u)
        r->cfg.acc_steps = 16u;
    if (!(r->cfg.acc_min_s > 0.0))
        r->cfg.acc_min_s = 0.020;
    if (!(r->cfg.q_shared > 0.0))
        r->cfg.q_shared = 0.5;
    if (!(r->cfg.q_alone >= 0.0))
        r->cfg.q_alone = 0.0;
    if (!(r->cfg.tau_ticks > 0.0))
        r->cfg.tau_ticks = 1.0;
    r->scale = 1.0;
    r->ser[0].w = r->cfg.acc_steps;
    r->ser[0].min_ticks = r->cfg.acc_min_s * (double)r->cfg.tick_hz;
    for (unsigned k = 1; k < PK_RATE_SCALES; k++)
        r->ser[k].w = 1u << k;
}

void pk_rate_reset(struct pk_rate *r)
{
    r->n = 0;
    for (unsigned k = 0; k < PK_RATE_SCALES; k++) {
        r->ser[k].open = 0;
        r->ser[k].have_prev = 0;
    }
}

void pk_rate_set_scale(struct pk_rate *r, double units_per_step)
{
    if (units_per_step != r->scale) {
        r->scale = units_per_step;
        pk_rate_reset(r);
    }
}

static void speed_window(struct pk_rate *r, struct pk_rate_fig *f, unsigned k)
{
    const unsigned i = (unsigned)((r->n - 1u) % PK_RATE_RING), j = (unsigned)((r->n - 1u - k) % PK_RATE_RING);
    struct pk_rate_speed s;
    if (pk_rate_speed_bounds(r->x[i] - r->x[j], r->t[i] - r->t[j], r->q[i], r->q[j], r->cfg.tau_ticks,
                             r->cfg.tick_hz, &s) != 0) {
        r->zero_dt++;
        return;
    }
    s.v *= r->scale;
    s.lo *= r->scale;
    s.hi *= r->scale;
    s.t = r->t[i];
    f->windows++;
    if (f->windows == 1u || s.v > f->vmax.v)
        f->vmax = s;
    if (s.lo > f->lo_max)
        f->lo_max = s.lo;
    if (r->cfg.v_limit > 0.0) {
        if (s.v > r->cfg.v_limit)
            f->over++;
        if (s.lo > r->cfg.v_limit)
            f->proven_over++;
    }
}

static void afig_add(struct pk_rate_afig *f, const struct pk_rate_accel *a, double limit, int by_proof)
{
    f->windows++;
    if (f->windows == 1u || (by_proof ? a->lo_abs > f->amax.lo_abs : fabs(a->a) > fabs(f->amax.a)))
        f->amax = *a;
    if (a->lo_abs > f->lo_abs_max)
        f->lo_abs_max = a->lo_abs;
    if (limit > 0.0) {
        if (fabs(a->a) > limit)
            f->over++;
        if (a->lo_abs > limit)
            f->proven_over++;
    }
}

/* Close series k's window at the newest step instant. */
static void accel_window(struct pk_rate *r, unsigned k, uint64_t t, int64_t x, double q)
{
    struct pk_rate_series *s = &r->ser[k];
    const double tau = r->cfg.tau_ticks, hz = (double)r->cfg.tick_hz;
    double v, lo, hi;
    double L = (double)(t - s->ws_t);
    if (vel_bounds(x - s->ws_x, L, s->ws_q + q, tau, &v, &lo, &hi) != 0) {
        s->have_prev = 0;
        return;
    }
    double c = ((double)t + (double)s->ws_t) / 2.0;
    if (s->have_prev && c - s->pc > tau) {
        struct pk_rate_accel a;
        accel_from(s->pv, s->pv_lo, s->pv_hi, v, lo, hi, c - s->pc, tau, hz, &a);
        a.a *= r->scale;
        a.lo *= r->scale;
        a.hi *= r->scale;
        a.lo_abs *= r->scale;
        a.t = s->ws_t;
        if (k == 0u)
            afig_add(&r->accel, &a, r->cfg.a_limit, 0);
        afig_add(&r->accel_proven, &a, r->cfg.a_limit, 1);
    }
    s->pv = v;
    s->pv_lo = lo;
    s->pv_hi = hi;
    s->pc = c;
    s->have_prev = 1;
}

void pk_rate_step(struct pk_rate *r, uint64_t tick, int dir, int shared)
{
    const double q = shared ? r->cfg.q_shared : r->cfg.q_alone;
    r->steps++;
    r->pos += dir > 0 ? 1 : -1;
    unsigned i = (unsigned)(r->n % PK_RATE_RING);
    r->t[i] = tick;
    r->x[i] = r->pos;
    r->q[i] = q;
    r->n++;
    if (r->n >= 2u)
        speed_window(r, &r->speed2, 1u);
    if (r->n >= 16u)
        speed_window(r, &r->speed16, 15u);
    /* acceleration: successive windows per series */
    for (unsigned k = 0; k < PK_RATE_SCALES; k++) {
        struct pk_rate_series *sr = &r->ser[k];
        if (!sr->open) {
            sr->open = 1;
        } else if (r->n - sr->ws_n < sr->w || (double)(tick - sr->ws_t) < sr->min_ticks) {
            continue;
        } else {
            accel_window(r, k, tick, r->pos, q);
        }
        sr->ws_t = tick;
        sr->ws_x = r->pos;
        sr->ws_q = q;
        sr->ws_n = r->n;
    }
}

void pk_rate_feed(struct pk_rate *r, unsigned axes, size_t n, const uint64_t *tick, const uint8_t *axis,
                  const int8_t *dir)
{
    size_t i = 0;
    while (i < n) {
        size_t j = i + 1u;
        while (j < n && tick[j] == tick[i])
            j++;
        for (size_t k = i; k < j; k++)
            if (axis[k] < axes)
                pk_rate_step(&r[axis[k]], tick[k], dir[k], j - i > 1u);
        i = j;
    }
}
