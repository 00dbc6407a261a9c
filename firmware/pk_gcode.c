/*
 * pk_gcode.c — G-code line parser and block interpreter (see pk_gcode.h).
 *
 * The parser walks the line once with a cursor that hands out "significant"
 * bytes: upper-cased, with spaces, tabs and comments skipped, so whitespace or
 * a comment may sit anywhere, even inside a number ("X1 2.5" is X12.5, as in
 * Grbl, which strips them before parsing). Numbers are read digit by digit
 * into decimal fixed point (pk_gc_u6_t) with no float and no strtod: at most
 * 9 integer digits, 6 decimals kept, the 7th rounds (ties away from zero).
 *
 * The interpreter follows RS274/NGC's order of execution for the subset
 * plotkin implements and works in int64 micrometres before range-checking
 * against the machine travel, so no intermediate can overflow: every word is
 * below 10^15 (1e-6 units), times 254 (inch conversion) is below 2^58.
 */
#include "pk_gcode.h"

#include <string.h>

/* Cursor results besides a byte value. */
#define CUR_END (-1)
#define CUR_GARBAGE (-2)

struct pk_gc_cursor {
    const uint8_t *s;
    size_t n;
    size_t i;
};

/* Next significant byte (upper-cased), without consuming it. */
static int cur_peek(struct pk_gc_cursor *c)
{
    while (c->i < c->n) {
        uint8_t b = c->s[c->i];
        if (b == ' ' || b == '\t') {
            c->i++;
            continue;
        }
        if (b == '(') {
            /* Comment: to ')' or, as Grbl accepts, to the end of the line.
             * Text inside may be any printable ASCII or UTF-8; control bytes
             * are still garbage. */
            size_t j = c->i + 1;
            while (j < c->n && c->s[j] != ')') {
                uint8_t d = c->s[j];
                if ((d < 0x20 && d != '\t') || d == 0x7f)
                    return CUR_GARBAGE;
                j++;
            }
            c->i = j < c->n ? j + 1 : j;
            continue;
        }
        if (b == ';') {
            for (size_t j = c->i + 1; j < c->n; j++) {
                uint8_t d = c->s[j];
                if ((d < 0x20 && d != '\t') || d == 0x7f)
                    return CUR_GARBAGE;
            }
            c->i = c->n;
            return CUR_END;
        }
        if (b < 0x20 || b >= 0x7f)
            return CUR_GARBAGE;
        if (b >= 'a' && b <= 'z')
            b = (uint8_t)(b - 'a' + 'A');
        return b;
    }
    return CUR_END;
}

static int is_digit(int ch) { return ch >= '0' && ch <= '9'; }

/*
 * Read a number: [+-] digits [. digits] | [+-] . digits.
 * Returns PK_GC_OK or an error; *out in 1e-6 units.
 */
static int read_number(struct pk_gc_cursor *c, pk_gc_u6_t *out)
{
    int ch = cur_peek(c);
    int neg = 0;
    if (ch == CUR_GARBAGE)
        return PK_GC_E_EXPECTED_LETTER;
    if (ch == '+' || ch == '-') {
        neg = ch == '-';
        c->i++;
        ch = cur_peek(c);
        if (ch == CUR_GARBAGE)
            return PK_GC_E_EXPECTED_LETTER;
    }
    int64_t ip = 0;      /* integer part */
    int64_t fp = 0;      /* fraction, 6 digits */
    unsigned idig = 0;   /* significant integer digits */
    unsigned fdig = 0;   /* fraction digits seen */
    unsigned ndig = 0;   /* all digits seen */
    int dot = 0, round_up = 0;
    for (;;) {
        if (is_digit(ch)) {
            int d = ch - '0';
            ndig++;
            if (!dot) {
                if (ip != 0 || d != 0)
                    idig++;
                if (idig > 9)
                    return PK_GC_E_BAD_NUMBER;
                ip = ip * 10 + d;
            } else {
                fdig++;
                if (fdig <= 6)
                    fp = fp * 10 + d;
                else if (fdig == 7)
                    round_up = d >= 5;
            }
        } else if (ch == '.') {
            if (dot)
                return PK_GC_E_BAD_NUMBER;
            dot = 1;
        } else {
            break;
        }
        c->i++;
        ch = cur_peek(c);
    }
    if (ch == CUR_GARBAGE)
        return PK_GC_E_EXPECTED_LETTER;
    if (ndig == 0)
        return PK_GC_E_BAD_NUMBER;
    /* A sign right after a number ("X1-2") is a malformed number too. */
    if (ch == '+' || ch == '-')
        return PK_GC_E_BAD_NUMBER;
    while (fdig < 6) {
        fp *= 10;
        fdig++;
    }
    int64_t v = ip * PK_GC_U6_ONE + fp + round_up;
    if (v > PK_GC_U6_MAX)
        return PK_GC_E_BAD_NUMBER; /* 999999999.9999995 rounds up past 9 digits */
    *out = neg ? -v : v;
    return PK_GC_OK;
}

