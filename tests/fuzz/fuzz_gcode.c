/*
 * fuzz_gcode.c — libFuzzer target for the G-code parser and interpreter
 * (pk_gcode.h).
 *
 * The first byte picks the machine travel; the rest is split into lines at
 * '\n' (a line keeps its other bytes, CR and NUL included). Each line is
 * copied into a buffer of exactly its length, so AddressSanitizer catches any
 * read past it, parsed, and, when it parses, interpreted against a modal
 * state carried from line to line, like a program.
 *
 * Invariants checked:
 *   - parse returns PK_GC_OK or one of the documented error numbers; a line
 *     longer than PK_GC_LINE_MAX is never accepted.
 *   - an accepted block is clean: only defined word and group bits, every
 *     present word within ±PK_GC_U6_MAX, every absent word zero, enums in
 *     range, N an integer in 0..PK_GC_N_MAX.
 *   - parsing is a function of the bytes: parsing again gives the same status
 *     and an identical block, and so does the line with every ASCII letter
 *     upper-cased or lower-cased (letters are case-insensitive).
 *   - an error accepts nothing: a line that fails to parse is not
 *     interpreted, and a block the interpreter refuses leaves the modal state
 *     byte-for-byte unchanged.
 *   - an accepted move starts at the previous commanded position, ends
 *     inside the travel (its G5/G5.1 control points too), and becomes the new
 *     position; the feed is within 0..PK_GC_FEED_MAX and non-zero for
 *     G1/G5/G5.1; a block without a move does not move the position.
 *   - pk_gcode_parse_number on the same bytes: any accepted value is within
 *     ±PK_GC_U6_MAX.
 */
#include "fuzz_common.h"
#include "pk_gcode.h"

#include <string.h>

static int known_status(int st)
{
    switch (st) {
    case PK_GC_OK: case PK_GC_E_EXPECTED_LETTER: case PK_GC_E_BAD_NUMBER: case PK_GC_E_NEGATIVE:
    case PK_GC_E_LINE_OVERFLOW: case PK_GC_E_TRAVEL: case PK_GC_E_UNSUPPORTED:
    case PK_GC_E_MODAL_GROUP: case PK_GC_E_UNDEFINED_FEED: case PK_GC_E_NOT_INTEGER:
    case PK_GC_E_AXIS_CONFLICT: case PK_GC_E_REPEATED_WORD: case PK_GC_E_NO_AXIS_WORDS:
    case PK_GC_E_LINE_NUMBER: case PK_GC_E_VALUE_MISSING: case PK_GC_E_UNUSED_WORDS:
    case PK_GC_E_BAD_TARGET: case PK_GC_E_UNUSED_VALUE: case PK_GC_E_TOOL_NUMBER:
        return 1;
    default:
        return 0;
    }
}

static void check_block(const struct pk_gc_block *b)
{
    FZ_CHECK((b->words >> PK_GC_W_COUNT) == 0u, "only defined word bits");
    FZ_CHECK((b->groups >> PK_GC_G_COUNT) == 0u, "only defined group bits");
    for (unsigned w = 0; w < PK_GC_W_COUNT; w++) {
        if (b->words & PK_GC_WBIT(w))
            FZ_CHECK(b->v[w] <= PK_GC_U6_MAX && b->v[w] >= -PK_GC_U6_MAX, "word value in range");
        else
            FZ_CHECK(b->v[w] == 0, "absent words are zero");
    }
    if (b->words & PK_GC_WBIT(PK_GC_W_N)) {
        FZ_CHECK(b->v[PK_GC_W_N] >= 0 && b->v[PK_GC_W_N] % PK_GC_U6_ONE == 0 &&
                     b->v[PK_GC_W_N] / PK_GC_U6_ONE <= PK_GC_N_MAX,
                 "N is an integer in 0..PK_GC_N_MAX");
    }
    FZ_CHECK(b->nonmodal <= PK_GC_NM_SET_OFFSET, "nonmodal in range");
    FZ_CHECK(b->motion <= PK_GC_MOT_NONE, "motion in range");
    FZ_CHECK(b->distance <= PK_GC_INCREMENTAL && b->units <= PK_GC_INCH, "distance, units in range");
    FZ_CHECK(b->path <= PK_GC_PATH_BLEND && b->spindle <= PK_GC_PEN_DOWN, "path, spindle in range");
    FZ_CHECK(b->stop == 0 || b->stop == PK_GC_STOP_END || b->stop == PK_GC_STOP_END_RESET,
             "stop in range");
}

