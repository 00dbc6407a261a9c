/*
 * pk_gcode.c — G-code line parser and block interpreter (see pk_gcode.h).
 *
 * The parser walks the line once with a cursor that hands out significant
 * bytes (upper-cased; bytes <= ' ', '/' and comments skipped) and reads each
 * number digit by digit into a 32-bit mantissa and a decimal count: no float,
 * no strtod, no 64-bit arithmetic.
 *
 * The interpreter follows Grbl 1.1h's gc_execute_line step by step, so that
 * a block with several faults fails with the error Grbl reports first; the
 * numbered comments ([2. Set feed rate mode], ...) are Grbl's. All lengths
 * are converted once to int32 µm (mm values: 32-bit; inch values: one 64-bit
 * product), checked against ±PK_UM_MAX before anything is committed.
 */
#include "pk_gcode.h"
#include "pk_rom.h"

#include <stddef.h>
#include <string.h>

#define CUR_END (-1)

static const uint32_t pow10_tab[10] PK_ROM = { 1u, 10u, 100u, 1000u, 10000u, 100000u, 1000000u,
                                        10000000u, 100000000u, 1000000000u };
/* 0x7fffffff / 10^k: the overflow bound of a * 10^k without a division (a
 * 32-bit divide is ~600 cycles on an AVR) */
static const uint32_t pow10_lim[10] PK_ROM = { 2147483647u, 214748364u, 21474836u, 2147483u,
                                        214748u, 21474u, 2147u, 214u, 21u, 2u };

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
        if (b <= ' ' || b == '/') { /* whitespace, control bytes, block delete */
            c->i++;
            continue;
        }
        if (b == '(') { /* to ')' or, as Grbl, to the end of the line */
            size_t j = c->i + 1;
            while (j < c->n && c->s[j] != ')')
                j++;
            c->i = j < c->n ? j + 1 : j;
            continue;
        }
        if (b == ';') {
            c->i = c->n;
            return CUR_END;
        }
        if (b >= 'a' && b <= 'z')
            b = (uint8_t)(b - 'a' + 'A');
        return b;
    }
    return CUR_END;
}


/*
 * Read a number: [+-] digits [. digits] | [+-] . digits. At most 9 integer
 * digits; fraction digits are kept while the mantissa has fewer than 9
 * digits and the decimals are fewer than 9, later ones dropped.
 *
 * (the loop is the parser's hot spot on the AVR: 3-4 numbers a line.) While
 * the mantissa is below 6553 a digit is a 16-bit multiply-add (the hardware
 * multiplier), beyond it libgcc's 32 x 16-bit product. The cursor stays in
 * registers; digits and the point are read straight from the line while
 * they come without blanks (the engine hands over lines without blanks or
 * comments), cur_peek only for anything else.
 */
static int read_number(struct pk_gc_cursor *c, int32_t *m_out, uint8_t *dec_out)
{
    const uint8_t *s = c->s;
    const size_t n = c->n;
    size_t i = c->i;
    int ch;
    uint8_t neg = 0;
    if (i < n && (uint8_t)(s[i] - '0') <= 9u) {
        ch = s[i];
    } else {
        ch = cur_peek(c);
        if (ch == '+' || ch == '-') {
            neg = ch == '-';
            c->i++;
            ch = cur_peek(c);
        }
        i = c->i;
    }
    uint32_t m = 0;
    uint8_t dec = 0, any = 0, dot = 0;
    for (;;) {
        const uint8_t d = (uint8_t)(ch - '0');
        if (d <= 9u) {
            any = 1;
            if (!dot || dec < 9u) { /* (fraction digits past the 9th are dropped) */
                if (m < 6553u) {
                    /* m * 10 + d <= 65529: a 16-bit product (hardware
                     * multiply), not libgcc's 32-bit one */
                    m = (uint16_t)((uint16_t)m * 10u + d);
                    dec = (uint8_t)(dec + dot);
                } else if (m <= 99999999u) {
                    m = m * 10u + d;
                    dec = (uint8_t)(dec + dot);
                } else if (!dot) {
                    return PK_GC_E_BAD_NUMBER; /* a tenth integer digit */
                }
            }
        } else if (ch == '.' && !dot) {
            dot = 1;
        } else {
            break;
        }
        i++;
        uint8_t b;
        if (i < n && ((uint8_t)((b = s[i]) - '0') <= 9u || b == '.')) {
            ch = b;
        } else {
            c->i = i;
            ch = cur_peek(c);
            i = c->i;
        }
    }
    c->i = i; /* at ch, the byte after the number (not consumed) */
    if (!any)
        return PK_GC_E_BAD_NUMBER;
    *m_out = neg ? -(int32_t)m : (int32_t)m;
    *dec_out = dec;
    return PK_GC_OK;
}

int pk_gcode_parse_number(const uint8_t *s, size_t len, int32_t *m, uint8_t *dec)
{
    struct pk_gc_cursor c = { s, len, 0 };
    int rc = read_number(&c, m, dec);
    if (rc != PK_GC_OK)
        return rc;
    return cur_peek(&c) == CUR_END ? PK_GC_OK : PK_GC_E_EXPECTED_LETTER;
}

int pk_gcode_scaled(int32_t m, uint8_t md, uint8_t dec, int32_t *out)
{
    uint32_t a = m < 0 ? (uint32_t)0 - (uint32_t)m : (uint32_t)m;
    uint32_t r;
    if (dec == md) {
        r = a; /* the common case: as many decimals as wanted */
    } else if (dec > md) {
        unsigned k = (unsigned)(dec - md);
        if (k > 9u || a > pk_rom_u32(&pow10_lim[k]))
            return PK_GC_E_BAD_NUMBER;
        r = a * pk_rom_u32(&pow10_tab[k]);
    } else {
        uint32_t p = pk_rom_u32(&pow10_tab[md - dec]);
        r = a / p;
        if ((a % p) * 2u >= p) /* half away from zero */
            r++;
    }
    *out = m < 0 ? -(int32_t)r : (int32_t)r;
    return PK_GC_OK;
}

int pk_gcode_len_um(int32_t m, uint8_t dec, uint8_t units, int32_t *out)
{
    if (units != PK_GC_INCH)
        return pk_gcode_scaled(m, dec, 3, out);
    /* 1 inch = 25400 µm: |m| * 25400 / 10^dec, rounded half away, the sign
     * put back after (|m| < 2^31: below 2^46; one unsigned division) */
    uint32_t a = m < 0 ? (uint32_t)0 - (uint32_t)m : (uint32_t)m;
    uint32_t p = pk_rom_u32(&pow10_tab[dec]);
    uint64_t q = ((uint64_t)a * 25400u + p / 2u) / p;
    if (q > 0x7fffffffu)
        return PK_GC_E_BAD_NUMBER;
    *out = m < 0 ? -(int32_t)q : (int32_t)q;
    return PK_GC_OK;
}

/* The value word of a letter, -1 for none: range checks on the runs of the
 * enum (a switch becomes a lookup table that avr-gcc copies to RAM, and a
 * table in program memory costs ~5 cycles a word more on the AVR). */
_Static_assert(PK_GC_W_F == 0 && PK_GC_W_J == PK_GC_W_I + 1 && PK_GC_W_L == PK_GC_W_I + 3 &&
               PK_GC_W_T == PK_GC_W_P + 4 && PK_GC_W_Z == PK_GC_W_X + 2, "word runs I-L, P-T, X-Z");