int pk_gcode_parse_number(const uint8_t *s, size_t len, pk_gc_u6_t *out)
{
    struct pk_gc_cursor c = { s, len, 0 };
    int rc = read_number(&c, out);
    if (rc != PK_GC_OK)
        return rc;
    return cur_peek(&c) == CUR_END ? PK_GC_OK : PK_GC_E_EXPECTED_LETTER;
}

static int word_index(int letter)
{
    switch (letter) {
    case 'F': return PK_GC_W_F;
    case 'I': return PK_GC_W_I;
    case 'J': return PK_GC_W_J;
    case 'K': return PK_GC_W_K;
    case 'N': return PK_GC_W_N;
    case 'P': return PK_GC_W_P;
    case 'Q': return PK_GC_W_Q;
    case 'R': return PK_GC_W_R;
    case 'S': return PK_GC_W_S;
    case 'T': return PK_GC_W_T;
    case 'X': return PK_GC_W_X;
    case 'Y': return PK_GC_W_Y;
    case 'Z': return PK_GC_W_Z;
    default: return -1;
    }
}

/* Record that group g is commanded; two in one block is error 21. */
static int set_group(struct pk_gc_block *b, unsigned g)
{
    if (b->groups & PK_GC_GBIT(g))
        return PK_GC_E_MODAL_GROUP;
    b->groups |= PK_GC_GBIT(g);
    return PK_GC_OK;
}

/* A G word. v is the value in 1e-6 units. */
static int g_word(struct pk_gc_block *b, pk_gc_u6_t v)
{
    if (v < 0)
        return PK_GC_E_UNSUPPORTED;
    int64_t whole = v / PK_GC_U6_ONE;
    int64_t frac = v % PK_GC_U6_ONE;     /* 0..999999 */
    if (whole > 99)
        return PK_GC_E_UNSUPPORTED;
    if (frac != 0) {
        if (whole == 5 && frac == 100000) { /* G5.1 */
            if (set_group(b, PK_GC_G_MOTION) != PK_GC_OK)
                return PK_GC_E_MODAL_GROUP;
            b->motion = PK_GC_MOT_QUAD;
            return PK_GC_OK;
        }
        /* G5.2 (NURBS), G92.1, G61.1, G64.5 ...: a known number with a
         * fraction it does not have is "not an integer"; G5.x is a family
         * LinuxCNC defines, so an unknown member is unsupported. */
        switch (whole) {
        case 0: case 1: case 2: case 3: case 4: case 17: case 20: case 21:
        case 40: case 49: case 54: case 61: case 64: case 80: case 90:
        case 91: case 92: case 94:
            return PK_GC_E_NOT_INTEGER;
        default:
            return PK_GC_E_UNSUPPORTED;
        }
    }
    unsigned g;
    uint8_t val = 0;
    uint8_t *field = NULL;
    switch (whole) {
    case 0: g = PK_GC_G_MOTION; field = &b->motion; val = PK_GC_MOT_RAPID; break;
    case 1: g = PK_GC_G_MOTION; field = &b->motion; val = PK_GC_MOT_LINEAR; break;
    case 2: g = PK_GC_G_MOTION; field = &b->motion; val = PK_GC_MOT_CW_ARC; break;
    case 3: g = PK_GC_G_MOTION; field = &b->motion; val = PK_GC_MOT_CCW_ARC; break;
    case 5: g = PK_GC_G_MOTION; field = &b->motion; val = PK_GC_MOT_CUBIC; break;
    case 80: g = PK_GC_G_MOTION; field = &b->motion; val = PK_GC_MOT_NONE; break;
    case 4: g = PK_GC_G_NONMODAL; field = &b->nonmodal; val = PK_GC_NM_DWELL; break;
    case 92: g = PK_GC_G_NONMODAL; field = &b->nonmodal; val = PK_GC_NM_SET_OFFSET; break;
    case 17: g = PK_GC_G_PLANE; break;
    case 90: g = PK_GC_G_DISTANCE; field = &b->distance; val = PK_GC_ABSOLUTE; break;
    case 91: g = PK_GC_G_DISTANCE; field = &b->distance; val = PK_GC_INCREMENTAL; break;
    case 94: g = PK_GC_G_FEEDMODE; break;
    case 20: g = PK_GC_G_UNITS; field = &b->units; val = PK_GC_INCH; break;
    case 21: g = PK_GC_G_UNITS; field = &b->units; val = PK_GC_MM; break;
    case 40: g = PK_GC_G_CUTTER; break;
    case 49: g = PK_GC_G_TLO; break;
    case 54: g = PK_GC_G_WCS; break;
    case 61: g = PK_GC_G_PATH; field = &b->path; val = PK_GC_PATH_EXACT; break;
    case 64: g = PK_GC_G_PATH; field = &b->path; val = PK_GC_PATH_BLEND; break;
    default: return PK_GC_E_UNSUPPORTED;
    }
    if (set_group(b, g) != PK_GC_OK)
        return PK_GC_E_MODAL_GROUP;
    if (field != NULL)
        *field = val;
    return PK_GC_OK;
}

