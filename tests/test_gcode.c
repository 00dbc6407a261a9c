/*
 * test_gcode.c — the G-code parser and interpreter (firmware/pk_gcode.c).
 *
 * References are independent of the code under test: expected values are
 * written by hand from the G-code text (or, for the number round trip and the
 * single-byte sweep, computed by a separate rule in this file), and error
 * numbers are Grbl 1.1's published table.
 */
#include <stdio.h>
#include <string.h>
#include "th.h"
#include "pk_gcode.h"

#define U6(x) ((pk_gc_u6_t)(x) * PK_GC_U6_ONE)

static int parse(const char *s, struct pk_gc_block *b)
{
    return pk_gcode_parse((const uint8_t *)s, strlen(s), b);
}

static int parse_rc(const char *s)
{
    struct pk_gc_block b;
    return parse(s, &b);
}

static void test_a_plain_line_gives_its_words_and_commands(void)
{
    struct pk_gc_block b;
    TH_ASSERT_EQ(parse("G1 X10.5 Y-3 F1500", &b), PK_GC_OK);
    TH_EXPECT(b.groups == PK_GC_GBIT(PK_GC_G_MOTION));
    TH_EXPECT_EQ(b.motion, PK_GC_MOT_LINEAR);
    TH_EXPECT(b.words == (PK_GC_WBIT(PK_GC_W_X) | PK_GC_WBIT(PK_GC_W_Y) | PK_GC_WBIT(PK_GC_W_F)));
    TH_EXPECT_EQ(b.v[PK_GC_W_X], 10500000);
    TH_EXPECT_EQ(b.v[PK_GC_W_Y], -3000000);
    TH_EXPECT_EQ(b.v[PK_GC_W_F], U6(1500));
}

static void test_case_whitespace_and_comments_do_not_change_the_block(void)
{
    static const char *const same[] = {
        "g1x10.5y-3f1500",
        "  G 1 X 1 0 . 5 Y - 3 F 1500  ",
        "\tG01\tX10.50\tY-3.\tF1500.000",
        "G1 (first comment) X10.5 (second) Y-3 F1500 ; trailing comment",
        "G1 X1(inside a number)0.5 Y-3 F1500",
        "/G1 X10.5 Y-3 F1500",
        "G1 X+10.5 Y-3 F1500 (unclosed comment to the end, as Grbl accepts",
        "G1 X10.5 Y-3 F1500 (caf\xc3\xa9: UTF-8 inside a comment is fine)",
        "N0 G1 X10.5 Y-3 F1500",
    };
    struct pk_gc_block ref, b;
    TH_ASSERT_EQ(parse("G1 X10.5 Y-3 F1500", &ref), PK_GC_OK);
    for (unsigned i = 0; i < TH_COUNT(same); i++) {
        TH_EXPECT_EQ(parse(same[i], &b), PK_GC_OK);
        b.words &= (uint16_t)~PK_GC_WBIT(PK_GC_W_N);
        b.v[PK_GC_W_N] = 0;
        if (memcmp(&b, &ref, sizeof b) != 0) {
            th_print("  differs: ");
            th_print(same[i]);
            th_print("\n");
            TH_EXPECT(0);
        }
    }
}

static void test_empty_and_comment_only_lines_parse_to_an_empty_block(void)
{
    static const char *const empty[] = { "", " ", "\t", "(hello)", "; only a comment", "%",
                                         " % ", "/", "()", "(a)(b) ;c" };
    for (unsigned i = 0; i < TH_COUNT(empty); i++) {
        struct pk_gc_block b;
        TH_EXPECT_EQ(parse(empty[i], &b), PK_GC_OK);
        TH_EXPECT(b.words == 0 && b.groups == 0);
    }
    struct pk_gc_block b;
    TH_EXPECT_EQ(pk_gcode_parse(NULL, 0, &b), PK_GC_OK);
}

