/*
 * fuzz_gcode.c — libFuzzer target for the G-code parser and interpreter
 * (pk_gcode.h).
 *
 * The first byte picks the start position; the rest is split into lines at
 * '\n' (a line keeps its other bytes, CR and NUL included). Each line is
 * copied into a buffer of exactly its length, so AddressSanitizer catches any
 * read past it, parsed, and, when it parses, interpreted against a modal
 * state carried from line to line, like a program.
 *
 * Invariants checked:
 *   - parse returns PK_GC_OK or one of the documented error numbers; a line
 *     longer than PK_GC_LINE_MAX is never accepted.
 *   - an accepted block is clean: only defined word and group bits, every
 *     present word a mantissa of at most 9 digits with at most 9 decimals,
 *     every absent word zero.
 *   - parsing is a function of the bytes: parsing again gives the same status
 *     and an identical block, and so does the line with every ASCII letter
 *     upper-cased or lower-cased (letters are case-insensitive).
 *   - an error accepts nothing: a line that fails to parse is not
 *     interpreted, and a block the interpreter refuses leaves the modal state
 *     byte-for-byte unchanged.
 *   - an accepted move starts at the previous commanded position (G28/G30:
 *     from their intermediate point), ends within the machine's numeric range
 *     ±PK_UM_MAX, and becomes the new position (a probe's end is where it
 *     triggers: the position stays); a feed move has a feed of 1 mm/min or
 *     more; an arc's chords (all of them, pk_arc_next) stay within its bounds
 *     and end exactly on the target; a G5's control points are in range; a
 *     block without a move does not move the position.
 *   - pk_gcode_parse_number on the same bytes: any accepted value is a
 *     mantissa of at most 9 digits.
 */
#include "fuzz_common.h"
#include "pk_gcode.h"

#include <string.h>

static int known_status(int st)
{
    switch (st) {
    case PK_GC_OK: case PK_GC_E_EXPECTED_LETTER: case PK_GC_E_BAD_NUMBER: case PK_GC_E_NEGATIVE:
    case PK_GC_E_READ_FAIL: case PK_GC_E_LINE_OVERFLOW: case PK_GC_E_TRAVEL:
    case PK_GC_E_INVALID_JOG: case PK_GC_E_UNSUPPORTED: case PK_GC_E_MODAL_GROUP:
    case PK_GC_E_UNDEFINED_FEED: case PK_GC_E_NOT_INTEGER: case PK_GC_E_AXIS_CONFLICT:
    case PK_GC_E_REPEATED_WORD: case PK_GC_E_NO_AXIS_WORDS: case PK_GC_E_LINE_NUMBER:
    case PK_GC_E_VALUE_MISSING: case 29: case PK_GC_E_G53_MOTION: case PK_GC_E_UNUSED_WORDS:
    case PK_GC_E_NO_AXIS_IN_PLANE: case PK_GC_E_BAD_TARGET: case PK_GC_E_ARC_RADIUS:
    case PK_GC_E_NO_OFFSETS: case PK_GC_E_UNUSED_VALUE: case PK_GC_E_G43_AXIS:
    case PK_GC_E_TOOL_NUMBER:
        return 1;
    default:
        return 0;
    }
}

static void check_block(const struct pk_gc_block *b)
{
    FZ_CHECK((b->words >> PK_GC_W_COUNT) == 0u, "only defined word bits");
    FZ_CHECK((b->groups >> PK_GC_G_COUNT) == 0u, "only defined group bits");
    for (unsigned w = 0; w < PK_GC_W_COUNT; w++)
        if (b->words & PK_GC_WBIT(w))
            FZ_CHECK(b->m[w] <= 999999999 && b->m[w] >= -999999999 && b->dec[w] <= 9,
                     "word value: 9 digits, 9 decimals at most");
#define IN_GROUP(g) (b->groups & PK_GC_GBIT(g))
    FZ_CHECK(!IN_GROUP(PK_GC_G_MOTION) || b->motion <= PK_GC_MOT_NONE, "motion in range");
    FZ_CHECK((!IN_GROUP(PK_GC_G_DISTANCE) || b->distance <= PK_GC_INCREMENTAL) &&
             (!IN_GROUP(PK_GC_G_UNITS) || b->units <= PK_GC_INCH), "distance, units in range");
    FZ_CHECK((!IN_GROUP(PK_GC_G_PATH) || b->path <= PK_GC_PATH_BLEND) &&
             (!IN_GROUP(PK_GC_G_PLANE) || b->plane <= PK_GC_PLANE_YZ), "path, plane in range");
    FZ_CHECK(!IN_GROUP(PK_GC_G_WCS) || b->wcs <= 5, "coordinate system in range");
#undef IN_GROUP
}