static int m_word(struct pk_gc_block *b, pk_gc_u6_t v)
{
    if (v < 0)
        return PK_GC_E_UNSUPPORTED;
    if (v % PK_GC_U6_ONE != 0)
        return PK_GC_E_NOT_INTEGER;
    int64_t m = v / PK_GC_U6_ONE;
    unsigned g;
    uint8_t *field;
    uint8_t val;
    switch (m) {
    case 2: g = PK_GC_G_STOP; field = &b->stop; val = PK_GC_STOP_END; break;
    case 30: g = PK_GC_G_STOP; field = &b->stop; val = PK_GC_STOP_END_RESET; break;
    case 3: g = PK_GC_G_SPINDLE; field = &b->spindle; val = PK_GC_PEN_DOWN; break;
    case 5: g = PK_GC_G_SPINDLE; field = &b->spindle; val = PK_GC_PEN_UP; break;
    default: return PK_GC_E_UNSUPPORTED;
    }
    if (set_group(b, g) != PK_GC_OK)
        return PK_GC_E_MODAL_GROUP;
    *field = val;
    return PK_GC_OK;
}

static int has(const struct pk_gc_block *b, int w) { return (b->words & PK_GC_WBIT(w)) != 0; }

int pk_gcode_parse(const uint8_t *line, size_t len, struct pk_gc_block *out)
{
    memset(out, 0, sizeof *out);
    if (len > PK_GC_LINE_MAX)
        return PK_GC_E_LINE_OVERFLOW;
    struct pk_gc_cursor c = { line, len, 0 };
    int ch = cur_peek(&c);
    if (ch == '/') {            /* block delete: ignored, as Grbl does */
        c.i++;
        ch = cur_peek(&c);
    } else if (ch == '%') {     /* program delimiter: the line must hold nothing else */
        c.i++;
        ch = cur_peek(&c);
        if (ch == CUR_END)
            return PK_GC_OK;
        return ch == CUR_GARBAGE || ch < 'A' || ch > 'Z' ? PK_GC_E_EXPECTED_LETTER
                                                         : PK_GC_E_UNSUPPORTED;
    }
    for (;;) {
        if (ch == CUR_END)
            break;
        if (ch == CUR_GARBAGE || ch < 'A' || ch > 'Z')
            return PK_GC_E_EXPECTED_LETTER;
        int letter = ch;
        c.i++;
        pk_gc_u6_t v;
        int rc = read_number(&c, &v);
        if (rc != PK_GC_OK)
            return rc;
        if (letter == 'G') {
            rc = g_word(out, v);
        } else if (letter == 'M') {
            rc = m_word(out, v);
        } else {
            int w = word_index(letter);
            if (w < 0)
                return PK_GC_E_UNSUPPORTED;
            if (has(out, w))
                return PK_GC_E_REPEATED_WORD;
            out->words |= PK_GC_WBIT(w);
            out->v[w] = v;
        }
        if (rc != PK_GC_OK)
            return rc;
        ch = cur_peek(&c);
    }

    /* Rules that depend on this line alone. */
    if (has(out, PK_GC_W_N)) {
        pk_gc_u6_t n = out->v[PK_GC_W_N];
        if (n < 0 || n % PK_GC_U6_ONE != 0 || n / PK_GC_U6_ONE > PK_GC_N_MAX)
            return PK_GC_E_LINE_NUMBER;
    }
    if (has(out, PK_GC_W_F) && out->v[PK_GC_W_F] < 0)
        return PK_GC_E_NEGATIVE;
    if (has(out, PK_GC_W_S) && out->v[PK_GC_W_S] < 0)
        return PK_GC_E_NEGATIVE;
    if (has(out, PK_GC_W_T)) {
        pk_gc_u6_t t = out->v[PK_GC_W_T];
        if (t < 0)
            return PK_GC_E_NEGATIVE;
        if (t % PK_GC_U6_ONE != 0)
            return PK_GC_E_NOT_INTEGER;
        if (t / PK_GC_U6_ONE > 255)
            return PK_GC_E_TOOL_NUMBER;
    }
    if (out->groups & PK_GC_GBIT(PK_GC_G_NONMODAL)) {
        if (out->nonmodal == PK_GC_NM_DWELL) {
            if (!has(out, PK_GC_W_P))
                return PK_GC_E_VALUE_MISSING;
            if (out->v[PK_GC_W_P] < 0)
                return PK_GC_E_NEGATIVE;
        } else { /* G92 */
            if ((out->groups & PK_GC_GBIT(PK_GC_G_MOTION)) && out->motion != PK_GC_MOT_NONE)
                return PK_GC_E_AXIS_CONFLICT;
            if (!(out->words & PK_GC_AXIS_WORDS))
                return PK_GC_E_NO_AXIS_WORDS;
        }
    }
    return PK_GC_OK;
}