static void test_decimals_round_to_the_micro_unit_ties_away_from_zero(void)
{
    static const struct { const char *s; pk_gc_u6_t v; } cases[] = {
        { "X0.0000005", 1 },        { "X-0.0000005", -1 },
        { "X0.00000049999", 0 },    { "X1.23456789", 1234568 },
        { "X.5", 500000 },          { "X-.25", -250000 },
        { "X5.", 5000000 },         { "X0000000001.5", 1500000 },
        { "X999999999.999999", PK_GC_U6_MAX }, { "X-999999999.999999", -PK_GC_U6_MAX },
        { "X0.9999996", 1000000 },  { "X-0", 0 },
    };
    for (unsigned i = 0; i < TH_COUNT(cases); i++) {
        struct pk_gc_block b;
        TH_EXPECT_EQ(parse(cases[i].s, &b), PK_GC_OK);
        TH_EXPECT_EQ(b.v[PK_GC_W_X], cases[i].v);
    }
}

/* Deterministic pseudo-random numbers (LCG), independent of the parser. */
static uint64_t rng_state = 0x9e3779b97f4a7c15ull;
static uint64_t rng(void)
{
    rng_state = rng_state * 6364136223846793005ull + 1442695040888963407ull;
    return rng_state >> 11;
}

static void test_every_printed_number_reads_back_exactly(void)
{
    for (int i = 0; i < 20000; i++) {
        int64_t v = (int64_t)(rng() % (uint64_t)(PK_GC_U6_MAX + 1));
        if (i % 3 == 0)
            v %= 100000000;  /* plenty of small values too */
        if (rng() & 1)
            v = -v;
        int64_t a = v < 0 ? -v : v;
        char s[64];
        snprintf(s, sizeof s, "Y%s%lld.%06lld", v < 0 ? "-" : "", (long long)(a / 1000000),
                 (long long)(a % 1000000));
        struct pk_gc_block b;
        TH_ASSERT_EQ(parse(s, &b), PK_GC_OK);
        TH_ASSERT_EQ(b.v[PK_GC_W_Y], v);
    }
}

static void test_line_numbers_are_integers_within_grbl_range(void)
{
    struct pk_gc_block b;
    TH_EXPECT_EQ(parse("N9999999 G0 X1", &b), PK_GC_OK);
    TH_EXPECT_EQ(b.v[PK_GC_W_N], U6(9999999));
    TH_EXPECT_EQ(parse_rc("N10000000 G0 X1"), PK_GC_E_LINE_NUMBER);
    TH_EXPECT_EQ(parse_rc("N1.5 G0 X1"), PK_GC_E_LINE_NUMBER);
    TH_EXPECT_EQ(parse_rc("N-1 G0 X1"), PK_GC_E_LINE_NUMBER);
    TH_EXPECT_EQ(parse_rc("N1 N2"), PK_GC_E_REPEATED_WORD);
}