/* Equal as far as the block means anything: the masks, each value word
 * that is present and each modal field whose group is commanded (the parser
 * leaves the other fields as they were). */
static int block_eq(const struct pk_gc_block *a, const struct pk_gc_block *b)
{
    if (a->words != b->words || a->groups != b->groups || a->axis_cmd != b->axis_cmd)
        return 0;
#define GROUP_FIELD_EQ(g, f) (!(a->groups & PK_GC_GBIT(g)) || a->f == b->f)
    if (!GROUP_FIELD_EQ(PK_GC_G_NONMODAL, nonmodal) || !GROUP_FIELD_EQ(PK_GC_G_MOTION, motion) ||
        !GROUP_FIELD_EQ(PK_GC_G_DISTANCE, distance) || !GROUP_FIELD_EQ(PK_GC_G_UNITS, units) ||
        !GROUP_FIELD_EQ(PK_GC_G_PATH, path) || !GROUP_FIELD_EQ(PK_GC_G_STOP, stop) ||
        !GROUP_FIELD_EQ(PK_GC_G_SPINDLE, spindle) || !GROUP_FIELD_EQ(PK_GC_G_PLANE, plane) ||
        !GROUP_FIELD_EQ(PK_GC_G_FEEDMODE, feedmode) || !GROUP_FIELD_EQ(PK_GC_G_TLO, tlo) ||
        !GROUP_FIELD_EQ(PK_GC_G_WCS, wcs) || !GROUP_FIELD_EQ(PK_GC_G_COOLANT, coolant))
        return 0;
#undef GROUP_FIELD_EQ
    for (unsigned w = 0; w < PK_GC_W_COUNT; w++)
        if ((a->words & PK_GC_WBIT(w)) && (a->m[w] != b->m[w] || a->dec[w] != b->dec[w]))
            return 0;
    return 1;
}

static int in_range(int64_t v) { return v >= -PK_UM_MAX && v <= PK_UM_MAX; }

/* stored coordinate data: all zero, readable */
static int coord_read(void *ctx, unsigned idx, pk_um_t out[PK_GC_AXES])
{
    (void)ctx;
    (void)idx;
    memset(out, 0, sizeof(pk_um_t) * PK_GC_AXES);
    return 0;
}

/* Bytes of input used (tests/fuzz/fuzz_gcode.options passes the same
 * -max_len): room for lines well past PK_GC_LINE_MAX. */
#define MAX_INPUT 1024u

/* An exact-length copy in slot k (fuzz_common.h: static, poisoned around
 * under ASan): 0 the line, 1 its case-folded copy. */
static uint8_t *dup_exact(unsigned k, const uint8_t *s, size_t n) { return fz_exact(k, s, n); }

