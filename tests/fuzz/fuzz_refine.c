/*
 * fuzz_refine.c — libFuzzer target for the refinement kernel (pk_refine.h).
 *
 * The bytes choose a configuration (valid or not) and then a program of
 * calls: push a point (in range, at the range limit, far out of range, a
 * repeat of the last one, or a run of random-walk points), pull 1..64 points,
 * finish (twice, to check idempotence), reset mid-stroke. Every stroke that
 * reaches PK_END is then checked against a second, independent instance fed
 * the same accepted points with the canonical interleaving (push, pull until
 * PK_NEED_INPUT; finish, pull until PK_END).
 *
 * Invariants checked:
 *   - init: PK_EINVAL exactly for out-of-range fields; without the limit
 *     stage, PK_ENOTSUP only for an explicit clamped end on degree > 3.
 *   - push: an out-of-range point (in an axis below dims) returns PK_ERANGE
 *     and leaves the whole struct byte-for-byte unchanged; a push right after
 *     a push returns PK_EBUSY, unchanged; after a PK_NEED_INPUT it is PK_OK;
 *     after finish it is PK_ESTATE, unchanged. Axes beyond dims are ignored.
 *   - pull: never PK_END before finish, never PK_NEED_INPUT after it; every
 *     stroke ends with PK_END within its expected count + 1 pulls.
 *   - the output count equals the per-level count iterated depth
 *     times (spec_level_count in tests/refine_spec.h, shared with
 *     tests/test_refine.c), for every configuration without the limit
 *     stage and for closed ones with it.
 *   - B-splines: every output lies inside the bounding box of the stroke's
 *     input, ±1 LSB. DLG: inside the box widened by 0.126 of its width per
 *     side plus 2 LSB (the kernel essay's bound: the composite subdivision
 *     matrix has infinity norm <= 1.2517, so negative weights sum to <=
 *     0.12585).
 *   - the same points with a different pull interleaving, on another
 *     instance, give identical output (positions and tangents).
 *   - one push releases at most 2^depth points, a finish at most
 *     pk_refine_max_release().
 *   - tangents: zero, or a unit vector with |t|^2 within 2^-20 of 1 (Q1.30);
 *     all zero when tangents are off.
 *
 * Cost per input (the campaign's rate): the kernel's work is one pull per
 * output point, so an input gets WORK_OUT outputs: once the fuzzed instance
 * has delivered that many, further pushes are skipped (the bytes are still
 * consumed), and the stroke in progress is finished and checked as any
 * other. An input thus costs at most WORK_OUT + 2^depth +
 * pk_refine_max_release() pulls, twice (the reference). Inputs are capped at
 * MAX_INPUT bytes (tests/fuzz/fuzz_refine.options passes the same -max_len);
 * the bytes beyond are ignored.
 */
#include "fuzz_common.h"
#include "pk_refine.h"
#include "refine_spec.h"

#include <string.h>

#define MAXOUT (1u << 16)
#define MAXPTS 4096u
/** Outputs per input (all strokes) after which no more points are pushed:
 *  depth 0 still reaches the kernel's 255-point saturation, depth 8 gets
 *  a few points (each one 256 outputs). */
#define WORK_OUT 1024u
/** Bytes of input used. */
#define MAX_INPUT 512u

static struct pk_refine_out OUT_F[MAXOUT], OUT_R[MAXOUT];
static pk_um_t PTS[MAXPTS][PK_AXES];

struct stroke {
    unsigned m;     /* accepted points */
    unsigned nout;  /* outputs pulled in the fuzzed interleaving */
    int finished;
};

static uint32_t expected_count(const struct pk_refine *r, uint32_t m)
{
    for (unsigned l = 0; l < r->cfg.depth; l++)
        m = spec_level_count(r->cfg.scheme, r->cfg.degree, r->cfg.closed, r->ends, m);
    return m;
}

/* The reference: a fresh instance, canonical interleaving. Returns the count. */
static unsigned reference_run(const struct pk_refine_cfg *cfg, unsigned m)
{
    static struct pk_refine ref;
    FZ_CHECK(pk_refine_init(&ref, cfg) == PK_OK, "a configuration that initialised once must again");
    unsigned n = 0;
    const uint32_t push_bound = (1u << cfg->depth) + (cfg->limit || cfg->tangents ? PK_LWIN : 0u),
                   fin_bound = pk_refine_max_release(cfg);
    for (unsigned i = 0; i <= m; i++) {
        if (i < m)
            FZ_CHECK(pk_refine_push(&ref, PTS[i]) == PK_OK, "push after PK_NEED_INPUT is accepted");
        else
            pk_refine_finish(&ref);
        unsigned since = 0;
        for (;;) {
            int st = pk_refine_pull(&ref, &OUT_R[n < MAXOUT ? n : MAXOUT - 1u]);
            if (st == PK_OK) {
                n++;
                since++;
                FZ_CHECK(since <= (i < m ? push_bound : fin_bound), "release bound");
                FZ_CHECK(n < MAXOUT, "output fits the harness buffer");
                continue;
            }
            if (i < m) {
                FZ_CHECK(st == PK_NEED_INPUT, "before finish, pull stops with PK_NEED_INPUT");
            } else {
                FZ_CHECK(st == PK_END, "after finish, pull stops with PK_END");
            }
            break;
        }
    }
    return n;
}

