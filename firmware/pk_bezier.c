/*
 * pk_bezier.c — adaptive flattening of quadratic and cubic Bézier curves
 * (see pk_bezier.h for the error bound). The recursion of the textbook
 * algorithm is replaced by an explicit stack of right halves, bounded by
 * PK_BEZ_MAX_DEPTH + 1 entries: visiting the left half first emits the
 * vertices in curve order.
 */
#include "pk_bezier.h"

#include <string.h>

static int32_t mid(int64_t a, int64_t b) { return (int32_t)pk_rshift_round64(a + b, 1); }

void pk_bez_init(struct pk_bez *b, const pk_um_t p[4][2], int quad, pk_um_t tol_um)
{
    memset(b, 0, sizeof *b);
    b->quad = quad ? 1u : 0u;
    int n = quad ? 3 : 4;
    for (int i = 0; i < n; i++)
        for (int a = 0; a < 2; a++)
            b->stk[0][i][a] = (int32_t)p[i][a] * PK_W8_ONE_UM;
    b->sp = 1;
    int64_t tol = (int64_t)(tol_um < 1 ? 1 : tol_um) * PK_W8_ONE_UM;
    /* cubic: 3/4 |d| <= tol  <=>  |d|^2 <= 16 tol^2 / 9 (floor: conservative)
     * quad:  1/4 |d| <= tol  <=>  |d|^2 <= 16 tol^2 */
    b->lim2 = quad ? 16 * tol * tol : 16 * tol * tol / 9;
}

/* |P_i - 2 P_{i+1} + P_{i+2}|^2 <= lim2 ? Components beyond 2^30 Q.8 are far
 * above any tolerance; checking them first keeps the squares in int64. */
static int flat2(const int32_t (*q)[2], int i, int64_t lim2)
{
    int64_t dx = (int64_t)q[i][0] - 2 * (int64_t)q[i + 1][0] + q[i + 2][0];
    int64_t dy = (int64_t)q[i][1] - 2 * (int64_t)q[i + 1][1] + q[i + 2][1];
    if (dx > (1LL << 30) || dx < -(1LL << 30) || dy > (1LL << 30) || dy < -(1LL << 30))
        return 0;
    return dx * dx + dy * dy <= lim2;
}

int pk_bez_next(struct pk_bez *b, pk_um_t out[2])
{
    while (b->sp > 0) {
        uint8_t top = (uint8_t)(b->sp - 1);
        int32_t(*q)[2] = b->stk[top];
        int last = b->quad ? 2 : 3;
        int flat = flat2((const int32_t(*)[2])q, 0, b->lim2) &&
                   (b->quad || flat2((const int32_t(*)[2])q, 1, b->lim2));
        if (flat || b->lvl[top] >= PK_BEZ_MAX_DEPTH) {
            out[0] = (pk_um_t)pk_rshift_round32(q[last][0], PK_W8_SHIFT);
            out[1] = (pk_um_t)pk_rshift_round32(q[last][1], PK_W8_SHIFT);
            b->sp--;
            return 1;
        }
        /* Split at t = 1/2: the right half goes in this slot, the left half
         * on top of it (visited first). */
        int32_t l[4][2], r[4][2];
        for (int a = 0; a < 2; a++) {
            if (b->quad) {
                int32_t m01 = mid(q[0][a], q[1][a]), m12 = mid(q[1][a], q[2][a]);
                int32_t c = mid(m01, m12);
                l[0][a] = q[0][a]; l[1][a] = m01; l[2][a] = c; l[3][a] = 0;
                r[0][a] = c; r[1][a] = m12; r[2][a] = q[2][a]; r[3][a] = 0;
            } else {
                int32_t m01 = mid(q[0][a], q[1][a]), m12 = mid(q[1][a], q[2][a]);
                int32_t m23 = mid(q[2][a], q[3][a]);
                int32_t m012 = mid(m01, m12), m123 = mid(m12, m23);
                int32_t c = mid(m012, m123);
                l[0][a] = q[0][a]; l[1][a] = m01; l[2][a] = m012; l[3][a] = c;
                r[0][a] = c; r[1][a] = m123; r[2][a] = m23; r[3][a] = q[3][a];
            }
        }
        uint8_t lv = (uint8_t)(b->lvl[top] + 1);
        memcpy(b->stk[top], r, sizeof r);
        b->lvl[top] = lv;
        memcpy(b->stk[top + 1], l, sizeof l);
        b->lvl[top + 1] = lv;
        b->sp++;
    }
    return 0;
}