/* ------------------------------------------------------------------------- */
/* Interpreter                                                                */
/* ------------------------------------------------------------------------- */

int64_t pk_gcode_len_um(pk_gc_u6_t v, uint8_t units)
{
    if (units == PK_GC_INCH)   /* 1 inch = 25400 µm: v * 25400 / 10^6 */
        return pk_div_round64(v * 254, 10000);
    return pk_div_round64(v, 1000);
}

void pk_gcode_state_init(struct pk_gc_state *st, const struct pk_gc_limits *lim,
                         const pk_um_t pos_um[PK_GC_AXES])
{
    memset(st, 0, sizeof *st);
    st->lim = *lim;
    for (int a = 0; a < PK_GC_AXES; a++)
        st->pos_um[a] = pos_um[a];
    st->motion = PK_GC_MOT_RAPID;
    st->distance = PK_GC_ABSOLUTE;
    st->units = PK_GC_MM;
    st->path = PK_GC_PATH_BLEND;
    st->pen = PK_GC_PEN_UP;
}

static int in_travel(const struct pk_gc_limits *lim, int a, int64_t v)
{
    return v >= lim->min_um[a] && v <= lim->max_um[a];
}

#define VALUE_WORDS (PK_GC_WBIT(PK_GC_W_I) | PK_GC_WBIT(PK_GC_W_J) | PK_GC_WBIT(PK_GC_W_K) | \
                     PK_GC_WBIT(PK_GC_W_P) | PK_GC_WBIT(PK_GC_W_Q) | PK_GC_WBIT(PK_GC_W_R))