static int64_t tan_norm2(const pk_q30_t *t)
{
    int64_t s = 0;
    for (unsigned a = 0; a < PK_AXES; a++)
        s += (int64_t)t[a] * t[a];
    return s;
}

static void check_stroke(const struct pk_refine *r, const struct stroke *s)
{
    const struct pk_refine_cfg *c = &r->cfg;
    unsigned nref = reference_run(c, s->m);
    FZ_CHECK(nref == s->nout, "another interleaving gives the same number of points");
    for (unsigned i = 0; i < nref; i++)
        FZ_CHECK(memcmp(&OUT_R[i], &OUT_F[i], sizeof OUT_R[i]) == 0,
                 "another interleaving gives the same points and tangents");
    if (!c->limit || c->closed)
        FZ_CHECK(nref == expected_count(r, s->m), "point count as specified");

    unsigned dims = c->dims ? c->dims : PK_AXES;
    for (unsigned a = 0; a < dims && s->m > 0u; a++) {
        int64_t lo = PTS[0][a], hi = PTS[0][a];
        for (unsigned i = 1; i < s->m; i++) {
            if (PTS[i][a] < lo)
                lo = PTS[i][a];
            if (PTS[i][a] > hi)
                hi = PTS[i][a];
        }
        int64_t slack = 1;
        if (c->scheme == PK_SCHEME_DLG)
            slack = ((hi - lo) * 126 + 999) / 1000 + 2;
        for (unsigned i = 0; i < nref; i++) {
            if (OUT_R[i].p[a] < lo - slack || OUT_R[i].p[a] > hi + slack) {
                fprintf(stderr, "axis %u: out %d outside [%lld, %lld] +- %lld\n", a,
                        (int)OUT_R[i].p[a], (long long)lo, (long long)hi, (long long)slack);
                FZ_CHECK(0, "output inside the input's bounding box (within the stated bound)");
            }
        }
    }
    for (unsigned i = 0; i < nref; i++) {
        int64_t n2 = tan_norm2(OUT_R[i].t);
        if (c->tangents) {
            int64_t one = (int64_t)1 << 60, err = n2 - one;
            FZ_CHECK(n2 == 0 || (err < 0 ? -err : err) <= ((int64_t)1 << 40),
                     "tangent is zero or a unit vector within 2^-20");
        } else {
            FZ_CHECK(n2 == 0, "tangents are zero when not asked for");
        }
    }
}

/* Decode one point; returns 1 if every axis below dims is within range. */
static int decode_point(struct fz_in *in, unsigned mode, const pk_um_t *prev, unsigned dims,
                        pk_um_t *p)
{
    for (unsigned a = 0; a < PK_AXES; a++) {
        switch (mode) {
        case 0: /* a small step from the previous point */
            p[a] = (pk_um_t)(int32_t)(uint32_t)((int64_t)prev[a] + (int8_t)fz_u8(in) * 37);
            break;
        case 1: /* anywhere in the valid range */
            p[a] = (pk_um_t)(fz_u32(in) % (2u * (uint32_t)PK_UM_MAX + 1u)) - PK_UM_MAX;
            break;
        case 2: /* at or just beyond the range limit */
            p[a] = (fz_u8(in) & 1u ? PK_UM_MAX : -PK_UM_MAX) + ((int8_t)fz_u8(in) % 3);
            break;
        case 3: /* any int32 at all (nearly always out of range) */
            p[a] = (pk_um_t)fz_u32(in);
            break;
        default: /* the previous point again */
            p[a] = prev[a];
            break;
        }
    }
    int ok = 1;
    for (unsigned a = 0; a < PK_AXES; a++) {
        if (a >= dims)
            continue; /* ignored by the kernel, whatever it holds */
        if (p[a] > PK_UM_MAX || p[a] < -PK_UM_MAX)
            ok = 0;
    }
    return ok;
}

#ifndef FZ_STRICT
#define FZ_STRICT 0
#endif