/* Field by field: the struct has padding the parser need not write. */
static int block_eq(const struct pk_gc_block *a, const struct pk_gc_block *b)
{
    if (a->words != b->words || a->groups != b->groups || a->nonmodal != b->nonmodal ||
        a->motion != b->motion || a->distance != b->distance || a->units != b->units ||
        a->path != b->path || a->stop != b->stop || a->spindle != b->spindle)
        return 0;
    for (unsigned w = 0; w < PK_GC_W_COUNT; w++)
        if (a->v[w] != b->v[w])
            return 0;
    return 1;
}

static int inside(const struct pk_gc_limits *l, unsigned a, int64_t v)
{
    return v >= l->min_um[a] && v <= l->max_um[a];
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

    pk_gc_u6_t num;
    if (pk_gcode_parse_number(line, n, &num) == PK_GC_OK)
        FZ_CHECK(num <= PK_GC_U6_MAX && num >= -PK_GC_U6_MAX, "a parsed number is in range");

    if (ps != PK_GC_OK)
        return; /* an error accepts nothing: nothing to interpret */
    check_block(&b);

    struct pk_gc_state before = *st;
    struct pk_gc_cmd cmd;
    int is = pk_gcode_interp(st, &b, &cmd);
    FZ_CHECK(known_status(is), "interp returns a documented status");
    if (is != PK_GC_OK) {
        FZ_CHECK(memcmp(&before, st, sizeof before) == 0, "a refused block changes nothing");
        return;
    }
    FZ_CHECK(cmd.feed_umpm >= 0 && cmd.feed_umpm <= PK_GC_FEED_MAX, "feed in range");
    FZ_CHECK(st->feed_umpm >= 0 && st->feed_umpm <= PK_GC_FEED_MAX, "modal feed in range");
    if (cmd.what & PK_GC_DO_MOVE) {
        for (unsigned a = 0; a < PK_GC_AXES; a++) {
            FZ_CHECK(cmd.start_um[a] == before.pos_um[a], "a move starts where the last one ended");
            FZ_CHECK(inside(&st->lim, a, cmd.target_um[a]), "a move ends inside the travel");
            FZ_CHECK(st->pos_um[a] == cmd.target_um[a], "the target becomes the position");
        }
        FZ_CHECK(cmd.motion <= PK_GC_MOT_QUAD, "a move is G0, G1, G5 or G5.1");
        FZ_CHECK(cmd.motion != PK_GC_MOT_CW_ARC && cmd.motion != PK_GC_MOT_CCW_ARC,
                 "arcs are refused");
        if (cmd.motion != PK_GC_MOT_RAPID)
            FZ_CHECK(cmd.feed_umpm > 0, "a feed move has a feed");
        unsigned nctrl = cmd.motion == PK_GC_MOT_CUBIC ? 2u : cmd.motion == PK_GC_MOT_QUAD ? 1u : 0u;
        for (unsigned k = 0; k < nctrl; k++)
            for (unsigned a = 0; a < 2u; a++)
                FZ_CHECK(inside(&st->lim, a, cmd.ctrl_um[k][a]), "control points inside the travel");
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
    struct pk_gc_limits lim;
    for (unsigned a = 0; a < PK_GC_AXES; a++) {
        switch (sel & 3u) {
        case 0: lim.min_um[a] = 0; lim.max_um[a] = 300000; break;          /* a plotter */
        case 1: lim.min_um[a] = -PK_UM_MAX; lim.max_um[a] = PK_UM_MAX; break; /* everything */
        case 2: lim.min_um[a] = -1000; lim.max_um[a] = 1000; break;         /* tiny */
        default: lim.min_um[a] = -50000; lim.max_um[a] = 0; break;          /* negative space */
        }
    }
    pk_um_t home[PK_GC_AXES] = { lim.min_um[0], lim.min_um[1], lim.max_um[2] };
    struct pk_gc_state st;
    pk_gcode_state_init(&st, &lim, home);

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