static void one_line(struct pk_gc_state *st, const uint8_t *src, size_t n)
{
    uint8_t *line = dup_exact(0, src, n);
    struct pk_gc_block b, b2;
    memset(&b, 0xA5, sizeof b); /* "fully overwritten": stale bytes must not survive */
    int ps = pk_gcode_parse(line, n, &b);
    FZ_CHECK(known_status(ps), "parse returns a documented status");
    if (n > PK_GC_LINE_MAX)
        FZ_CHECK(ps != PK_GC_OK, "an over-long line is refused");

    memset(&b2, 0x5A, sizeof b2);
    FZ_CHECK(pk_gcode_parse(line, n, &b2) == ps, "parsing twice gives the same status");
    if (ps == PK_GC_OK)
        FZ_CHECK(block_eq(&b, &b2), "parsing twice gives the same block");

    for (int up = 0; up < 2; up++) { /* letters are case-insensitive */
        uint8_t *c = dup_exact(1, line, n);
        for (size_t i = 0; i < n; i++) {
            if (up && c[i] >= 'a' && c[i] <= 'z')
                c[i] = (uint8_t)(c[i] - 'a' + 'A');
            if (!up && c[i] >= 'A' && c[i] <= 'Z')
                c[i] = (uint8_t)(c[i] - 'A' + 'a');
        }
        memset(&b2, 0x3C, sizeof b2);
        FZ_CHECK(pk_gcode_parse(c, n, &b2) == ps, "case does not change the status");
        if (ps == PK_GC_OK)
            FZ_CHECK(block_eq(&b, &b2), "case does not change the block");
    }

    int32_t nm;
    uint8_t nd;
    if (pk_gcode_parse_number(line, n, &nm, &nd) == PK_GC_OK)
        FZ_CHECK(nm <= 999999999 && nm >= -999999999 && nd <= 9, "a parsed number is in range");

    if (ps != PK_GC_OK)
        return; /* an error accepts nothing: nothing to interpret */
    check_block(&b);

    struct pk_gc_state before = *st;
    static struct pk_gc_cmd cmd;
    static const struct pk_gc_env env = { coord_read, NULL, 20 };
    int is = pk_gcode_interp(st, &b, &env, &cmd);
    FZ_CHECK(known_status(is), "interp returns a documented status");
    if (is != PK_GC_OK) {
        FZ_CHECK(memcmp(&before, st, sizeof before) == 0, "a refused block changes nothing");
        return;
    }
    FZ_CHECK(cmd.feed_umpm >= 0 && cmd.feed_umpm <= PK_GC_FEED_MAX, "feed in range");
    if (cmd.what & PK_GC_DO_MOVE) {
        const pk_um_t *from = (cmd.what & PK_GC_DO_VIA) ? cmd.via_um : before.pos_um;
        int probe = cmd.motion >= PK_GC_MOT_PROBE_TOWARD && cmd.motion <= PK_GC_MOT_PROBE_AWAY_NO_ERROR;
        for (unsigned a = 0; a < PK_GC_AXES; a++) {
            FZ_CHECK(cmd.start_um[a] == from[a], "a move starts where the last one ended");
            FZ_CHECK(in_range(cmd.target_um[a]), "a move ends within the numeric range");
            FZ_CHECK(st->pos_um[a] == (probe ? before.pos_um[a] : cmd.target_um[a]),
                     "the target becomes the position");
        }
        if (cmd.motion != PK_GC_MOT_RAPID)
            FZ_CHECK(cmd.feed_umpm >= PK_GC_FEED_MIN, "a feed move has a feed of 1 mm/min or more");
        if (cmd.motion == PK_GC_MOT_CW_ARC || cmd.motion == PK_GC_MOT_CCW_ARC) {
            int32_t lo[PK_AXES], hi[PK_AXES];
            pk_arc_bounds(&cmd.u.arc, lo, hi);
            pk_um_t v[PK_AXES];
            uint32_t k = 0;
            int last_ok = 0;
            while (k < 2000000u && pk_arc_next(&cmd.u.arc, v)) {
                for (unsigned a = 0; a < PK_GC_AXES; a++)
                    FZ_CHECK(v[a] >= lo[a] && v[a] <= hi[a], "arc chords stay within its bounds");
                last_ok = memcmp(v, cmd.target_um, sizeof v) == 0;
                k++;
            }
            FZ_CHECK(k == pk_arc_chords(&cmd.u.arc) && last_ok, "an arc ends exactly on its target");
        }
        if (cmd.motion == PK_GC_MOT_CUBIC || cmd.motion == PK_GC_MOT_QUAD)
            for (unsigned k = 0; k < 4; k++)
                for (unsigned a = 0; a < 2u; a++)
                    FZ_CHECK(in_range(cmd.u.bez.p[k][a]), "control points in range");
    } else {
        for (unsigned a = 0; a < PK_GC_AXES; a++)
            FZ_CHECK(st->pos_um[a] == before.pos_um[a], "no move, no change of position");
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    size = size < MAX_INPUT ? size : MAX_INPUT;
    struct fz_in in = { data, size, 0 };
    uint8_t sel = fz_u8(&in);
    pk_um_t home[PK_GC_AXES];
    for (unsigned a = 0; a < PK_GC_AXES; a++) {
        switch (sel & 3u) {
        case 0: home[a] = 0; break;
        case 1: home[a] = PK_UM_MAX; break;
        case 2: home[a] = -PK_UM_MAX; break;
        default: home[a] = -50000; break;
        }
    }
    static struct pk_gc_state st;
    pk_gcode_state_init(&st, home, NULL);

    const uint8_t *p = data + in.i;
    size_t left = size - in.i;
    while (left > 0u) {
        const uint8_t *nl = memchr(p, '\n', left);
        size_t n = nl ? (size_t)(nl - p) : left;
        one_line(&st, p, n);
        if (!nl)
            break;
        p += n + 1u;
        left -= n + 1u;
    }
    return 0;
}