/* PK_GC_WBIT(w) from program memory: a shift by a variable count is a
 * loop on the AVR (~40 cycles for X, Y) */
static const uint16_t word_bit[PK_GC_W_COUNT] PK_ROM = {
    PK_GC_WBIT(0), PK_GC_WBIT(1), PK_GC_WBIT(2), PK_GC_WBIT(3), PK_GC_WBIT(4),
    PK_GC_WBIT(5), PK_GC_WBIT(6), PK_GC_WBIT(7), PK_GC_WBIT(8), PK_GC_WBIT(9),
    PK_GC_WBIT(10), PK_GC_WBIT(11), PK_GC_WBIT(12), PK_GC_WBIT(13)
};
_Static_assert(PK_GC_W_COUNT == 14, "word_bit has a bit for each word");
static int word_index(int letter)
{
    if (letter >= 'P' && letter <= 'T')
        return PK_GC_W_P + (letter - 'P');
    if (letter >= 'X' && letter <= (PK_GC_AXES >= 3 ? 'Z' : 'Y'))
        return PK_GC_W_X + (letter - 'X');
    if (letter >= 'I' && letter <= 'L')
        return PK_GC_W_I + (letter - 'I');
    if (letter == 'F')
        return PK_GC_W_F;
    return letter == 'N' ? PK_GC_W_N : -1;
}

/* Grbl's int_value (trunc) and mantissa (round(100 * fraction)) of a G/M
 * value; -1 for a negative or too large one (unsupported). */
static int code_parts(int32_t m, uint8_t dec, uint32_t *whole, uint32_t *mant)
{
    if (m < 0)
        return -1;
    if (dec == 0) { /* G1, M3: no division */
        *whole = (uint32_t)m;
        *mant = 0;
        return *whole > 255u ? -1 : 0;
    }
    uint32_t p = pk_rom_u32(&pow10_tab[dec]);
    *whole = (uint32_t)m / p;
    uint32_t frac = (uint32_t)m % p;
    /* round(frac * 100 / p): frac < p <= 10^9, so frac * 100 fits in 64 bits
     * only; split to stay in 32: (frac / (p/100)) for p >= 100 (p / 100 is
     * 10^(dec-2), from the table; dec 1: frac * 10) */
    if (dec >= 2u) {
        uint32_t q = pk_rom_u32(&pow10_tab[dec - 2u]);
        *mant = frac / q + ((frac % q) * 2u >= q ? 1u : 0u);
    } else {
        *mant = frac * 10u;
    }
    return *whole > 255u ? -1 : 0;
}

static int set_group(struct pk_gc_block *b, unsigned g)
{
    if (b->groups & PK_GC_GBIT(g))
        return PK_GC_E_MODAL_GROUP;
    b->groups |= PK_GC_GBIT(g);
    return PK_GC_OK;
}

static int axis_command(struct pk_gc_block *b, uint8_t kind)
{
    if (b->axis_cmd != PK_GC_AXCMD_NONE)
        return PK_GC_E_AXIS_CONFLICT;
    b->axis_cmd = kind;
    return PK_GC_OK;
}

/* The G numbers Grbl's switch knows, bit n of byte n / 8 (G0-G5 G10 G17-G21
 * G28 G30 G38 G40 G43 G49 G53-G59 G61 G64 G80 G90-G94), in program memory. */
static const uint8_t g_codes[12] PK_ROM = { 0x3fu, 0x04u, 0x3eu, 0x50u, 0x40u, 0x09u,
                                              0xe2u, 0x2fu, 0x01u, 0x00u, 0x01u, 0x7cu };

/* Grbl keeps a G/M number in a uint8 (trunc) and the fraction times 100 in
 * a uint16: a negative or > 255 value wraps to another code with a non-zero
 * "mantissa". Its answer: error 23 where the wrapped code exists, else 20. */
static int code_wrapped(int32_t m, uint8_t dec, int is_g)
{
    int32_t t = m / (int32_t)pk_rom_u32(&pow10_tab[dec]); /* trunc */
    uint32_t w = (uint32_t)t & 0xffu;
    if (!is_g)
        return PK_GC_E_NOT_INTEGER;
    return w < 8u * sizeof g_codes && (pk_rom_u8(&g_codes[w >> 3]) >> (w & 7u)) & 1u
               ? PK_GC_E_NOT_INTEGER : PK_GC_E_UNSUPPORTED;
}

/* A G word (Grbl's switch, plus G5/G5.1 and G64). */
static int g_word(struct pk_gc_block *b, int32_t m, uint8_t dec)
{
    uint32_t v, mant;
    if (code_parts(m, dec, &v, &mant) != 0)
        return code_wrapped(m, dec, 1);
    unsigned g;
    int rc;
    switch (v) {
    case 10: case 28: case 30: case 92:
        if (mant == 0 && (rc = axis_command(b, PK_GC_AXCMD_NONMODAL)) != PK_GC_OK)
            return rc;
        /* fall through */
    case 4: case 53:
        g = PK_GC_G_NONMODAL;
        b->nonmodal = (uint8_t)v;
        if (v == 28 || v == 30 || v == 92) {
            if (mant != 0 && mant != 10)
                return PK_GC_E_UNSUPPORTED;
            b->nonmodal = (uint8_t)(v + mant);
            mant = 0;
        }
        break;
    case 0: case 1: case 2: case 3: case 38: case 5:
        if ((rc = axis_command(b, PK_GC_AXCMD_MOTION)) != PK_GC_OK)
            return rc;
        /* fall through */
    case 80:
        g = PK_GC_G_MOTION;
        switch (v) {
        case 0: b->motion = PK_GC_MOT_RAPID; break;
        case 1: b->motion = PK_GC_MOT_LINEAR; break;
        case 2: case 3:
            if (!PK_BUILD_ARCS)
                return PK_GC_E_UNSUPPORTED; /* not built into this firmware */
            b->motion = v == 2 ? PK_GC_MOT_CW_ARC : PK_GC_MOT_CCW_ARC;
            break;
        case 80: b->motion = PK_GC_MOT_NONE; break;
        case 5:
            if (!PK_BUILD_G5 || (mant != 0 && mant != 10))
                return PK_GC_E_UNSUPPORTED; /* G5.2 NURBS and the rest of LinuxCNC's G5.x */
            b->motion = mant ? PK_GC_MOT_QUAD : PK_GC_MOT_CUBIC;
            mant = 0;
            break;
        default: /* 38 */
            if (mant != 20 && mant != 30 && mant != 40 && mant != 50)
                return PK_GC_E_UNSUPPORTED;
            b->motion = (uint8_t)(PK_GC_MOT_PROBE_TOWARD + (mant - 20u) / 10u);
            mant = 0;
            break;
        }
        break;
    case 17: case 18: case 19:
#if PK_GC_AXES < 3
        if (v != 17)
            return PK_GC_E_UNSUPPORTED;
#endif
        g = PK_GC_G_PLANE;
        b->plane = (uint8_t)(v - 17);
        break;
    case 90: case 91:
        if (mant == 0) {
            g = PK_GC_G_DISTANCE;
            b->distance = (uint8_t)(v - 90);
        } else {
            g = PK_GC_G_ARC_DISTANCE;
            if (mant != 10 || v == 90)
                return PK_GC_E_UNSUPPORTED; /* G90.1 */
            mant = 0;
        }
        break;
    case 93: case 94:
        g = PK_GC_G_FEEDMODE;
        b->feedmode = (uint8_t)(94 - v);
        break;
    case 20: case 21:
        g = PK_GC_G_UNITS;
        b->units = (uint8_t)(21 - v);
        break;
    case 40:
        g = PK_GC_G_CUTTER;
        break;
    case 43: case 49:
        g = PK_GC_G_TLO;
        if ((rc = axis_command(b, PK_GC_AXCMD_TLO)) != PK_GC_OK)
            return rc;
        if (v == 49) {
            b->tlo = PK_GC_TLO_CANCEL;
            mant = 0; /* Grbl: G49.x is G49 */
        } else if (mant == 10) {
#if PK_GC_AXES < 3
            return PK_GC_E_UNSUPPORTED; /* no Z axis to offset */
#endif
            b->tlo = PK_GC_TLO_DYNAMIC;
            mant = 0;
        } else {
            return PK_GC_E_UNSUPPORTED; /* G43 (tool table), G43.2 */
        }
        break;
    case 54: case 55: case 56: case 57: case 58: case 59:
        g = PK_GC_G_WCS;
        b->wcs = (uint8_t)(v - 54);
        break;
    case 61: case 64:
        g = PK_GC_G_PATH;
        if (mant != 0)
            return PK_GC_E_UNSUPPORTED; /* G61.1, G64.x */
        b->path = v == 61 ? PK_GC_PATH_EXACT : PK_GC_PATH_BLEND;
        break;
    default:
        return PK_GC_E_UNSUPPORTED;
    }
    if (mant > 0)
        return PK_GC_E_NOT_INTEGER;
    return set_group(b, g);
}