/* G5 / G5.1 control points; start/target are XY machine µm. */
static int spline_ctrl(const struct pk_gc_state *st, const struct pk_gc_block *b, uint8_t units,
                       const int64_t start[2], const int64_t target[2], struct pk_gc_cmd *cmd,
                       uint16_t *used, int64_t pq_out[2])
{
    int hi = has(b, PK_GC_W_I), hj = has(b, PK_GC_W_J);
    int64_t ij[2] = { 0, 0 };
    if (b->words & PK_GC_WBIT(PK_GC_W_Z))
        return PK_GC_E_BAD_TARGET;  /* LinuxCNC: X and Y only */
    if (hi)
        ij[0] = pk_gcode_len_um(b->v[PK_GC_W_I], units);
    if (hj)
        ij[1] = pk_gcode_len_um(b->v[PK_GC_W_J], units);
    *used |= PK_GC_WBIT(PK_GC_W_I) | PK_GC_WBIT(PK_GC_W_J);
    int64_t c[2][2];
    if (st->motion == PK_GC_MOT_QUAD) {
        if (!hi && !hj)
            return PK_GC_E_VALUE_MISSING;
        c[0][0] = start[0] + ij[0];
        c[0][1] = start[1] + ij[1];
        c[1][0] = c[0][0];
        c[1][1] = c[0][1];
    } else {
        if (!has(b, PK_GC_W_P) || !has(b, PK_GC_W_Q))
            return PK_GC_E_VALUE_MISSING;
        if (hi != hj)
            return PK_GC_E_VALUE_MISSING;
        if (!hi) {
            /* I,J omitted: continue the previous cubic's end tangent. */
            if (!st->cubic_prev)
                return PK_GC_E_VALUE_MISSING;
            ij[0] = -(int64_t)st->prev_pq_um[0];
            ij[1] = -(int64_t)st->prev_pq_um[1];
        }
        pq_out[0] = pk_gcode_len_um(b->v[PK_GC_W_P], units);
        pq_out[1] = pk_gcode_len_um(b->v[PK_GC_W_Q], units);
        *used |= PK_GC_WBIT(PK_GC_W_P) | PK_GC_WBIT(PK_GC_W_Q);
        c[0][0] = start[0] + ij[0];
        c[0][1] = start[1] + ij[1];
        c[1][0] = target[0] + pq_out[0];
        c[1][1] = target[1] + pq_out[1];
    }
    /* Conservative travel check: the curve lies in the hull of its control
     * points, so checking them guarantees every refined point is inside. */
    for (int k = 0; k < 2; k++)
        for (int a = 0; a < 2; a++) {
            if (!in_travel(&st->lim, a, c[k][a]))
                return PK_GC_E_TRAVEL;
            cmd->ctrl_um[k][a] = (pk_um_t)c[k][a];
        }
    return PK_GC_OK;
}