/* The table of bad lines and the Grbl error each must get. */
static const struct bad_line {
    const char *s;
    int err;
} bad_lines[] = {
    /* 1: expected command letter (also every byte that is not G-code) */
    { "12", PK_GC_E_EXPECTED_LETTER },
    { "G1 X1 )", PK_GC_E_EXPECTED_LETTER },
    { "G1 #1", PK_GC_E_EXPECTED_LETTER },
    { "G1 X1 *5", PK_GC_E_EXPECTED_LETTER },
    { "G1 X1 \x01", PK_GC_E_EXPECTED_LETTER },
    { "G1 X\x7f", PK_GC_E_EXPECTED_LETTER },
    { "G1 X1 \x80", PK_GC_E_EXPECTED_LETTER },
    { "G1 X1\xff", PK_GC_E_EXPECTED_LETTER },
    { "\xc3\xa9", PK_GC_E_EXPECTED_LETTER },
    { "G1 (bell \x07 in a comment)", PK_GC_E_EXPECTED_LETTER },
    { "G1 ; escape \x1b in a comment", PK_GC_E_EXPECTED_LETTER },
    { "% G1", PK_GC_E_UNSUPPORTED },
    /* 2: bad number format / missing value / does not fit */
    { "G1 X", PK_GC_E_BAD_NUMBER },
    { "G1 XY1", PK_GC_E_BAD_NUMBER },
    { "G X1", PK_GC_E_BAD_NUMBER },
    { "G1 X-", PK_GC_E_BAD_NUMBER },
    { "G1 X.", PK_GC_E_BAD_NUMBER },
    { "G1 X+-1", PK_GC_E_BAD_NUMBER },
    { "G1 X1.2.3", PK_GC_E_BAD_NUMBER },
    { "G1 X1-2", PK_GC_E_BAD_NUMBER },
    { "G1 X1234567890", PK_GC_E_BAD_NUMBER },
    { "G1 X999999999.9999995", PK_GC_E_BAD_NUMBER },
    { "G1 X99999999999999999999999", PK_GC_E_BAD_NUMBER },
    { "M", PK_GC_E_BAD_NUMBER },
    { "F", PK_GC_E_BAD_NUMBER },
    /* 4: negative where a positive value is expected */
    { "G1 X1 F-100", PK_GC_E_NEGATIVE },
    { "M3 S-1", PK_GC_E_NEGATIVE },
    { "G4 P-1", PK_GC_E_NEGATIVE },
    { "T-1", PK_GC_E_NEGATIVE },
    /* 20: unsupported command or unknown word */
    { "G1 A5", PK_GC_E_UNSUPPORTED },
    { "G1 X1 E0.5", PK_GC_E_UNSUPPORTED },
    { "H1", PK_GC_E_UNSUPPORTED },
    { "G18", PK_GC_E_UNSUPPORTED },
    { "G28", PK_GC_E_UNSUPPORTED },
    { "G93", PK_GC_E_UNSUPPORTED },
    { "G5.2 X1 Y1", PK_GC_E_UNSUPPORTED },
    { "G-1", PK_GC_E_UNSUPPORTED },
    { "G100", PK_GC_E_UNSUPPORTED },
    { "M4", PK_GC_E_UNSUPPORTED },
    { "M8", PK_GC_E_UNSUPPORTED },
    { "M-3", PK_GC_E_UNSUPPORTED },
    /* 21: two commands of one modal group */
    { "G0 G1 X1", PK_GC_E_MODAL_GROUP },
    { "G90 G91", PK_GC_E_MODAL_GROUP },
    { "G20 G21", PK_GC_E_MODAL_GROUP },
    { "G61 G64", PK_GC_E_MODAL_GROUP },
    { "M3 M5", PK_GC_E_MODAL_GROUP },
    { "M2 M30", PK_GC_E_MODAL_GROUP },
    { "G4 P1 G92 X0", PK_GC_E_MODAL_GROUP },
    { "G1 G5.1 X1 I1", PK_GC_E_MODAL_GROUP },
    { "G17 G17", PK_GC_E_MODAL_GROUP },
    /* 23: command number with a fraction it does not have */
    { "G1.5 X1", PK_GC_E_NOT_INTEGER },
    { "G92.1", PK_GC_E_NOT_INTEGER },
    { "G64.5", PK_GC_E_NOT_INTEGER },
    { "M3.5", PK_GC_E_NOT_INTEGER },
    { "T1.5", PK_GC_E_NOT_INTEGER },
    /* 24: two commands that use axis words */
    { "G1 G92 X0", PK_GC_E_AXIS_CONFLICT },
    { "G92 G0 X0", PK_GC_E_AXIS_CONFLICT },
    /* 25: repeated word */
    { "G1 X1 X2", PK_GC_E_REPEATED_WORD },
    { "G1 x1 X1", PK_GC_E_REPEATED_WORD },
    { "F100 F200", PK_GC_E_REPEATED_WORD },
    { "G5 X1 Y1 I1 J1 P1 P1 Q1", PK_GC_E_REPEATED_WORD },
    /* 26: G92 needs axis words */
    { "G92", PK_GC_E_NO_AXIS_WORDS },
    /* 27: line number */
    { "N12345678", PK_GC_E_LINE_NUMBER },
    /* 28: required value word missing */
    { "G4", PK_GC_E_VALUE_MISSING },
    { "G4 X1", PK_GC_E_VALUE_MISSING },
    /* 38: tool number */
    { "T256", PK_GC_E_TOOL_NUMBER },
};