static int m_word(struct pk_gc_block *b, int32_t m, uint8_t dec)
{
    uint32_t v, mant;
    if (code_parts(m, dec, &v, &mant) != 0)
        return code_wrapped(m, dec, 0);
    if (mant > 0)
        return PK_GC_E_NOT_INTEGER;
    unsigned g;
    switch (v) {
    case 0: case 1: case 2: case 30:
        g = PK_GC_G_STOP;
        b->stop = v == 0 ? PK_GC_STOP_PAUSE : (uint8_t)v;
        break;
    case 3: case 4: case 5:
        g = PK_GC_G_SPINDLE;
        b->spindle = v == 5 ? PK_GC_SPINDLE_OFF : (uint8_t)v;
        break;
    case 7: case 8: case 9:
        g = PK_GC_G_COOLANT;
        b->coolant = (uint8_t)v;
        break;
    case 56:
        g = PK_GC_G_OVERRIDE;
        break;
    default:
        return PK_GC_E_UNSUPPORTED;
    }
    return set_group(b, g);
}

static int has(const struct pk_gc_block *b, int w) { return (b->words & PK_GC_WBIT(w)) != 0; }

/* The words of a line. A negative P is error 4 where Grbl reads it, unless
 * the block is a G5 (plotkin: P, Q are the offset of its second control
 * point): *neg_p marks one read before any G5, and any error after it
 * becomes error 4, as Grbl would have stopped there. */
static int parse_words(struct pk_gc_cursor *c, struct pk_gc_block *out, int *neg_p)
{
    int ch = cur_peek(c);
    while (ch != CUR_END) {
        if (ch < 'A' || ch > 'Z')
            return PK_GC_E_EXPECTED_LETTER;
        int letter = ch;
        c->i++;
        int32_t m;
        uint8_t dec;
        int rc = read_number(c, &m, &dec);
        if (rc != PK_GC_OK)
            return rc;
        if (letter == 'G') {
            rc = g_word(out, m, dec);
            if (PK_BUILD_G5 && rc == PK_GC_OK && (out->groups & PK_GC_GBIT(PK_GC_G_MOTION)) &&
                out->motion == PK_GC_MOT_CUBIC) /* (g_word sets it only where G5 is built) */
                *neg_p = 0;
        } else if (letter == 'M') {
            rc = m_word(out, m, dec);
        } else {
            int w = word_index(letter);
            if (w < 0)
                return PK_GC_E_UNSUPPORTED;
            /* Grbl: T above 255 first, then repeats, then negatives */
            if (w == PK_GC_W_T && m > 0 && ((uint32_t)m / pk_rom_u32(&pow10_tab[dec]) > 255u))
                return PK_GC_E_TOOL_NUMBER;
            const uint16_t bit = pk_rom_u16(&word_bit[w]);
            if (out->words & bit)
                return PK_GC_E_REPEATED_WORD;
            if (m < 0) {
                int cubic = PK_BUILD_G5 && (out->groups & PK_GC_GBIT(PK_GC_G_MOTION)) &&
                            out->motion == PK_GC_MOT_CUBIC;
                if (w == PK_GC_W_P && !cubic)
                    *neg_p = 1;
                else if (w == PK_GC_W_F || w == PK_GC_W_N || w == PK_GC_W_T || w == PK_GC_W_S)
                    return PK_GC_E_NEGATIVE;
            }
            out->words |= bit;
            out->m[w] = m;
            out->dec[w] = dec;
        }
        if (rc != PK_GC_OK)
            return rc;
        /* read_number left the cursor at a significant byte: a capital
         * letter needs no peek (~40 cycles a word on the AVR) */
        if (c->i < c->n && (uint8_t)(c->s[c->i] - 'A') <= (uint8_t)('Z' - 'A'))
            ch = c->s[c->i];
        else
            ch = cur_peek(c);
    }
    return PK_GC_OK;
}

int pk_gcode_parse(const uint8_t *line, size_t len, struct pk_gc_block *out)
{
    /* only the presence masks: every other field is read only under its
     * words/groups bit (clearing all 76 bytes costs ~300 cycles on an AVR) */
    out->words = 0;
    out->groups = 0;
    out->axis_cmd = PK_GC_AXCMD_NONE;
    if (len > PK_GC_LINE_MAX)
        return PK_GC_E_LINE_OVERFLOW;
    struct pk_gc_cursor c = { line, len, 0 };
    int ch = cur_peek(&c);
    if (ch == '%') { /* program delimiter: the line must hold nothing else */
        c.i++;
        ch = cur_peek(&c);
        return ch == CUR_END ? PK_GC_OK : PK_GC_E_EXPECTED_LETTER;
    }
    int neg_p = 0;
    int rc = parse_words(&c, out, &neg_p);
    if (neg_p)
        return PK_GC_E_NEGATIVE;
    return rc;
}

/* ------------------------------------------------------------------------- */
/* Interpreter                                                                */
/* ------------------------------------------------------------------------- */

void pk_gcode_state_init(struct pk_gc_state *st, const pk_um_t pos_um[PK_GC_AXES],
                         const pk_um_t g54_um[PK_GC_AXES])
{
    memset(st, 0, sizeof *st);
    for (int a = 0; a < PK_GC_AXES; a++) {
        st->pos_um[a] = pos_um[a];
        st->wcs_um[a] = g54_um ? g54_um[a] : 0;
    }
    st->motion = PK_GC_MOT_RAPID;
    st->path = PK_GC_PATH_BLEND;
    st->parking_ovr = 1;
}