int pk_gcode_interp(struct pk_gc_state *st, const struct pk_gc_block *b, struct pk_gc_cmd *cmd)
{
    struct pk_gc_state n = *st;  /* committed only on success */
    uint16_t used = PK_GC_WBIT(PK_GC_W_N) | PK_GC_WBIT(PK_GC_W_F) | PK_GC_WBIT(PK_GC_W_S) |
                    PK_GC_WBIT(PK_GC_W_T);
    memset(cmd, 0, sizeof *cmd);
    cmd->line_number = has(b, PK_GC_W_N) ? (int32_t)(b->v[PK_GC_W_N] / PK_GC_U6_ONE) : -1;

    /* Units and distance mode of this block apply to all its words (Grbl). */
    if (b->groups & PK_GC_GBIT(PK_GC_G_UNITS))
        n.units = b->units;
    if (b->groups & PK_GC_GBIT(PK_GC_G_DISTANCE))
        n.distance = b->distance;
    if (has(b, PK_GC_W_F)) {
        int64_t f = pk_gcode_len_um(b->v[PK_GC_W_F], n.units);
        if (f > PK_GC_FEED_MAX)
            return PK_GC_E_BAD_NUMBER;
        n.feed_umpm = (pk_gc_umpm_t)f;
    }
    if (b->groups & PK_GC_GBIT(PK_GC_G_SPINDLE)) {
        cmd->what |= PK_GC_DO_PEN;
        cmd->pen = b->spindle;
        n.pen = b->spindle;
    }
    if ((b->groups & PK_GC_GBIT(PK_GC_G_NONMODAL)) && b->nonmodal == PK_GC_NM_DWELL) {
        int64_t ms = pk_div_round64(b->v[PK_GC_W_P], 1000);  /* P in seconds */
        if (ms > 0x7fffffffLL)
            return PK_GC_E_BAD_NUMBER;
        cmd->what |= PK_GC_DO_DWELL;
        cmd->dwell_ms = (uint32_t)ms;
        used |= PK_GC_WBIT(PK_GC_W_P);
    }
    if (b->groups & PK_GC_GBIT(PK_GC_G_PATH)) {
        n.path = b->path;
        if (b->path == PK_GC_PATH_BLEND) {
            n.tol_um = 0;
            if (has(b, PK_GC_W_P)) {
                int64_t t = pk_gcode_len_um(b->v[PK_GC_W_P], n.units);
                if (t < 0)
                    return PK_GC_E_NEGATIVE;
                if (t > PK_UM_MAX)
                    return PK_GC_E_BAD_NUMBER;
                n.tol_um = (pk_um_t)t;
                used |= PK_GC_WBIT(PK_GC_W_P);
            }
        }
        cmd->what |= PK_GC_DO_PATH;
        cmd->path = n.path;
        cmd->tol_um = n.tol_um;
    }
    if (b->groups & PK_GC_GBIT(PK_GC_G_MOTION))
        n.motion = b->motion;

    uint16_t axes = b->words & PK_GC_AXIS_WORDS;
    if ((b->groups & PK_GC_GBIT(PK_GC_G_NONMODAL)) && b->nonmodal == PK_GC_NM_SET_OFFSET) {
        /* G92: the current position takes the given program coordinates. */
        for (int a = 0; a < PK_GC_AXES; a++) {
            if (!has(b, PK_GC_W_X + a))
                continue;
            int64_t p = pk_gcode_len_um(b->v[PK_GC_W_X + a], n.units);
            if (p < -PK_UM_MAX || p > PK_UM_MAX)
                return PK_GC_E_BAD_TARGET;
            n.offset_um[a] = (pk_um_t)(n.pos_um[a] - p);
        }
        used |= axes;
        cmd->what |= PK_GC_DO_OFFSET;
    } else if (axes != 0 || (n.motion >= PK_GC_MOT_CUBIC && n.motion != PK_GC_MOT_NONE &&
                             (b->words & VALUE_WORDS))) {
        if (n.motion == PK_GC_MOT_NONE)
            return PK_GC_E_UNUSED_WORDS;
        if (n.motion == PK_GC_MOT_CW_ARC || n.motion == PK_GC_MOT_CCW_ARC)
            return PK_GC_E_UNSUPPORTED;
        if (axes == 0)
            return PK_GC_E_NO_AXIS_WORDS;  /* G5/G5.1 words without an end point */
        int64_t start[PK_GC_AXES], target[PK_GC_AXES];
        for (int a = 0; a < PK_GC_AXES; a++) {
            start[a] = n.pos_um[a];
            target[a] = n.pos_um[a];
            if (!has(b, PK_GC_W_X + a))
                continue;
            int64_t p = pk_gcode_len_um(b->v[PK_GC_W_X + a], n.units);
            target[a] = n.distance == PK_GC_INCREMENTAL ? start[a] + p : p + n.offset_um[a];
            if (!in_travel(&n.lim, a, target[a]))
                return PK_GC_E_TRAVEL;
        }
        used |= axes;
        if (n.motion != PK_GC_MOT_RAPID && n.feed_umpm <= 0)
            return PK_GC_E_UNDEFINED_FEED;
        int64_t pq[2] = { 0, 0 };
        if (n.motion == PK_GC_MOT_CUBIC || n.motion == PK_GC_MOT_QUAD) {
            int rc = spline_ctrl(&n, b, n.units, start, target, cmd, &used, pq);
            if (rc != PK_GC_OK)
                return rc;
        }
        cmd->what |= PK_GC_DO_MOVE;
        cmd->motion = n.motion;
        cmd->feed_umpm = n.motion == PK_GC_MOT_RAPID ? 0 : n.feed_umpm;
        for (int a = 0; a < PK_GC_AXES; a++) {
            cmd->start_um[a] = (pk_um_t)start[a];
            cmd->target_um[a] = (pk_um_t)target[a];
            n.pos_um[a] = (pk_um_t)target[a];
        }
        n.cubic_prev = n.motion == PK_GC_MOT_CUBIC;
        n.prev_pq_um[0] = (pk_um_t)pq[0];
        n.prev_pq_um[1] = (pk_um_t)pq[1];
    }
    if (b->words & ~used & VALUE_WORDS)
        return PK_GC_E_UNUSED_VALUE;
    if (b->groups & PK_GC_GBIT(PK_GC_G_STOP)) {
        /* M2/M30: end of program; the executor lifts the pen after the move.
         * Modal state returns to the defaults Grbl restores. */
        cmd->what |= PK_GC_DO_STOP;
        n.motion = PK_GC_MOT_LINEAR;
        n.distance = PK_GC_ABSOLUTE;
        n.path = PK_GC_PATH_BLEND;
        n.pen = PK_GC_PEN_UP;
        n.cubic_prev = 0;
    }
    *st = n;
    return PK_GC_OK;
}