static void test_every_bad_line_gets_its_grbl_error(void)
{
    for (unsigned i = 0; i < TH_COUNT(bad_lines); i++) {
        int rc = parse_rc(bad_lines[i].s);
        if (rc != bad_lines[i].err) {
            th_print("  line: ");
            th_print(bad_lines[i].s);
            th_print("\n");
        }
        TH_EXPECT_EQ(rc, bad_lines[i].err);
    }
}

static void test_an_over_long_line_is_error_11_and_the_longest_legal_one_parses(void)
{
    char s[PK_GC_LINE_MAX + 2];
    memset(s, ' ', sizeof s);
    memcpy(s, "G1 X1", 5);
    TH_EXPECT_EQ(pk_gcode_parse((const uint8_t *)s, PK_GC_LINE_MAX, &(struct pk_gc_block){ 0 }),
                 PK_GC_OK);
    TH_EXPECT_EQ(pk_gcode_parse((const uint8_t *)s, PK_GC_LINE_MAX + 1,
                                &(struct pk_gc_block){ 0 }),
                 PK_GC_E_LINE_OVERFLOW);
}

/* Independent rule for a line of one byte. */
static int one_byte_expected(unsigned c)
{
    if (c == ' ' || c == '\t' || c == ';' || c == '(' || c == '/' || c == '%')
        return PK_GC_OK;
    if ((c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z'))
        return PK_GC_E_BAD_NUMBER; /* a letter with no value */
    return PK_GC_E_EXPECTED_LETTER;
}

static void test_every_single_byte_line_is_accepted_or_refused_as_grbl_would(void)
{
    for (unsigned c = 0; c < 256; c++) {
        uint8_t line[1] = { (uint8_t)c };
        struct pk_gc_block b;
        TH_EXPECT_EQ(pk_gcode_parse(line, 1, &b), one_byte_expected(c));
    }
}

static void test_spaces_inserted_anywhere_in_a_valid_line_change_nothing(void)
{
    static const char *const lines[] = { "G5X10Y20I1J2P-3Q4F100", "N12G1X-1.25Y.5Z3F2000",
                                         "G64P0.05", "G4P1.5", "M3S1000" };
    for (unsigned k = 0; k < TH_COUNT(lines); k++) {
        struct pk_gc_block ref, b;
        TH_ASSERT_EQ(parse(lines[k], &ref), PK_GC_OK);
        size_t n = strlen(lines[k]);
        for (size_t cut = 0; cut <= n; cut++) {
            char s[64];
            memcpy(s, lines[k], cut);
            s[cut] = ' ';
            memcpy(s + cut + 1, lines[k] + cut, n - cut + 1);
            TH_ASSERT_EQ(parse(s, &b), PK_GC_OK);
            TH_EXPECT(memcmp(&b, &ref, sizeof b) == 0);
        }
    }
}

static void test_random_bytes_never_crash_and_always_get_a_listed_answer(void)
{
    static const int listed[] = { 0, 1, 2, 4, 11, 20, 21, 23, 24, 25, 26, 27, 28, 38 };
    static const char alphabet[] = "GMXYZFNPQIJKRST0123456789.-+ ()%;/\x01\xff";
    for (int i = 0; i < 50000; i++) {
        uint8_t s[40];
        size_t n = (size_t)(rng() % sizeof s);
        for (size_t j = 0; j < n; j++)
            s[j] = (i & 1) ? (uint8_t)alphabet[rng() % (sizeof alphabet - 1)] : (uint8_t)rng();
        struct pk_gc_block b;
        int rc = pk_gcode_parse(s, n, &b);
        int ok = 0;
        for (unsigned k = 0; k < TH_COUNT(listed); k++)
            ok |= rc == listed[k];
        TH_ASSERT(ok);
        TH_ASSERT(rc != PK_GC_OK || (b.words & ~((1u << PK_GC_W_COUNT) - 1u)) == 0);
    }
}

/* ---- interpreter --------------------------------------------------------- */

static void init_state(struct pk_gc_state *st)
{
    struct pk_gc_limits lim = { { 0, 0, -50000 }, { 300000, 200000, 50000 } };
    pk_um_t origin[PK_GC_AXES] = { 0, 0, 0 };
    pk_gcode_state_init(st, &lim, origin);
}

/* Parse + interpret one line. */
static int run(struct pk_gc_state *st, const char *s, struct pk_gc_cmd *cmd)
{
    struct pk_gc_block b;
    int rc = parse(s, &b);
    if (rc != PK_GC_OK)
        return rc;
    return pk_gcode_interp(st, &b, cmd);
}

static void test_millimetre_and_inch_targets_land_on_the_right_micrometre(void)
{
    struct pk_gc_state st;
    struct pk_gc_cmd c;
    init_state(&st);
    TH_ASSERT_EQ(run(&st, "G21 G1 X10.0004 Y0.0005 F1200", &c), PK_GC_OK);
    TH_EXPECT(c.what == PK_GC_DO_MOVE);
    TH_EXPECT_EQ(c.target_um[0], 10000);  /* 10000.4 µm rounds down */
    TH_EXPECT_EQ(c.target_um[1], 1);      /* 0.5 µm ties away from zero */
    TH_EXPECT_EQ(c.feed_umpm, 1200000);
    TH_ASSERT_EQ(run(&st, "G20 X1 Y0.0001 F10", &c), PK_GC_OK);
    TH_EXPECT_EQ(c.target_um[0], 25400);
    TH_EXPECT_EQ(c.target_um[1], 3);      /* 2.54 µm */
    TH_EXPECT_EQ(c.start_um[0], 10000);
    TH_EXPECT_EQ(c.feed_umpm, 254000);
    TH_EXPECT_EQ(st.units, PK_GC_INCH);
}

static void test_incremental_moves_and_g92_offsets_compose(void)
{
    struct pk_gc_state st;
    struct pk_gc_cmd c;
    init_state(&st);
    TH_ASSERT_EQ(run(&st, "G0 X5 Y5", &c), PK_GC_OK);
    TH_ASSERT_EQ(run(&st, "G92 X0 Y0", &c), PK_GC_OK);
    TH_EXPECT(c.what == PK_GC_DO_OFFSET);
    TH_ASSERT_EQ(run(&st, "G0 X1 Y2", &c), PK_GC_OK);
    TH_EXPECT_EQ(c.target_um[0], 6000);
    TH_EXPECT_EQ(c.target_um[1], 7000);
    TH_ASSERT_EQ(run(&st, "G91 G0 X-1.5 Z1", &c), PK_GC_OK);
    TH_EXPECT_EQ(c.target_um[0], 4500);
    TH_EXPECT_EQ(c.target_um[1], 7000);
    TH_EXPECT_EQ(c.target_um[2], 1000);
    TH_EXPECT_EQ(c.feed_umpm, 0);        /* rapid */
}

static void test_modal_settings_carry_into_later_lines(void)
{
    struct pk_gc_state st;
    struct pk_gc_cmd c;
    init_state(&st);
    TH_ASSERT_EQ(run(&st, "G1 F600", &c), PK_GC_OK);  /* mode + feed only: no move */
    TH_EXPECT_EQ(c.what, 0);
    TH_ASSERT_EQ(run(&st, "X3", &c), PK_GC_OK);
    TH_EXPECT(c.what == PK_GC_DO_MOVE && c.motion == PK_GC_MOT_LINEAR);
    TH_EXPECT_EQ(c.feed_umpm, 600000);
    TH_ASSERT_EQ(run(&st, "N7 M3 G4 P0.25", &c), PK_GC_OK);
    TH_EXPECT(c.what == (PK_GC_DO_PEN | PK_GC_DO_DWELL));
    TH_EXPECT_EQ(c.pen, PK_GC_PEN_DOWN);
    TH_EXPECT_EQ(c.dwell_ms, 250);
    TH_EXPECT_EQ(c.line_number, 7);
    TH_ASSERT_EQ(run(&st, "G64 P0.05", &c), PK_GC_OK);
    TH_EXPECT(c.what == PK_GC_DO_PATH && c.path == PK_GC_PATH_BLEND && c.tol_um == 50);
    TH_ASSERT_EQ(run(&st, "G61", &c), PK_GC_OK);
    TH_EXPECT(c.what == PK_GC_DO_PATH && c.path == PK_GC_PATH_EXACT);
    TH_ASSERT_EQ(run(&st, "G1 X4 M2", &c), PK_GC_OK);
    TH_EXPECT(c.what == (PK_GC_DO_MOVE | PK_GC_DO_STOP));
    TH_EXPECT_EQ(st.pen, PK_GC_PEN_UP);
}

static void test_g5_control_points_follow_linuxcnc(void)
{
    struct pk_gc_state st;
    struct pk_gc_cmd c;
    init_state(&st);
    TH_ASSERT_EQ(run(&st, "G0 X10 Y10", &c), PK_GC_OK);
    TH_ASSERT_EQ(run(&st, "F1000 G5 X20 Y10 I2 J3 P-4 Q5", &c), PK_GC_OK);
    TH_EXPECT(c.motion == PK_GC_MOT_CUBIC);
    TH_EXPECT(c.ctrl_um[0][0] == 12000 && c.ctrl_um[0][1] == 13000);  /* start + (I,J) */
    TH_EXPECT(c.ctrl_um[1][0] == 16000 && c.ctrl_um[1][1] == 15000);  /* end + (P,Q) */
    /* Next G5 without I,J continues tangentially: I,J = -(previous P,Q). */
    TH_ASSERT_EQ(run(&st, "G5 X30 Y10 P1 Q1", &c), PK_GC_OK);
    TH_EXPECT(c.ctrl_um[0][0] == 24000 && c.ctrl_um[0][1] == 5000);
    TH_EXPECT(c.ctrl_um[1][0] == 31000 && c.ctrl_um[1][1] == 11000);
    TH_ASSERT_EQ(run(&st, "G5.1 X40 Y10 I5", &c), PK_GC_OK);
    TH_EXPECT(c.motion == PK_GC_MOT_QUAD);
    TH_EXPECT(c.ctrl_um[0][0] == 35000 && c.ctrl_um[0][1] == 10000);
}

/* Bad blocks that only the modal state can reveal. */
static const struct {
    const char *setup;
    const char *line;
    int err;
} bad_blocks[] = {
    { "", "G1 X1", PK_GC_E_UNDEFINED_FEED },
    { "", "G1 X1 F0", PK_GC_E_UNDEFINED_FEED },
    { "", "G0 X301", PK_GC_E_TRAVEL },
    { "", "G0 X-0.001", PK_GC_E_TRAVEL },
    { "", "G20 G0 X12", PK_GC_E_TRAVEL },          /* 304.8 mm */
    { "G0 X299", "G91 G0 X1.001", PK_GC_E_TRAVEL },
    { "", "G0 Z-999999999", PK_GC_E_TRAVEL },
    { "", "G80 X1", PK_GC_E_UNUSED_WORDS },
    { "", "G2 X1 Y1 I1", PK_GC_E_UNSUPPORTED },
    { "", "G1 X1 F10 P1", PK_GC_E_UNUSED_VALUE },
    { "", "G0 X1 R5", PK_GC_E_UNUSED_VALUE },
    { "", "I5", PK_GC_E_UNUSED_VALUE },
    { "F100", "G5 X1 Y1 I1 J1 P1", PK_GC_E_VALUE_MISSING },
    { "F100", "G5 X1 Y1 I1 P1 Q1", PK_GC_E_VALUE_MISSING },
    { "F100", "G5 X1 Y1 P1 Q1", PK_GC_E_VALUE_MISSING },  /* first G5 needs I,J */
    { "F100", "G5.1 X1 Y1", PK_GC_E_VALUE_MISSING },
    { "F100", "G5 X1 Y1 Z1 I1 J1 P1 Q1", PK_GC_E_BAD_TARGET },
    { "F100 G5.1 X1 Y1 I1", "I1 J1", PK_GC_E_NO_AXIS_WORDS },
    { "F100 G0 X1 Y1", "G5 X2 Y2 I-5 J0 P0 Q0", PK_GC_E_TRAVEL },  /* control point at X-4 */
    { "", "G64 P-1", PK_GC_E_NEGATIVE },
    { "", "G92 X99999", PK_GC_E_BAD_TARGET },
};

static void test_state_dependent_errors_leave_the_state_untouched(void)
{
    for (unsigned i = 0; i < TH_COUNT(bad_blocks); i++) {
        struct pk_gc_state st, before;
        struct pk_gc_cmd c;
        init_state(&st);
        if (bad_blocks[i].setup[0])
            TH_ASSERT_EQ(run(&st, bad_blocks[i].setup, &c), PK_GC_OK);
        before = st;
        int rc = run(&st, bad_blocks[i].line, &c);
        if (rc != bad_blocks[i].err) {
            th_print("  line: ");
            th_print(bad_blocks[i].line);
            th_print("\n");
        }
        TH_EXPECT_EQ(rc, bad_blocks[i].err);
        TH_EXPECT(memcmp(&st, &before, sizeof st) == 0);
    }
}

int th_main(int argc, char **argv);
int th_main(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    static const struct th_case cases[] = {
        TH_CASE(test_a_plain_line_gives_its_words_and_commands),
        TH_CASE(test_case_whitespace_and_comments_do_not_change_the_block),
        TH_CASE(test_empty_and_comment_only_lines_parse_to_an_empty_block),
        TH_CASE(test_decimals_round_to_the_micro_unit_ties_away_from_zero),
        TH_CASE(test_every_printed_number_reads_back_exactly),
        TH_CASE(test_line_numbers_are_integers_within_grbl_range),
        TH_CASE(test_every_bad_line_gets_its_grbl_error),
        TH_CASE(test_an_over_long_line_is_error_11_and_the_longest_legal_one_parses),
        TH_CASE(test_every_single_byte_line_is_accepted_or_refused_as_grbl_would),
        TH_CASE(test_spaces_inserted_anywhere_in_a_valid_line_change_nothing),
        TH_CASE(test_random_bytes_never_crash_and_always_get_a_listed_answer),
        TH_CASE(test_millimetre_and_inch_targets_land_on_the_right_micrometre),
        TH_CASE(test_incremental_moves_and_g92_offsets_compose),
        TH_CASE(test_modal_settings_carry_into_later_lines),
        TH_CASE(test_g5_control_points_follow_linuxcnc),
        TH_CASE(test_state_dependent_errors_leave_the_state_untouched),
    };
    return th_run(cases, TH_COUNT(cases));
}