pk_um_t pk_gcode_wco(const struct pk_gc_state *st, unsigned a)
{
    pk_um_t v = st->wcs_um[a] + st->g92_um[a];
#if PK_GC_AXES >= 3
    if (a == 2)
        v += st->tlo_um;
#endif
    return v;
}

#if PK_BUILD_G5
static int in_range(int64_t v) { return v >= -PK_UM_MAX && v <= PK_UM_MAX; }
#endif
static int in_range32(int32_t v) { return v >= -PK_UM_MAX && v <= PK_UM_MAX; }

/* Targets and offsets in 32 bits: every term added to an axis word is a
 * position or offset within +-PK_UM_MAX (< 2^21), so once the word itself is
 * within +-2^30 (beyond that it is out of travel anyway) no sum of up to
 * four terms leaves int32. */
#define WORD_LIM (INT32_C(1) << 30)
static int word_ok(int32_t v) { return v <= WORD_LIM && v >= -WORD_LIM; }

#define TLO_AXIS 2

/* A word's value in µm (length units), in thousandths, and a stored
 * coordinate set: one call each where the block is read (smaller code on a
 * small part than the field loads at every call). */
static int word_um(const struct pk_gc_block *b, int w, uint8_t units, int32_t *out)
{
    int32_t m = b->m[w];
    uint8_t dec = b->dec[w];
    if (units == PK_GC_INCH)
        return pk_gcode_len_um(m, dec, units, out);
    if (dec == 3u) { /* "X12.345": already µm (the common case, no call) */
        *out = m;
        return PK_GC_OK;
    }
    return pk_gcode_scaled(m, dec, 3, out); /* mm: pk_gcode_len_um's 32-bit path */
}

static int word_milli(const struct pk_gc_block *b, int w, int32_t *out)
{
    return pk_gcode_scaled(b->m[w], b->dec[w], 3, out);
}

static int coord_get(const struct pk_gc_env *env, unsigned idx, int32_t out[PK_GC_AXES])
{
    return env == NULL || env->coord_read == NULL || env->coord_read(env->ctx, idx, out) != 0 ? -1 : 0;
}

/* Truncated integer value of a word (Grbl's int_value). */
static uint32_t word_uint(const struct pk_gc_block *b, int w)
{
    return b->m[w] < 0 ? 0u : (uint32_t)b->m[w] / pk_rom_u32(&pow10_tab[b->dec[w]]);
}

#if PK_BUILD_G5
/* G5 / G5.1 control points (plotkin; LinuxCNC's rules). */
static int spline_ctrl(const struct pk_gc_state *st, const struct pk_gc_block *b, uint8_t motion,
                       uint8_t units, uint8_t plane, const int32_t start[2],
                       const int32_t target[2], pk_um_t ctrl[4][2], uint16_t *used,
                       int32_t pq_out[2])
{
    int hi = has(b, PK_GC_W_I), hj = has(b, PK_GC_W_J);
    int32_t ij[2] = { 0, 0 };
    if (plane != PK_GC_PLANE_XY || has(b, PK_GC_W_Z))
        return PK_GC_E_BAD_TARGET; /* LinuxCNC: X and Y only, in G17 */
    if (hi && word_um(b, PK_GC_W_I, units, &ij[0]) != PK_GC_OK)
        return PK_GC_E_BAD_NUMBER;
    if (hj && word_um(b, PK_GC_W_J, units, &ij[1]) != PK_GC_OK)
        return PK_GC_E_BAD_NUMBER;
    *used |= PK_GC_WBIT(PK_GC_W_I) | PK_GC_WBIT(PK_GC_W_J);
    int64_t c[2][2];
    if (motion == PK_GC_MOT_QUAD) {
        if (!hi && !hj)
            return PK_GC_E_VALUE_MISSING;
        for (int a = 0; a < 2; a++)
            c[0][a] = c[1][a] = (int64_t)start[a] + ij[a];
    } else {
        if (!has(b, PK_GC_W_P) || !has(b, PK_GC_W_Q) || hi != hj)
            return PK_GC_E_VALUE_MISSING;
        if (!hi) { /* I, J omitted: continue the previous cubic's end tangent */
            if (!st->cubic_prev)
                return PK_GC_E_VALUE_MISSING;
            ij[0] = -st->prev_pq_um[0];
            ij[1] = -st->prev_pq_um[1];
        }
        if (word_um(b, PK_GC_W_P, units, &pq_out[0]) != PK_GC_OK ||
            word_um(b, PK_GC_W_Q, units, &pq_out[1]) != PK_GC_OK)
            return PK_GC_E_BAD_NUMBER;
        *used |= PK_GC_WBIT(PK_GC_W_P) | PK_GC_WBIT(PK_GC_W_Q);
        for (int a = 0; a < 2; a++) {
            c[0][a] = (int64_t)start[a] + ij[a];
            c[1][a] = (int64_t)target[a] + pq_out[a];
        }
    }
    /* The curve lies in the hull of its control points. */
    for (int a = 0; a < 2; a++) {
        ctrl[0][a] = start[a];
        for (int k = 0; k < 2; k++) {
            if (!in_range(c[k][a]))
                return PK_GC_E_TRAVEL;
            ctrl[1 + k][a] = (pk_um_t)c[k][a];
        }
        ctrl[3][a] = target[a];
        if (motion == PK_GC_MOT_QUAD)
            ctrl[2][a] = target[a];
    }
    return PK_GC_OK;
}
#endif

/* Length of a straight move, µm (rounded up), for G93. */
static uint32_t move_len(const int32_t a[PK_GC_AXES], const int32_t b[PK_GC_AXES])
{
    uint64_t s = 0;
    for (int i = 0; i < PK_GC_AXES; i++) {
        int64_t d = (int64_t)b[i] - a[i];
        s += (uint64_t)(d * d);
    }
    uint64_t r = pk_isqrt64(s);
    return (uint32_t)(r * r < s ? r + 1u : r);
}

#if PK_BUILD_ARCS || PK_BUILD_G5
/* The chord tolerance of arcs and G5 (lead's rule): a quarter of the path
 * tolerance in G64, min($12, 2 µm) in G61. */
static pk_um_t chord_tol(uint8_t path, pk_um_t tol_um, pk_um_t dflt)
{
    if (path == PK_GC_PATH_EXACT)
        return dflt < 2 ? (dflt < 1 ? 1 : dflt) : 2;
    pk_um_t p = tol_um > 0 ? tol_um : dflt;
    p /= 4;
    return p < 1 ? 1 : p;
}
#endif