static void start_stroke(struct stroke *s) { memset(s, 0, sizeof *s); }

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    struct fz_in in = { data, size < MAX_INPUT ? size : MAX_INPUT, 0 };
    static struct pk_refine r, snap;
    struct pk_refine_cfg c = { 0 };
    uint8_t b0 = fz_u8(&in), b1 = fz_u8(&in);
    c.scheme = b0 & 1u;
    c.degree = (b0 >> 1) & 7u;
    c.closed = (b0 >> 4) & 1u;
    c.limit = (b0 >> 5) & 1u;
    c.tangents = (b0 >> 6) & 1u;
    c.dims = (b0 >> 7) ? 3u : 2u;
    c.depth = (uint8_t)(b1 % (PK_MAX_DEPTH + 2u));
    c.ends = (b1 >> 4) & 3u;
    if (b1 & 0x40u)
        c.ends = (uint8_t)(b1 >> 4); /* sometimes out of range */
    if ((b1 & 0x80u) && c.scheme == PK_SCHEME_DLG && c.degree == 0u)
        c.dims = 4; /* also an invalid dims (DLG ignores the degree) */

    int want_einval = c.depth > PK_MAX_DEPTH || c.ends > PK_ENDS_NONE || c.dims > PK_AXES ||
                      (c.scheme == PK_SCHEME_BSPLINE && c.degree == 0u);
    int st = pk_refine_init(&r, &c);
    if (want_einval) {
        FZ_CHECK(st == PK_EINVAL, "an out-of-range field is refused with PK_EINVAL");
        return 0;
    }
    if (st == PK_ENOTSUP) {
        int explicit_clamped_high = c.scheme == PK_SCHEME_BSPLINE && c.ends == PK_ENDS_CLAMPED &&
                                    c.degree > 3u;
        FZ_CHECK(explicit_clamped_high || c.limit || c.tangents,
                 "every scheme without the limit stage is built in (PK_WIN=5)");
        return 0;
    }
    FZ_CHECK(st == PK_OK, "init returns OK, EINVAL or ENOTSUP only");

    const unsigned dims = c.dims;
    /* points per stroke: bounded so that one input costs at most ~2k outputs
     * (throughput: the kernel work per output dominates an execution) */
    const unsigned cap = 4u + (1024u >> c.depth);
    struct stroke s;
    start_stroke(&s);
    int last_push = 0;   /* the previous call was an accepted push: a push now is EBUSY */
    int slot_free = 1;   /* the last pull said PK_NEED_INPUT (or nothing yet) */
    pk_um_t prev[PK_AXES] = { 0 };
    uint32_t walk = 0;
    unsigned ops = 0;
    unsigned done_out = 0; /* outputs of the strokes already checked (WORK_OUT) */

    while (fz_more(&in) && ops++ < 4000u) {
        uint8_t op = fz_u8(&in);
        switch (op & 7u) {
        case 0: case 1: case 2: { /* push one point */
            pk_um_t p[PK_AXES];
            int ok = decode_point(&in, (op >> 3) % 5u, prev, dims, p);
            if (ok)
            if (ok && (s.m >= cap || s.m >= MAXPTS || done_out + s.nout >= WORK_OUT))
                break; /* harness limits: the stroke's output fits the buffers; work per input */
            snap = r;
            int pr = pk_refine_push(&r, p);
            if (s.finished) {
                FZ_CHECK(pr == PK_ESTATE, "push after finish is PK_ESTATE");
                FZ_CHECK(memcmp(&snap, &r, sizeof r) == 0, "a refused push changes nothing");
                break;
            }
            if (!ok) {
                /* the kernel tests the slot before the range: while the
                 * previous point waits, EBUSY comes first (both change nothing) */
                FZ_CHECK(pr == PK_ERANGE || (pr == PK_EBUSY && !slot_free),
                         "out-of-range point is PK_ERANGE");
                FZ_CHECK(memcmp(&snap, &r, sizeof r) == 0, "PK_ERANGE changes nothing");
                break;
            }
            if (last_push)
                FZ_CHECK(pr == PK_EBUSY, "a second push without a pull is PK_EBUSY");
            if (slot_free)
                FZ_CHECK(pr == PK_OK, "a push after PK_NEED_INPUT is accepted");
            FZ_CHECK(pr == PK_OK || pr == PK_EBUSY, "push returns OK or EBUSY here");
            if (pr == PK_EBUSY) {
                FZ_CHECK(memcmp(&snap, &r, sizeof r) == 0, "PK_EBUSY changes nothing");
                break;
            }
            memcpy(PTS[s.m++], p, sizeof p);
            memcpy(prev, p, sizeof p);
            last_push = 1;
            slot_free = 0;
            break;
        }
        case 3: case 4: { /* pull up to k points */
            unsigned k = 1u + (fz_u8(&in) & 63u);
            last_push = 0;
            for (unsigned j = 0; j < k; j++) {
                int pr = pk_refine_pull(&r, &OUT_F[s.nout]);
                if (pr == PK_OK) {
                    s.nout++;
                    FZ_CHECK(s.nout < MAXOUT, "output fits the harness buffer");
                    continue;
                }
                if (pr == PK_NEED_INPUT) {
                    FZ_CHECK(!s.finished, "no PK_NEED_INPUT after finish");
                    slot_free = 1;
                } else {
                    FZ_CHECK(pr == PK_END, "pull returns OK, NEED_INPUT or END");
                    FZ_CHECK(s.finished, "no PK_END before finish");
                    check_stroke(&r, &s);
                    done_out += s.nout;
                    start_stroke(&s);
                    slot_free = 1;
                }
                break;
            }
            break;
        }
        case 5: /* finish (sometimes twice: idempotent) */
            pk_refine_finish(&r);
            if (op & 8u)
                pk_refine_finish(&r);
            s.finished = 1;
            last_push = 0;
            break;
        case 6: { /* a run of random-walk points, each pushed and pulled canonically */
            unsigned n = 1u + (fz_u8(&in) & 31u);
            walk = walk * 1664525u + 1013904223u + fz_u8(&in);
            if (s.finished)
                break;
            /* make room first: pull until the slot is free */
            for (;;) {
                int pr = pk_refine_pull(&r, &OUT_F[s.nout]);
                if (pr != PK_OK) {
                    FZ_CHECK(pr == PK_NEED_INPUT, "before finish, pull stops with NEED_INPUT");
                    break;
                }
                s.nout++;
                FZ_CHECK(s.nout < MAXOUT, "output fits the harness buffer");
            }
            for (unsigned j = 0; j < n && s.m < cap && s.m < MAXPTS && done_out + s.nout < WORK_OUT; j++) {
                pk_um_t p[PK_AXES];
                for (unsigned a = 0; a < PK_AXES; a++) {
                    walk = walk * 1664525u + 1013904223u;
                    /* int64: prev may hold anything in an axis beyond dims */
                    int64_t v = (int64_t)prev[a] + (int64_t)((walk >> 8) % 200001u) - 100000;
                    p[a] = (pk_um_t)(v > PK_UM_MAX ? PK_UM_MAX : v < -PK_UM_MAX ? -PK_UM_MAX : v);
                }
                FZ_CHECK(pk_refine_push(&r, p) == PK_OK, "push after NEED_INPUT is accepted");
                memcpy(PTS[s.m++], p, sizeof p);
                memcpy(prev, p, sizeof p);
                for (;;) {
                    int pr = pk_refine_pull(&r, &OUT_F[s.nout]);
                    if (pr != PK_OK) {
                        FZ_CHECK(pr == PK_NEED_INPUT, "before finish, pull stops with NEED_INPUT");
                        break;
                    }
                    s.nout++;
                    FZ_CHECK(s.nout < MAXOUT, "output fits the harness buffer");
                }
            }
            last_push = 0;
            slot_free = 1;
            break;
        }
        default: /* 7: reset mid-stroke, rarely (op must also have bits 3..5 set) */
            if ((op & 0x38u) != 0x38u)
                break;
            pk_refine_reset(&r);
            done_out += s.nout;
            start_stroke(&s);
            last_push = 0;
            slot_free = 1;
            break;
        }
    }

    /* The end of the bytes ends the stroke: finish and drain. */
    pk_refine_finish(&r);
    s.finished = 1;
    uint32_t bound = expected_count(&r, s.m) + 1u;
    for (uint32_t j = 0; j <= bound; j++) {
        int pr = pk_refine_pull(&r, &OUT_F[s.nout]);
        if (pr == PK_OK) {
            s.nout++;
            FZ_CHECK(s.nout < MAXOUT, "output fits the harness buffer");
            continue;
        }
        FZ_CHECK(pr == PK_END, "after finish, pull ends with PK_END");
        check_stroke(&r, &s);
        return 0;
    }
    FZ_CHECK(c.limit && !c.closed, "a finished stroke ends within its expected count");
    /* open strokes with the limit stage: no count is specified; just drain */
    for (uint32_t j = 0; j < MAXOUT; j++) {
        int pr = pk_refine_pull(&r, &OUT_F[s.nout]);
        if (pr == PK_END) {
            check_stroke(&r, &s);
            return 0;
        }
        FZ_CHECK(pr == PK_OK, "after finish, pull gives points then PK_END");
        s.nout++;
        FZ_CHECK(s.nout < MAXOUT, "output fits the harness buffer");
    }
    FZ_CHECK(0, "a finished stroke ends");
    return 0;
}