static int interp(const struct pk_gc_state *st, const struct pk_gc_block *b,
                  const struct pk_gc_env *env, int jog, struct pk_gc_state *n,
                  struct pk_gc_cmd *cmd)
{
    /* n == st (pk_gcode_interp): in place. Nothing is written before the
     * block is fully validated, and the execute part reads each old value
     * before it writes the new one, so *st is unchanged on any error. */
    if (n != st)
        *n = *st;
    /* the arc/curve union is set up only by the blocks that use it (clearing
     * its 136 bytes on every line costs ~550 cycles on an AVR); start_um and
     * target_um are cleared at the end only when no move wrote them
     * (cmd_done): the 78 bytes before the union at 6 cycles a byte were
     * the interpreter's largest cost a line */
    memset(cmd, 0, offsetof(struct pk_gc_cmd, start_um));
    uint16_t words = b->words;
    uint8_t axis_cmd = b->axis_cmd;
    uint8_t motion = (b->groups & PK_GC_GBIT(PK_GC_G_MOTION)) ? b->motion : st->motion;
    uint8_t units = (b->groups & PK_GC_GBIT(PK_GC_G_UNITS)) ? b->units : st->units;
    uint8_t distance = (b->groups & PK_GC_GBIT(PK_GC_G_DISTANCE)) ? b->distance : st->distance;
    uint8_t plane = (b->groups & PK_GC_GBIT(PK_GC_G_PLANE)) ? b->plane : st->plane;
    uint8_t feedmode = (b->groups & PK_GC_GBIT(PK_GC_G_FEEDMODE)) ? b->feedmode : st->feedmode;
    uint8_t wcs = (b->groups & PK_GC_GBIT(PK_GC_G_WCS)) ? b->wcs : st->wcs;
    uint8_t nonmodal = (b->groups & PK_GC_GBIT(PK_GC_G_NONMODAL)) ? b->nonmodal : PK_GC_NM_NONE;
    /* the path mode of this block applies to its own arcs and curves */
    uint8_t path = st->path;
    pk_um_t path_tol = st->tol_um;
    if (b->groups & PK_GC_GBIT(PK_GC_G_PATH)) {
        path = b->path;
        path_tol = 0;
        if (b->path == PK_GC_PATH_BLEND && has(b, PK_GC_W_P)) {
            int32_t t;
            if (word_um(b, PK_GC_W_P, units, &t) != PK_GC_OK ||
                t > 10000)
                return PK_GC_E_BAD_NUMBER; /* the smoother's range: 0..10 mm */
            path_tol = t;
        }
    }
    if (jog) {
        motion = PK_GC_MOT_LINEAR;
        feedmode = PK_GC_UNITS_PER_MIN;
    }
    uint16_t axis_words = words & PK_GC_AXIS_WORDS;
#if PK_BUILD_ARCS || PK_BUILD_G5
    int rc;
#endif

    /* [0] implicit motion command */
    if (axis_words && axis_cmd == PK_GC_AXCMD_NONE)
        axis_cmd = PK_GC_AXCMD_MOTION;
    /* line number */
    cmd->line_number = -1;
    if (has(b, PK_GC_W_N)) {
        uint32_t ln = word_uint(b, PK_GC_W_N);
        if (b->m[PK_GC_W_N] > 0 && ln > PK_GC_N_MAX)
            return PK_GC_E_LINE_NUMBER;
        cmd->line_number = (int32_t)ln;
    }
    /* [2. Set feed rate mode] [3. Set feed rate] */
    int32_t f = 0;
    if (jog) {
        if (!has(b, PK_GC_W_F))
            return PK_GC_E_UNDEFINED_FEED;
        if (word_um(b, PK_GC_W_F, units, &f) != PK_GC_OK)
            return PK_GC_E_BAD_NUMBER;
    } else if (feedmode == PK_GC_INVERSE_TIME) {
        if (axis_cmd == PK_GC_AXCMD_MOTION && motion != PK_GC_MOT_NONE &&
            motion != PK_GC_MOT_RAPID && !has(b, PK_GC_W_F))
            return PK_GC_E_UNDEFINED_FEED;
        if (has(b, PK_GC_W_F) &&
            word_milli(b, PK_GC_W_F, &f) != PK_GC_OK)
            return PK_GC_E_BAD_NUMBER; /* 1/min, in thousandths */
    } else {
        if (has(b, PK_GC_W_F)) {
            if (word_um(b, PK_GC_W_F, units, &f) != PK_GC_OK)
                return PK_GC_E_BAD_NUMBER;
        } else if (st->feedmode == PK_GC_UNITS_PER_MIN) {
            f = st->feed;
        } /* else: G93 -> G94 without F: undefined */
    }
    if (f > PK_GC_FEED_MAX)
        return PK_GC_E_BAD_NUMBER;
    /* [4. Set spindle speed] */
    int32_t s = st->spindle_s;
    if (has(b, PK_GC_W_S) && word_milli(b, PK_GC_W_S, &s) != PK_GC_OK)
        return PK_GC_E_BAD_NUMBER;
    /* [9. Override control] M56 P0 disables parking, M56 (P1) enables it */
    uint16_t used = 0;
    uint8_t parking = st->parking_ovr;
    if (b->groups & PK_GC_GBIT(PK_GC_G_OVERRIDE)) {
        parking = 1;
        if (has(b, PK_GC_W_P)) {
            if (b->m[PK_GC_W_P] == 0)
                parking = 0;
            used |= PK_GC_WBIT(PK_GC_W_P);
        }
    }
    /* [10. Dwell] */
    if (nonmodal == PK_GC_NM_DWELL) {
        if (!has(b, PK_GC_W_P))
            return PK_GC_E_VALUE_MISSING;
        used |= PK_GC_WBIT(PK_GC_W_P);
        int32_t ms;
        if (word_milli(b, PK_GC_W_P, &ms) != PK_GC_OK ||
            (uint32_t)ms > PK_GC_DWELL_MAX_MS)
            return PK_GC_E_BAD_NUMBER;
        cmd->dwell_ms = (uint32_t)ms;
    }
    /* [11. Set active plane] (its axes serve the arcs only) */
#if PK_BUILD_ARCS
    uint8_t ax0, ax1, axl;
    switch (plane) {
    case PK_GC_PLANE_ZX: ax0 = 2; ax1 = 0; axl = 1; break;
    case PK_GC_PLANE_YZ: ax0 = 1; ax1 = 2; axl = 0; break;
    default: ax0 = 0; ax1 = 1; axl = PK_GC_AXES >= 3 ? 2 : PK_GC_AXES; break;
    }
#endif
    /* [12. Set length units] axis words to µm */
    /* (the axis loops test a moving bit: a shift by a variable count is a
     * loop on the AVR) */
    int32_t xyz[PK_GC_AXES];
    for (int a = 0, bit = PK_GC_WBIT(PK_GC_W_X); a < PK_GC_AXES; a++, bit <<= 1) {
        xyz[a] = 0;
        if ((axis_words & bit) &&
            word_um(b, PK_GC_W_X + a, units, &xyz[a]) != PK_GC_OK)
            return PK_GC_E_BAD_NUMBER;
    }
    /* [14. Cutter length compensation] G43.1: Z only */
    if (axis_cmd == PK_GC_AXCMD_TLO && b->tlo == PK_GC_TLO_DYNAMIC &&
        axis_words != PK_GC_WBIT(PK_GC_W_X + TLO_AXIS))
        return PK_GC_E_G43_AXIS;
#if PK_GC_AXES >= 3
    if (axis_cmd == PK_GC_AXCMD_TLO && b->tlo == PK_GC_TLO_DYNAMIC && !in_range32(xyz[TLO_AXIS]))
        return PK_GC_E_TRAVEL; /* an offset stays within the travel range */
#endif
    /* [15. Coordinate system selection] */
    /* (the active offsets are read in place; a copy only of a new one) */
    int32_t wcs_read[PK_GC_AXES];
    const int32_t *wcs_um = st->wcs_um;
    if ((b->groups & PK_GC_GBIT(PK_GC_G_WCS)) && wcs != st->wcs) {
        if (coord_get(env, wcs, wcs_read) != 0)
            return PK_GC_E_READ_FAIL;
        wcs_um = wcs_read;
    }
    /* [19. Remaining non-modal actions] */
    /* The target is built in place in cmd->target_um (no copy from a local
     * and back), only where it is read: G0-G3, G5, G38 (axis_cmd MOTION),
     * G28/G30 (and the jog) take this last branch; G10 and G92 do not read
     * it, and a block without a move leaves it zero (cmd_done). */
    int32_t *const target = cmd->target_um;
    int32_t coord[PK_GC_AXES], g92[PK_GC_AXES];
    uint8_t coord_idx = 0;
    if (nonmodal == PK_GC_NM_SET_COORD) {
        if (!axis_words)
            return PK_GC_E_NO_AXIS_WORDS;
        if (!has(b, PK_GC_W_P) && !has(b, PK_GC_W_L))
            return PK_GC_E_VALUE_MISSING;
        uint32_t p = has(b, PK_GC_W_P) ? word_uint(b, PK_GC_W_P) : 0u;
        if (p > 6u)
            return 29; /* Grbl's STATUS_GCODE_UNSUPPORTED_COORD_SYS */
        uint32_t l = has(b, PK_GC_W_L) && b->m[PK_GC_W_L] >= 0 ? word_uint(b, PK_GC_W_L) : 0u;
        if (l != 20u && (l != 2u || has(b, PK_GC_W_R)))
            return PK_GC_E_UNSUPPORTED;
        used |= PK_GC_WBIT(PK_GC_W_L) | PK_GC_WBIT(PK_GC_W_P);
        coord_idx = p > 0u ? (uint8_t)(p - 1u) : wcs;
        if (coord_get(env, coord_idx, coord) != 0)
            return PK_GC_E_READ_FAIL;
        for (int a = 0, bit = PK_GC_WBIT(PK_GC_W_X); a < PK_GC_AXES; a++, bit <<= 1) {
            if (!(axis_words & bit))
                continue;
            if (!word_ok(xyz[a]))
                return PK_GC_E_TRAVEL;
            int32_t v = l == 20u ? st->pos_um[a] - st->g92_um[a] - xyz[a] : xyz[a];
#if PK_GC_AXES >= 3
            if (l == 20u && a == TLO_AXIS)
                v -= st->tlo_um;
#endif
            if (!in_range32(v))
                return PK_GC_E_TRAVEL;
            coord[a] = v;
        }
    } else if (nonmodal == PK_GC_NM_SET_OFFSET) {
        if (!axis_words)
            return PK_GC_E_NO_AXIS_WORDS;
        memcpy(g92, st->g92_um, sizeof g92); /* (g92 is read only by G92) */
        for (int a = 0, bit = PK_GC_WBIT(PK_GC_W_X); a < PK_GC_AXES; a++, bit <<= 1) {
            if (!(axis_words & bit))
                continue;
            if (!word_ok(xyz[a]) || !in_range32(wcs_um[a]))
                return PK_GC_E_TRAVEL;
            int32_t v = st->pos_um[a] - wcs_um[a] - xyz[a];
#if PK_GC_AXES >= 3
            if (a == TLO_AXIS)
                v -= st->tlo_um;
#endif
            if (!in_range32(v))
                return PK_GC_E_TRAVEL;
            g92[a] = v;
        }
    } else {
        /* the axes of the words move (not with G43.1), the others stay */
        memcpy(target, st->pos_um, sizeof cmd->target_um);
        if (axis_cmd != PK_GC_AXCMD_TLO && axis_words) {
            for (int a = 0, bit = PK_GC_WBIT(PK_GC_W_X); a < PK_GC_AXES; a++, bit <<= 1) {
                if (!(axis_words & bit))
                    continue;
                int32_t v = xyz[a];
                if (!word_ok(v) || !in_range32(wcs_um[a]))
                    return PK_GC_E_TRAVEL;
                if (nonmodal != PK_GC_NM_ABSOLUTE) {
                    if (distance == PK_GC_ABSOLUTE) {
                        v += wcs_um[a] + st->g92_um[a];
#if PK_GC_AXES >= 3
                        if (a == TLO_AXIS)
                            v += st->tlo_um;
#endif
                    } else {
                        v += st->pos_um[a];
                    }
                }
                if (!in_range32(v))
                    return PK_GC_E_TRAVEL;
                target[a] = v;
            }
        }
        if (nonmodal == PK_GC_NM_HOME0 || nonmodal == PK_GC_NM_HOME1) {
            unsigned idx = nonmodal == PK_GC_NM_HOME0 ? PK_GC_COORD_G28 : PK_GC_COORD_G30;
            if (coord_get(env, idx, coord) != 0)
                return PK_GC_E_READ_FAIL;
            if (axis_words) {
                for (int a = 0, bit = PK_GC_WBIT(PK_GC_W_X); a < PK_GC_AXES; a++, bit <<= 1)
                    if (!(axis_words & bit))
                        coord[a] = st->pos_um[a];
            } else {
                axis_cmd = PK_GC_AXCMD_NONE;
            }
            for (int a = 0; a < PK_GC_AXES; a++)
                if (!in_range32(coord[a]))
                    return PK_GC_E_TRAVEL;
        } else if (nonmodal == PK_GC_NM_ABSOLUTE) {
            if (motion != PK_GC_MOT_RAPID && motion != PK_GC_MOT_LINEAR)
                return PK_GC_E_G53_MOTION;
        }
    }
    /* [20. Motion modes] */
    int32_t pq[2] = { 0, 0 };
    if (motion == PK_GC_MOT_NONE) {
        if (axis_words)
            return PK_GC_E_UNUSED_WORDS;
    } else if (axis_cmd == PK_GC_AXCMD_MOTION) {
        if (motion == PK_GC_MOT_RAPID) {
            if (!axis_words)
                axis_cmd = PK_GC_AXCMD_NONE;
        } else {
            if (f == 0)
                return PK_GC_E_UNDEFINED_FEED;
            switch (motion) {
            case PK_GC_MOT_LINEAR:
                if (!axis_words)
                    axis_cmd = PK_GC_AXCMD_NONE;
                break;
            case PK_GC_MOT_CW_ARC:
            case PK_GC_MOT_CCW_ARC: {
#if !PK_BUILD_ARCS
                return PK_GC_E_UNSUPPORTED; /* g_word refused it already */
#else
                if (!axis_words)
                    return PK_GC_E_NO_AXIS_WORDS;
                if (!(axis_words & (PK_GC_WBIT(PK_GC_W_X + ax0) | PK_GC_WBIT(PK_GC_W_X + ax1))))
                    return PK_GC_E_NO_AXIS_IN_PLANE;
                struct pk_arc_geom g;
                memset(&g, 0, sizeof g);
                memcpy(g.start, st->pos_um, sizeof g.start);
                memcpy(g.end, target, sizeof g.end);
                g.a0 = ax0;
                g.a1 = ax1;
                g.al = axl;
                g.cw = motion == PK_GC_MOT_CW_ARC;
                if (has(b, PK_GC_W_R)) {
                    used |= PK_GC_WBIT(PK_GC_W_R);
                    if (memcmp(st->pos_um, target, sizeof cmd->target_um) == 0)
                        return PK_GC_E_BAD_TARGET;
                    int32_t r;
                    if (word_um(b, PK_GC_W_R, units, &r) != PK_GC_OK ||
                        r > (INT32_C(1) << 30) || r < -(INT32_C(1) << 30))
                        return PK_GC_E_BAD_TARGET;
                    rc = pk_arc_centre_r(&g, r);
                } else {
                    uint16_t ijk_plane = (uint16_t)(PK_GC_WBIT(PK_GC_W_I + ax0) | PK_GC_WBIT(PK_GC_W_I + ax1));
                    if (!(words & ijk_plane))
                        return PK_GC_E_NO_OFFSETS;
                    used |= PK_GC_WBIT(PK_GC_W_I) | PK_GC_WBIT(PK_GC_W_J) | PK_GC_WBIT(PK_GC_W_K);
                    int32_t o[2] = { 0, 0 };
                    for (int k = 0; k < 2; k++) {
                        int w = PK_GC_W_I + (k == 0 ? ax0 : ax1);
                        if (has(b, w) && word_um(b, w, units, &o[k]) != PK_GC_OK)
                            return PK_GC_E_BAD_TARGET;
                    }
                    rc = pk_arc_centre_ijk(&g, o[0], o[1]);
                }
                if (rc != PK_ARC_OK)
                    return rc;
                cmd->chord_tol_um = chord_tol(path, path_tol, env ? env->tol_default_um : 20);
                if (pk_arc_plan(&cmd->u.arc, &g, cmd->chord_tol_um) != PK_ARC_OK)
                    return PK_GC_E_BAD_TARGET;
                int32_t lo[PK_AXES], hi[PK_AXES];
                pk_arc_bounds(&cmd->u.arc, lo, hi);
                for (int a = 0; a < PK_GC_AXES; a++)
                    if (!in_range32(lo[a]) || !in_range32(hi[a]))
                        return PK_GC_E_TRAVEL;
                break;
#endif
            }
            case PK_GC_MOT_CUBIC:
            case PK_GC_MOT_QUAD:
#if !PK_BUILD_G5
                return PK_GC_E_UNSUPPORTED; /* g_word refused it already */
#else
                if (!axis_words)
                    return PK_GC_E_NO_AXIS_WORDS;
            {
                pk_um_t ctrl[4][2];
                rc = spline_ctrl(st, b, motion, units, plane, st->pos_um, target, ctrl, &used, pq);
                if (rc != PK_GC_OK)
                    return rc;
                cmd->chord_tol_um = chord_tol(path, path_tol, env ? env->tol_default_um : 20);
                pk_bez_init(&cmd->u.bez, (const pk_um_t(*)[2])ctrl, motion == PK_GC_MOT_QUAD,
                            cmd->chord_tol_um);
                break;
            }
#endif
            default: /* probes */
                if (!axis_words)
                    return PK_GC_E_NO_AXIS_WORDS;
                if (memcmp(st->pos_um, target, sizeof cmd->target_um) == 0)
                    return PK_GC_E_BAD_TARGET;
                break;
            }
        }
    }
    /* [0. Non-specific error-checks] unused words */
    if ((b->groups & PK_GC_GBIT(PK_GC_G_PATH)) && b->path == PK_GC_PATH_BLEND)
        used |= PK_GC_WBIT(PK_GC_W_P); /* plotkin: G64 P<tolerance> */
    used |= PK_GC_WBIT(PK_GC_W_N) | PK_GC_WBIT(PK_GC_W_F);
    if (!jog)
        used |= PK_GC_WBIT(PK_GC_W_S) | PK_GC_WBIT(PK_GC_W_T);
    if (axis_cmd)
        used |= PK_GC_AXIS_WORDS;
    if (words & ~used & PK_GC_WBIT(PK_GC_W_Q))
        return PK_GC_E_UNSUPPORTED; /* Q is not a Grbl word: error 20 there */
    if (words & ~used)
        return PK_GC_E_UNUSED_VALUE;

    /* plotkin: a feed move must run at 1 mm/min or more */
    int feed_move = axis_cmd == PK_GC_AXCMD_MOTION && motion != PK_GC_MOT_RAPID &&
                    motion != PK_GC_MOT_NONE;
    pk_gc_umpm_t move_feed = f;
    if (feed_move && feedmode == PK_GC_INVERSE_TIME && !jog) {
        /* G93: the move takes 1/F minutes: feed = length * F */
#if PK_BUILD_ARCS
        uint32_t len = (motion == PK_GC_MOT_CW_ARC || motion == PK_GC_MOT_CCW_ARC)
                           ? pk_arc_length_um(&cmd->u.arc) : move_len(st->pos_um, target);
#else
        uint32_t len = move_len(st->pos_um, target);
#endif
        if (PK_BUILD_G5 && (motion == PK_GC_MOT_CUBIC || motion == PK_GC_MOT_QUAD))
            return PK_GC_E_UNSUPPORTED; /* no curve length: G93 with G5 is not run */
        uint64_t v = ((uint64_t)len * (uint64_t)f + 999u) / 1000u;
        move_feed = v > (uint64_t)PK_GC_FEED_MAX ? PK_GC_FEED_MAX : (pk_gc_umpm_t)v;
    }
    if (feed_move && move_feed < PK_GC_FEED_MIN)
        return PK_GC_E_UNDEFINED_FEED;

    if (jog) {
        if (b->groups & ~(PK_GC_GBIT(PK_GC_G_DISTANCE) | PK_GC_GBIT(PK_GC_G_UNITS) |
                          PK_GC_GBIT(PK_GC_G_NONMODAL)))
            return PK_GC_E_INVALID_JOG;
        if (nonmodal != PK_GC_NM_ABSOLUTE && nonmodal != PK_GC_NM_NONE)
            return PK_GC_E_INVALID_JOG;
        if (axis_cmd == PK_GC_AXCMD_MOTION) {
            cmd->what = PK_GC_DO_MOVE;
            cmd->motion = PK_GC_MOT_LINEAR;
            cmd->feed_umpm = f;
            memcpy(cmd->start_um, st->pos_um, sizeof cmd->start_um);
            memcpy(n->pos_um, target, sizeof n->pos_um);
        }
        return PK_GC_OK;
    }

    /* program end resets to G54: its offsets are read now (the only read
     * that can fail), before anything is written */
    pk_um_t g54_um[PK_GC_AXES];
    if ((b->groups & PK_GC_GBIT(PK_GC_G_STOP)) && b->stop != PK_GC_STOP_OPTIONAL &&
        b->stop != PK_GC_STOP_PAUSE && wcs != 0) {
        if (coord_get(env, 0, g54_um) != 0)
            return PK_GC_E_READ_FAIL;
    }

    /* ---- execute: the new state and the actions, in Grbl's order ---- */
    n->line_number = cmd->line_number < 0 ? 0 : cmd->line_number;
    n->feedmode = feedmode;
    n->feed = f;
    if (s != st->spindle_s && st->spindle != PK_GC_SPINDLE_OFF)
        cmd->what |= PK_GC_DO_SPINDLE;
    n->spindle_s = s;
    /* [5. Select tool] Grbl copies T every block: a block without T is T0 */
    n->tool = has(b, PK_GC_W_T) ? (uint8_t)word_uint(b, PK_GC_W_T) : 0u;
    if ((b->groups & PK_GC_GBIT(PK_GC_G_SPINDLE)) && b->spindle != st->spindle) {
        cmd->what |= PK_GC_DO_SPINDLE;
        cmd->spindle_state_changed = 1;
        n->spindle = b->spindle;
    }
    cmd->spindle = n->spindle;
    cmd->spindle_s = s;
    if (b->groups & PK_GC_GBIT(PK_GC_G_COOLANT)) {
        uint8_t c = b->coolant == 9 ? 0u
                    : (uint8_t)(st->coolant | (b->coolant == 7 ? PK_GC_COOLANT_MIST : PK_GC_COOLANT_FLOOD));
        if (c != st->coolant)
            cmd->what |= PK_GC_DO_COOLANT;
        n->coolant = c;
    }
    cmd->coolant = n->coolant;
    n->parking_ovr = parking;
    if (nonmodal == PK_GC_NM_DWELL)
        cmd->what |= PK_GC_DO_DWELL;
    n->plane = plane;
    n->units = units;
    if (axis_cmd == PK_GC_AXCMD_TLO) {
        n->tlo = b->tlo;
        pk_um_t t = 0;
#if PK_GC_AXES >= 3
        if (b->tlo == PK_GC_TLO_DYNAMIC)
            t = xyz[TLO_AXIS];
#endif
        if (t != st->tlo_um) {
            n->tlo_um = t;
            cmd->what |= PK_GC_DO_WCO;
        }
    }
    if (wcs != st->wcs) { /* (then wcs_um is wcs_read: never a copy onto itself) */
        n->wcs = wcs;
        memcpy(n->wcs_um, wcs_um, sizeof n->wcs_um);
        cmd->what |= PK_GC_DO_WCO;
    }
    if (b->groups & PK_GC_GBIT(PK_GC_G_PATH)) {
        /* plotkin: G64 P<tol> (units); without P the $12 default */
        n->path = path;
        n->tol_um = path_tol;
        cmd->what |= PK_GC_DO_PATH;
        cmd->path = n->path;
        cmd->tol_um = n->tol_um;
    }
    n->distance = distance;
    switch (nonmodal) {
    case PK_GC_NM_SET_COORD:
        cmd->what |= PK_GC_DO_COORD;
        cmd->coord_idx = coord_idx;
        memcpy(cmd->coord_um, coord, sizeof coord);
        if (coord_idx == n->wcs) {
            memcpy(n->wcs_um, coord, sizeof coord);
            cmd->what |= PK_GC_DO_WCO;
        }
        break;
    case PK_GC_NM_HOME0:
    case PK_GC_NM_HOME1:
        if (axis_cmd) {
            cmd->what |= PK_GC_DO_VIA;
            memcpy(cmd->via_um, target, sizeof cmd->via_um);
        }
        cmd->what |= PK_GC_DO_MOVE;
        cmd->motion = PK_GC_MOT_RAPID;
        cmd->laser_off = 1;
        memcpy(cmd->start_um, axis_cmd ? target : st->pos_um, sizeof cmd->start_um);
        memcpy(cmd->target_um, coord, sizeof coord);
        memcpy(n->pos_um, coord, sizeof coord);
        break;
    case PK_GC_NM_SET_HOME0:
    case PK_GC_NM_SET_HOME1:
        cmd->what |= PK_GC_DO_COORD;
        cmd->coord_idx = nonmodal == PK_GC_NM_SET_HOME0 ? PK_GC_COORD_G28 : PK_GC_COORD_G30;
        memcpy(cmd->coord_um, st->pos_um, sizeof cmd->coord_um);
        break;
    case PK_GC_NM_SET_OFFSET:
        memcpy(n->g92_um, g92, sizeof g92);
        cmd->what |= PK_GC_DO_WCO;
        break;
    case PK_GC_NM_RESET_OFFSET:
        memset(n->g92_um, 0, sizeof n->g92_um);
        cmd->what |= PK_GC_DO_WCO;
        break;
    default:
        break;
    }
    n->motion = motion;
    if (motion != PK_GC_MOT_NONE && axis_cmd == PK_GC_AXCMD_MOTION) {
        cmd->what |= PK_GC_DO_MOVE;
        cmd->motion = motion;
        cmd->feed_umpm = motion == PK_GC_MOT_RAPID ? 0 : move_feed;
        cmd->laser_off = !(motion == PK_GC_MOT_LINEAR || motion == PK_GC_MOT_CW_ARC ||
                           motion == PK_GC_MOT_CCW_ARC || motion == PK_GC_MOT_CUBIC ||
                           motion == PK_GC_MOT_QUAD);
        memcpy(cmd->start_um, st->pos_um, sizeof cmd->start_um); /* (target_um: built in place) */
        /* a probe's end is where the probe triggers: synced by the engine */
        if (motion < PK_GC_MOT_PROBE_TOWARD)
            memcpy(n->pos_um, target, sizeof n->pos_um);
        n->cubic_prev = PK_BUILD_G5 && motion == PK_GC_MOT_CUBIC;
        n->prev_pq_um[0] = pq[0];
        n->prev_pq_um[1] = pq[1];
    }
    /* [21. Program flow] */
    if ((b->groups & PK_GC_GBIT(PK_GC_G_STOP)) && b->stop != PK_GC_STOP_OPTIONAL) {
        cmd->what |= PK_GC_DO_STOP;
        cmd->stop = b->stop;
        if (b->stop != PK_GC_STOP_PAUSE) {
            /* LinuxCNC's (and Grbl's) program end: G1 G17 G90 G94 G54 M5 M9;
             * other groups, offsets and F S T stay. */
            n->motion = PK_GC_MOT_LINEAR;
            n->plane = PK_GC_PLANE_XY;
            n->distance = PK_GC_ABSOLUTE;
            n->feedmode = PK_GC_UNITS_PER_MIN;
            if (n->wcs != 0)
                memcpy(n->wcs_um, g54_um, sizeof n->wcs_um);
            n->wcs = 0;
            n->spindle = PK_GC_SPINDLE_OFF;
            n->coolant = 0;
            n->cubic_prev = 0;
            cmd->what |= PK_GC_DO_WCO;
        }
    }
    return PK_GC_OK;
}

/* An accepted block without a move: its start and target are zero, as the
 * rest of *cmd before the union (interp cleared up to start_um). */
static int cmd_done(int rc, struct pk_gc_cmd *cmd)
{
    _Static_assert(offsetof(struct pk_gc_cmd, target_um) ==
                   offsetof(struct pk_gc_cmd, start_um) + sizeof cmd->start_um &&
                   offsetof(struct pk_gc_cmd, u) ==
                   offsetof(struct pk_gc_cmd, target_um) + sizeof cmd->target_um,
                   "start_um and target_um end the part before the union");
    if (rc == PK_GC_OK && !(cmd->what & PK_GC_DO_MOVE))
        memset((uint8_t *)cmd + offsetof(struct pk_gc_cmd, start_um), 0,
               offsetof(struct pk_gc_cmd, u) - offsetof(struct pk_gc_cmd, start_um));
    return rc;
}

int pk_gcode_interp(struct pk_gc_state *st, const struct pk_gc_block *b,
                    const struct pk_gc_env *env, struct pk_gc_cmd *cmd)
{
    return cmd_done(interp(st, b, env, 0, st, cmd), cmd);
}

int pk_gcode_jog(const struct pk_gc_state *st, const struct pk_gc_block *b, struct pk_gc_cmd *cmd)
{
    struct pk_gc_state n;
    return cmd_done(interp(st, b, NULL, 1, &n, cmd), cmd);
}
