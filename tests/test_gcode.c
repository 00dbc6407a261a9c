/*
 * test_gcode.c — the G-code parser and interpreter (firmware/pk_gcode.c).
 *
 * References are independent of the code under test: expected values are
 * written by hand from the G-code text, computed here by a separate exact
 * rule (128-bit rationals for the unit conversions), or are the answers the
 * real Grbl 1.1h gave to the same lines (run in grbl-sim, gnea/grbl at
 * bfb67f0 with grbl/grbl-sim; the error tables below were checked line by
 * line against it, except where marked "plotkin").
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "th.h"
#include "pk_gcode.h"

int th_main(int argc, char **argv);

static int parse(const char *s, struct pk_gc_block *b)
{
    return pk_gcode_parse((const uint8_t *)s, strlen(s), b);
}

static int parse_rc(const char *s)
{
    struct pk_gc_block b;
    return parse(s, &b);
}

/* value of word w as a decimal string, for comparisons */
static long double wval(const struct pk_gc_block *b, int w)
{
    long double v = b->m[w];
    for (int i = 0; i < b->dec[w]; i++)
        v /= 10;
    return v;
}

/* ---- an environment with stored coordinate data ---------------------------- */

static pk_um_t coords[PK_GC_COORD_COUNT][PK_GC_AXES];
static int coord_fail;
static int coord_read(void *ctx, unsigned idx, pk_um_t out[PK_GC_AXES])
{
    (void)ctx;
    if (coord_fail || idx >= PK_GC_COORD_COUNT)
        return -1;
    memcpy(out, coords[idx], sizeof coords[idx]);
    return 0;
}
static const struct pk_gc_env ENV = { coord_read, NULL, 20 };

static struct pk_gc_state ST;
static struct pk_gc_cmd CMD;

static void reset_state(void)
{
    memset(coords, 0, sizeof coords);
    coord_fail = 0;
    pk_um_t zero[PK_GC_AXES] = { 0 };
    pk_gcode_state_init(&ST, zero, zero);
}

/* Parse and interpret one line against ST. */
static int run(const char *s)
{
    struct pk_gc_block b;
    int rc = parse(s, &b);
    if (rc != PK_GC_OK)
        return rc;
    return pk_gcode_interp(&ST, &b, &ENV, &CMD);
}

/* ---- lexical rules ------------------------------------------------------------ */

static void test_case_whitespace_comments_and_block_delete_do_not_change_the_block(void)
{
    static const char *const same[] = {
        "g1x10.5y-3f1500",
        "  G 1 X 1 0 . 5 Y - 3 F 1500  ",
        "\tG01\tX10.50\tY-3.\tF1500.000",
        "G1 (first comment) X10.5 (second) Y-3 F1500 ; trailing comment",
        "G1 X1(inside a number)0.5 Y-3 F1500",
        "/G1 X10.5 Y-3 F1500",
        "G1 X10/.5 Y-3 F1500",                          /* Grbl drops '/' anywhere */
        "G1 X+10.5 Y-3 F1500 (unclosed comment to the end, as Grbl accepts",
        "G1 X10.5 Y-3 F1500 (caf\xc3\xa9: anything inside a comment)",
        "G1 X10.5 Y-3 F1500 (bell \x07 in a comment)",
        "G1\x01 X10.5\x1b Y-3 F1500",                    /* Grbl drops bytes <= ' ' */
    };
    struct pk_gc_block ref, b;
    TH_ASSERT_EQ(parse("G1 X10.5 Y-3 F1500", &ref), PK_GC_OK);
    TH_EXPECT_EQ(ref.motion, PK_GC_MOT_LINEAR);
    TH_EXPECT(wval(&ref, PK_GC_W_X) == 10.5L && wval(&ref, PK_GC_W_Y) == -3 &&
              wval(&ref, PK_GC_W_F) == 1500);
    for (unsigned i = 0; i < TH_COUNT(same); i++) {
        TH_EXPECT_EQ(parse(same[i], &b), PK_GC_OK);
        int eq = b.words == ref.words && b.groups == ref.groups && b.motion == ref.motion;
        for (int w = 0; w < PK_GC_W_COUNT && eq; w++)
            if (b.words & PK_GC_WBIT(w))
                eq = wval(&b, w) == wval(&ref, w);
        if (!eq) {
            th_print("  differs: ");
            th_print(same[i]);
            th_print("\n");
        }
        TH_EXPECT(eq);
    }
}

static void test_empty_and_comment_only_lines_parse_to_an_empty_block(void)
{
    static const char *const empty[] = { "", " ", "\t", "(hello)", "; only a comment", "%",
                                         " % ", "/", "()", "(a)(b) ;c", "\x01\x02" };
    for (unsigned i = 0; i < TH_COUNT(empty); i++) {
        struct pk_gc_block b;
        TH_EXPECT_EQ(parse(empty[i], &b), PK_GC_OK);
        TH_EXPECT(b.words == 0 && b.groups == 0);
    }
    struct pk_gc_block b;
    TH_EXPECT_EQ(pk_gcode_parse(NULL, 0, &b), PK_GC_OK);
}

/* ---- numbers -------------------------------------------------------------------- */

/* Exact reference: round(num / den) half away from zero. */
static int64_t ref_round(__int128 num, __int128 den)
{
    int neg = (num < 0) != (den < 0);
    if (num < 0)
        num = -num;
    if (den < 0)
        den = -den;
    __int128 q = num / den, r = num % den;
    if (2 * r >= den)
        q++;
    return (int64_t)(neg ? -q : q);
}

static uint64_t rng_state = 0x9e3779b97f4a7c15ull;
static uint64_t rng(void)
{
    rng_state = rng_state * 6364136223846793005ull + 1442695040888963407ull;
    return rng_state >> 11;
}

static void test_lengths_are_exact_roundings_of_the_decimal_text_in_mm_and_inch(void)
{
    /* random decimal texts with 0..12 fraction digits, mm and inch */
    for (int i = 0; i < 40000; i++) {
        int units = (int)(rng() & 1);
        unsigned fd = (unsigned)(rng() % 13);
        uint64_t ip = rng() % (units ? 82u : 2097u);
        char frac[16];
        for (unsigned k = 0; k < fd; k++)
            frac[k] = (char)('0' + rng() % 10);
        frac[fd] = 0;
        int neg = (int)(rng() & 1);
        char s[64];
        snprintf(s, sizeof s, "X%s%llu%s%s", neg ? "-" : "", (unsigned long long)ip, fd ? "." : "", frac);
        struct pk_gc_block b;
        TH_ASSERT_EQ(parse(s, &b), PK_GC_OK);
        int32_t um;
        TH_ASSERT_EQ(pk_gcode_len_um(b.m[PK_GC_W_X], b.dec[PK_GC_W_X], (uint8_t)units, &um), PK_GC_OK);
        /* the text is ip.frac exactly: value = (ip * 10^fd + frac) / 10^fd;
         * µm = value * (1000 or 25400); digits beyond what the parser keeps
         * (9 significant, 9 decimals) may be dropped: truncation, which the
         * reference copies (rounding half away after a truncation is exact). */
        __int128 num = ip, den = 1;
        unsigned kept = 0, sig = ip ? (unsigned)snprintf(NULL, 0, "%llu", (unsigned long long)ip) : 0;
        for (unsigned k = 0; k < fd; k++) {
            if (kept >= 9 || (sig >= 9))
                break;
            num = num * 10 + (frac[k] - '0');
            den *= 10;
            kept++;
            if (num != 0)
                sig = (unsigned)snprintf(NULL, 0, "%lld", (long long)num);
        }
        if (neg)
            num = -num;
        int64_t want = ref_round(num * (units ? 25400 : 1000), den);
        if (um != want) {
            th_print("  ");
            th_print(s);
            th_print(units ? " in\n" : " mm\n");
        }
        TH_ASSERT_EQ(um, want);
    }
}

static void test_number_syntax_follows_grbl(void)
{
    struct pk_gc_block b;
    TH_EXPECT_EQ(parse("X.5", &b), PK_GC_OK);
    TH_EXPECT(wval(&b, PK_GC_W_X) == 0.5L);
    TH_EXPECT_EQ(parse("X-.25", &b), PK_GC_OK);
    TH_EXPECT(wval(&b, PK_GC_W_X) == -0.25L);
    TH_EXPECT_EQ(parse("X5.", &b), PK_GC_OK);
    TH_EXPECT_EQ(parse("X0000000001.5", &b), PK_GC_OK); /* leading zeros are not digits that count */
    TH_EXPECT(wval(&b, PK_GC_W_X) == 1.5L);
    TH_EXPECT_EQ(parse("X999999999", &b), PK_GC_OK);
    TH_EXPECT_EQ(parse("X1234567890", &b), PK_GC_E_BAD_NUMBER); /* a tenth integer digit */
    /* mantissas across the parser's 16-bit/32-bit step (6553 * 10 + 9 is
     * the largest 16-bit one), blanks inside included */
    static const struct { const char *s; int32_t m; uint8_t dec; } mant[] = {
        { "X6552.9", 65529, 1 }, { "X6553.5", 65535, 1 }, { "X655.36", 65536, 2 },
        { "X-6553.59", -655359, 2 }, { "X65 53.6", 65536, 1 }, { "X0.0065536", 65536, 7 },
        { "X99999999.99", 999999999, 1 }, { "X6553.612345678", 655361234, 5 },
    };
    for (size_t i = 0; i < sizeof mant / sizeof mant[0]; i++) {
        TH_EXPECT_EQ(parse(mant[i].s, &b), PK_GC_OK);
        TH_EXPECT_EQ(b.m[PK_GC_W_X], mant[i].m);
        TH_EXPECT_EQ(b.dec[PK_GC_W_X], mant[i].dec);
    }
    int32_t v;
    /* inches: rounded half away from zero on both signs */
    TH_EXPECT_EQ(pk_gcode_len_um(-1, 4, PK_GC_INCH, &v), PK_GC_OK);
    TH_EXPECT_EQ(v, -3); /* -2.54 µm */
    TH_EXPECT_EQ(pk_gcode_len_um(1, 4, PK_GC_INCH, &v), PK_GC_OK);
    TH_EXPECT_EQ(v, 3);
    TH_EXPECT_EQ(pk_gcode_len_um(-84546, 0, PK_GC_INCH, &v), PK_GC_OK);
    TH_EXPECT_EQ(v, -2147468400);
    TH_EXPECT_EQ(pk_gcode_len_um(-84547, 0, PK_GC_INCH, &v), PK_GC_E_BAD_NUMBER);
    TH_EXPECT_EQ(pk_gcode_scaled(1999, 3, 0, &v), PK_GC_OK);
    TH_EXPECT_EQ(v, 2);
    TH_EXPECT_EQ(pk_gcode_scaled(-1500, 3, 0, &v), PK_GC_OK);
    TH_EXPECT_EQ(v, -2); /* ties away from zero */
    TH_EXPECT_EQ(pk_gcode_scaled(2147484, 0, 3, &v), PK_GC_E_BAD_NUMBER);
    TH_EXPECT_EQ(pk_gcode_scaled(2147483, 0, 3, &v), PK_GC_OK);
    uint8_t d;
    TH_EXPECT_EQ(pk_gcode_parse_number((const uint8_t *)"12.5", 4, &v, &d), PK_GC_OK);
    TH_EXPECT(v == 125 && d == 1);
    TH_EXPECT_EQ(pk_gcode_parse_number((const uint8_t *)"12.5x", 5, &v, &d), PK_GC_E_EXPECTED_LETTER);
}

/* ---- parse errors: Grbl 1.1h's answers (grbl-sim), line by line ------------------ */

static const struct { const char *s; int err; } parse_errors[] = {
    /* 1: expected command letter */
    { "12", 1 }, { "G1 X1 )", 1 }, { "G1 #1", 1 }, { "G1 X1 *5", 1 }, { "G1 X1 \x7f", 1 },
    { "G1 X1.2.3", 1 }, { "G1 X1-2", 1 }, { "% G1", 1 },
    { "G1 X1 \x80", 1 }, /* plotkin's parser; the engine takes bytes >= 0x80 off first */
    /* 2: bad number */
    { "G1 X", 2 }, { "G1 XY1", 2 }, { "G X1", 2 }, { "G1 X-", 2 }, { "G1 X.", 2 },
    { "G1 X+-1", 2 }, { "M", 2 }, { "F", 2 }, { "G1 X\x7f", 2 },
    /* 4: negative where a positive value is expected */
    { "G1 X1 F-100", 4 }, { "M3 S-1", 4 }, { "G4 P-1", 4 }, { "T-1", 4 }, { "N-1 G0 X1", 4 },
    { "P-1 A1", 4 }, /* Grbl stops at the P */
    /* 20: unsupported command or word */
    { "G1 A5", 20 }, { "G1 X1 E0.5", 20 }, { "H1", 20 }, { "G5.2 X1 Y1", 20 }, { "G-1", 20 },
    { "G100", 20 }, { "M6", 20 }, { "M48", 20 }, { "G28.2", 20 }, { "G38.1 X1", 20 },
    { "G43 Z1", 20 }, { "G61.1", 20 }, { "G90.1", 20 }, { "G41", 20 },
    /* 21: two commands of one modal group */
    { "G90 G91", 21 }, { "G20 G21", 21 }, { "M3 M5", 21 }, { "M2 M30", 21 },
    { "G4 P1 G92 X0", 21 }, { "G17 G17", 21 }, { "G61 G64", 21 }, { "M7 M8", 21 },
    /* 23: a fraction the code does not have (Grbl: trunc + 100 * fraction) */
    { "G1.5 X1", 23 }, { "G92.2", 20 }, { "M3.5", 23 }, { "G54.1", 23 }, { "G59.1", 23 },
    { "G256", 23 }, { "M-3", 23 }, /* Grbl's uint8 wrap: 256 -> G0 with a fraction */
    /* 24: two commands that use axis words (Grbl checks this before 21) */
    { "G0 G1 X1", 24 }, { "G0 G92 X0", 24 }, { "G92 G0 X1", 24 }, { "G10 G92 X0", 24 },
    { "G43.1 G0 Z1", 24 }, { "G1 G5.1 X1 I1", 24 },
    /* 25: a repeated word */
    { "G1 X1 X2", 25 }, { "N1 N2", 25 },
    /* 38: tool number above 255 */
    { "T256", 38 },
};

static void test_parse_errors_are_grbl_s(void)
{
    for (unsigned i = 0; i < TH_COUNT(parse_errors); i++) {
        int rc = parse_rc(parse_errors[i].s);
        if (rc != parse_errors[i].err) {
            char msg[120];
            snprintf(msg, sizeof msg, "  '%s': %d, want %d\n", parse_errors[i].s, rc, parse_errors[i].err);
            th_print(msg);
        }
        TH_EXPECT_EQ(rc, parse_errors[i].err);
    }
    /* what Grbl accepts at parse time */
    TH_EXPECT_EQ(parse_rc("T255"), 0);
    TH_EXPECT_EQ(parse_rc("T1.5"), 0);  /* Grbl truncates T */
    TH_EXPECT_EQ(parse_rc("G49.1"), 0); /* Grbl: G49.x is G49 */
    TH_EXPECT_EQ(parse_rc("G1.001 X1"), 0); /* mantissa round(0.1) = 0 */
    TH_EXPECT_EQ(parse_rc("G5 X1 Y1 I1 J1 P-1 Q-1"), 0); /* plotkin: G5's P may be negative */
}

/* ---- the interpreter: Grbl's checks in Grbl's order (grbl-sim answers) --------- */

/* Each line runs against the state the previous ones left. */
static const struct { const char *s; int err; } interp_seq[] = {
    { "G0", 0 }, { "G1", 22 }, { "G2", 22 }, { "G4", 28 }, { "G4 P0.5", 0 },
    { "G92", 26 }, { "G92 X0 Y0", 0 }, { "G92.1", 0 }, { "G92.1 X5", 0 },
    { "G10 L2 X0", 0 }, /* Grbl: one of L, P is enough (P0: the active system) */
    { "G10 P1 X0", 20 }, { "G10 L2 P1 X10", 0 }, { "G10 L20 P2 X5", 0 }, { "G10 L3 P1 X5", 20 },
    { "G10 L2 P7 X1", 29 }, { "G10 L2 P1 R1 X1", 20 }, { "G10 L2 P1", 26 },
    { "G28.1", 0 }, { "G30.1", 0 },
    { "G38.2 X1", 22 }, /* no feed yet */
    { "G43.1 Z1", 0 }, { "G43.1 X1", 37 }, { "G43.1 Z1 X1", 37 }, { "G49", 0 },
    { "G53 X1", 0 }, /* the failed G38.2 left G0 in force */
    { "G53 G1 X1 F100", 0 }, { "G53 G2 X1 I1", 30 },
    { "G59", 0 }, { "G54", 0 }, { "G61", 0 }, { "G64", 0 }, { "G80", 0 }, { "G80 X1", 31 },
    { "G80 G92 X0", 31 }, { "G91.1", 0 }, { "G93", 0 }, { "G93 G1 X1", 22 }, { "G94", 0 },
    { "G40", 0 }, { "M0", 0 }, { "M1", 0 }, { "M7", 0 }, { "M8", 0 }, { "M9", 0 },
    { "M56", 0 }, { "M56 P0", 0 }, { "N10000000 G0 X1", 0 }, { "N10000001 G0 X1", 27 },
    { "N1.5 G0 X1", 0 },
};

static void test_interpreter_errors_follow_grbl_in_sequence(void)
{
    reset_state();
    for (unsigned i = 0; i < TH_COUNT(interp_seq); i++) {
        int rc = run(interp_seq[i].s);
        if (rc != interp_seq[i].err) {
            char msg[120];
            snprintf(msg, sizeof msg, "  '%s': %d, want %d\n", interp_seq[i].s, rc, interp_seq[i].err);
            th_print(msg);
        }
        TH_EXPECT_EQ(rc, interp_seq[i].err);
    }
}

/* Arcs: Grbl's answers (grbl-sim), in sequence from (0,0) in G17 at F1000 */
static const struct { const char *s; int err; } arc_cases[] = {
    { "G2 X10 Y0 I5 J0", 0 }, { "G3 X0 Y0 I-5 J0", 0 }, { "G2 X10 Y0 R5", 0 },
    { "G2 X0 Y0 R5", 0 }, { "G2 X10 Y0 R4.9", 34 }, { "G2 X10 Y0 R-5", 0 },
    { "G2 X10 Y0 R5 I1", 33 }, { "G2 X10 Y0", 35 }, { "G2 I5", 26 }, { "G2 Z5 I5", 32 },
    { "G2 X0 Y0 I5", 33 }, { "G2 X10.006 Y0 I5 J0", 33 }, { "G2 X0 Y0 I5", 33 },
    { "G2 X10.011 Y0 I5 J0", 33 }, { "G2 X0 Y0 R10", 0 }, { "G2 X10 Y10 R10", 0 },
    { "G2 X0 Y0 K5 I5", 33 }, { "G18", 0 }, { "G2 X10 Z0 I5 K0", 0 }, { "G2 X0 Y0 I5", 33 },
    { "G2 X0 Z0 K-5", 33 }, { "G19", 0 }, { "G2 Y10 Z0 J5 K0", 0 }, { "G17", 0 },
    { "G2 X10 Y0 Z5 I5 J0", 33 }, { "G2 X0 Y0 Z0 I-5 J0 P1", 33 },
    { "G2 X0 Y0 I-5 J0 L1", 33 }, { "G2 X10 Y0 I5 F0", 22 }, { "G91 G2 X10 Y0 I5 J0", 0 },
    { "G90", 0 }, { "G93 G2 X0 Y0 I-5", 22 }, { "G93 G2 X0 Y0 I-5 F10", 33 }, { "G94", 0 },
    { "G2 X0.001 Y0 I0.0005 J0", 33 }, { "G3 X0 Y0 I1000 J0", 33 },
};

static void test_arc_checks_are_grbl_s(void)
{
    reset_state();
    TH_ASSERT_EQ(run("G21 G90 G17 F1000"), 0);
    for (unsigned i = 0; i < TH_COUNT(arc_cases); i++) {
        int rc = run(arc_cases[i].s);
        if (rc != arc_cases[i].err) {
            char msg[120];
            snprintf(msg, sizeof msg, "  '%s': %d, want %d\n", arc_cases[i].s, rc, arc_cases[i].err);
            th_print(msg);
        }
        TH_EXPECT_EQ(rc, arc_cases[i].err);
    }
    /* the first arc: a half circle about (5,0) */
    reset_state();
    TH_ASSERT_EQ(run("G21 G90 G17 F1000"), 0);
    TH_ASSERT_EQ(run("G2 X10 Y0 I5 J0"), 0);
    TH_EXPECT(CMD.what & PK_GC_DO_MOVE);
    TH_EXPECT_EQ(CMD.motion, PK_GC_MOT_CW_ARC);
    TH_EXPECT_EQ(CMD.u.arc.g.centre_q8[0], 5000 * 256);
    TH_EXPECT_EQ(CMD.u.arc.g.centre_q8[1], 0);
    TH_EXPECT_EQ(CMD.u.arc.sweep, PK_ARC_TURN / 2);
    /* G18: the plane is Z,X (Grbl's axis_0 = Z); G19: Y,Z */
    TH_EXPECT_EQ(run("G18 G2 X20 Z0 I5 K0"), 0);
    TH_EXPECT(CMD.u.arc.g.a0 == 2 && CMD.u.arc.g.a1 == 0 && CMD.u.arc.g.al == 1);
    TH_EXPECT_EQ(run("G19 G2 Y10 Z0 J5 K0"), 0);
    TH_EXPECT(CMD.u.arc.g.a0 == 1 && CMD.u.arc.g.a1 == 2 && CMD.u.arc.g.al == 0);
    /* chord tolerance: min($12, 2 µm) in G61; G64 P: P/4; G64: $12/4 */
    reset_state();
    TH_ASSERT_EQ(run("G21 G90 F1000 G61"), 0);
    TH_ASSERT_EQ(run("G2 X10 Y0 I5"), 0);
    TH_EXPECT_EQ(CMD.chord_tol_um, 2);
    TH_ASSERT_EQ(run("G64 P0.04 G3 X0 Y0 I-5"), 0);
    TH_EXPECT_EQ(CMD.chord_tol_um, 10);
    TH_ASSERT_EQ(run("G64 G2 X10 Y0 I5"), 0);
    TH_EXPECT_EQ(CMD.chord_tol_um, 5); /* $12 = 0.020 mm -> 5 µm */
    /* an arc leaving the machine's numeric range */
    TH_EXPECT_EQ(run("G2 X10 Y0 I1100"), 15);
}

static void test_targets_follow_distance_units_offsets_and_g53(void)
{
    reset_state();
    TH_ASSERT_EQ(run("G21 G90 G0 X10 Y20"), 0);
    TH_EXPECT(CMD.target_um[0] == 10000 && CMD.target_um[1] == 20000);
    TH_ASSERT_EQ(run("G91 G0 X1 Y-2"), 0);
    TH_EXPECT(CMD.target_um[0] == 11000 && CMD.target_um[1] == 18000);
    TH_ASSERT_EQ(run("G20 G90 G0 X1"), 0); /* 1 inch */
    TH_EXPECT_EQ(CMD.target_um[0], 25400);
    TH_ASSERT_EQ(run("G21 G92 X0 Y0"), 0); /* here is work zero */
    TH_EXPECT(CMD.what & PK_GC_DO_WCO);
    TH_EXPECT(pk_gcode_wco(&ST, 0) == 25400 && pk_gcode_wco(&ST, 1) == 18000);
    TH_ASSERT_EQ(run("G0 X-5"), 0);
    TH_EXPECT_EQ(CMD.target_um[0], 20400);
    TH_ASSERT_EQ(run("G53 G0 X-5"), 0); /* machine coordinates */
    TH_EXPECT_EQ(CMD.target_um[0], -5000);
    /* G10 L2 P2: G55's offset; selecting G55 reads it (and G92 stays) */
    TH_ASSERT_EQ(run("G10 L2 P2 X100 Y50"), 0);
    TH_EXPECT(CMD.what & PK_GC_DO_COORD);
    TH_EXPECT(CMD.coord_idx == 1 && CMD.coord_um[0] == 100000 && CMD.coord_um[1] == 50000);
    memcpy(coords[1], CMD.coord_um, sizeof CMD.coord_um); /* the engine stores it */
    TH_ASSERT_EQ(run("G55 G0 X0 Y0"), 0);
    TH_EXPECT_EQ(CMD.target_um[0], 100000 + 25400);
    TH_EXPECT_EQ(CMD.target_um[1], 50000 + 18000);
    /* G10 L20 P0: the active system so that here is the given work position */
    TH_ASSERT_EQ(run("G10 L20 P0 X1"), 0);
    TH_EXPECT_EQ(CMD.coord_idx, 1);
    TH_EXPECT_EQ(CMD.coord_um[0], (100000 + 25400) - 25400 - 1000);
    TH_EXPECT_EQ(ST.wcs_um[0], 99000); /* active: applied at once */
    /* G43.1 Z: a tool length offset on Z */
    TH_ASSERT_EQ(run("G43.1 Z2"), 0);
    TH_EXPECT_EQ(ST.tlo_um, 2000);
    TH_ASSERT_EQ(run("G0 Z0"), 0);
    TH_EXPECT_EQ(CMD.target_um[2], 2000);
    TH_ASSERT_EQ(run("G49"), 0);
    TH_EXPECT_EQ(ST.tlo_um, 0);
    /* unreadable store: error 7 */
    coord_fail = 1;
    TH_EXPECT_EQ(run("G56"), PK_GC_E_READ_FAIL);
    coord_fail = 0;
    /* beyond the machine's numeric range: 15 */
    TH_EXPECT_EQ(run("G53 G0 X2098"), PK_GC_E_TRAVEL);
    TH_EXPECT_EQ(run("G53 G0 X2097"), 0);
}

static void test_g28_g30_go_through_the_given_point_to_the_stored_one(void)
{
    reset_state();
    coords[PK_GC_COORD_G28][0] = 5000;
    coords[PK_GC_COORD_G28][1] = 6000;
    coords[PK_GC_COORD_G28][2] = 7000;
    TH_ASSERT_EQ(run("G0 X1 Y1 Z1"), 0);
    TH_ASSERT_EQ(run("G28"), 0); /* straight to the stored position, all axes */
    TH_EXPECT(!(CMD.what & PK_GC_DO_VIA) && (CMD.what & PK_GC_DO_MOVE));
    TH_EXPECT(CMD.target_um[0] == 5000 && CMD.target_um[1] == 6000 && CMD.target_um[2] == 7000);
    TH_ASSERT_EQ(run("G0 X1 Y1 Z1"), 0);
    TH_ASSERT_EQ(run("G28 Z3"), 0); /* via Z3, then only Z to the stored value */
    TH_EXPECT(CMD.what & PK_GC_DO_VIA);
    TH_EXPECT(CMD.via_um[0] == 1000 && CMD.via_um[2] == 3000);
    TH_EXPECT(CMD.target_um[0] == 1000 && CMD.target_um[1] == 1000 && CMD.target_um[2] == 7000);
    TH_ASSERT_EQ(run("G30.1"), 0);
    TH_EXPECT(CMD.coord_idx == PK_GC_COORD_G30 && CMD.coord_um[2] == 7000);
}

static void test_feed_dwell_and_spindle_rules(void)
{
    reset_state();
    TH_EXPECT_EQ(run("G1 X1 F0.5"), PK_GC_E_UNDEFINED_FEED);  /* below 1 mm/min: refused */
    TH_EXPECT_EQ(run("G1 X1 F1"), 0);
    TH_EXPECT_EQ(CMD.feed_umpm, 1000);
    TH_EXPECT_EQ(run("G20 G1 X1 F0.03"), PK_GC_E_UNDEFINED_FEED); /* 0.76 mm/min */
    TH_EXPECT_EQ(run("G20 G1 X2 F10"), 0);
    TH_EXPECT_EQ(CMD.feed_umpm, 254000);
    TH_EXPECT_EQ(run("G21"), 0);
    /* G93: F is moves per minute, required on every feed move, then forgotten */
    TH_EXPECT_EQ(run("G93 G1 X60.8"), PK_GC_E_UNDEFINED_FEED);
    TH_EXPECT_EQ(run("G93 G1 X60.8 F2"), 0); /* 10 mm (from 50.8) at 2/min: 20 mm/min */
    TH_EXPECT_EQ(CMD.feed_umpm, 20000);
    TH_EXPECT_EQ(run("G1 X61"), PK_GC_E_UNDEFINED_FEED);
    TH_EXPECT_EQ(run("G94 G1 X62"), PK_GC_E_UNDEFINED_FEED); /* G93 -> G94: F undefined */
    /* dwells: seconds, up to 24 h */
    TH_EXPECT_EQ(run("G4 P1.5"), 0);
    TH_EXPECT_EQ(CMD.dwell_ms, 1500);
    TH_EXPECT_EQ(run("G4 P86400"), 0);
    TH_EXPECT_EQ(run("G4 P86400.001"), PK_GC_E_BAD_NUMBER);
    /* S with M3, M4; changes of S while on; M5 */
    TH_EXPECT_EQ(run("M3 S1000"), 0);
    TH_EXPECT(CMD.what & PK_GC_DO_SPINDLE);
    TH_EXPECT(CMD.spindle == PK_GC_SPINDLE_CW && CMD.spindle_state_changed && CMD.spindle_s == 1000000);
    TH_EXPECT_EQ(run("S500"), 0);
    TH_EXPECT((CMD.what & PK_GC_DO_SPINDLE) && !CMD.spindle_state_changed && CMD.spindle_s == 500000);
    TH_EXPECT_EQ(run("M4"), 0);
    TH_EXPECT(CMD.spindle_state_changed && ST.spindle == PK_GC_SPINDLE_CCW);
    TH_EXPECT_EQ(run("M5 S10"), 0);
    TH_EXPECT_EQ(ST.spindle, PK_GC_SPINDLE_OFF);
    TH_EXPECT_EQ(run("S20"), 0);
    TH_EXPECT(!(CMD.what & PK_GC_DO_SPINDLE)); /* off: only the state */
    /* coolant: M7 and M8 add up, M9 clears */
    TH_EXPECT_EQ(run("M7"), 0);
    TH_EXPECT_EQ(run("M8"), 0);
    TH_EXPECT_EQ(ST.coolant, PK_GC_COOLANT_MIST | PK_GC_COOLANT_FLOOD);
    TH_EXPECT_EQ(run("M9"), 0);
    TH_EXPECT_EQ(ST.coolant, 0);
    /* T: Grbl copies it on every block */
    TH_EXPECT_EQ(run("T7"), 0);
    TH_EXPECT_EQ(ST.tool, 7);
    TH_EXPECT_EQ(run("G0 X1"), 0);
    TH_EXPECT_EQ(ST.tool, 0);
}

static void test_program_end_resets_the_groups_grbl_resets(void)
{
    reset_state();
    TH_ASSERT_EQ(run("G91 G18 G93 M3 M8 G20 G61 F10"), 0);
    TH_ASSERT_EQ(run("G92 X1"), 0);
    TH_ASSERT_EQ(run("M2"), 0);
    TH_EXPECT(CMD.what & PK_GC_DO_STOP);
    TH_EXPECT_EQ(ST.motion, PK_GC_MOT_LINEAR);
    TH_EXPECT_EQ(ST.distance, PK_GC_ABSOLUTE);
    TH_EXPECT_EQ(ST.plane, PK_GC_PLANE_XY);
    TH_EXPECT_EQ(ST.feedmode, PK_GC_UNITS_PER_MIN);
    TH_EXPECT_EQ(ST.spindle, PK_GC_SPINDLE_OFF);
    TH_EXPECT_EQ(ST.coolant, 0);
    TH_EXPECT_EQ(ST.units, PK_GC_INCH);       /* kept, as Grbl */
    TH_EXPECT_EQ(ST.path, PK_GC_PATH_EXACT);  /* kept */
    TH_EXPECT(ST.g92_um[0] != 0);              /* kept */
    TH_ASSERT_EQ(run("M0"), 0);
    TH_EXPECT(CMD.stop == PK_GC_STOP_PAUSE);
    TH_ASSERT_EQ(run("M1"), 0);
    TH_EXPECT(!(CMD.what & PK_GC_DO_STOP)); /* optional stop: ignored, as Grbl */
}

static void test_g5_rules(void)
{
    reset_state();
    TH_ASSERT_EQ(run("G21 G90 F1000 G0 X10 Y10"), 0);
    TH_EXPECT_EQ(run("G5 X60 Y10 I0 J40 P0 Q40"), 0);
    TH_EXPECT_EQ(CMD.motion, PK_GC_MOT_CUBIC);
    TH_EXPECT(CMD.u.bez.p[1][0] == 10000 && CMD.u.bez.p[1][1] == 50000);
    TH_EXPECT(CMD.u.bez.p[2][0] == 60000 && CMD.u.bez.p[2][1] == 50000);
    TH_EXPECT_EQ(run("G5 X80 Y10 P0 Q-20"), 0); /* I,J from the previous P,Q: tangent */
    TH_EXPECT(CMD.u.bez.p[1][0] == 60000 && CMD.u.bez.p[1][1] == -30000);
    TH_EXPECT_EQ(run("G5 X1 Y1 I1"), PK_GC_E_VALUE_MISSING);
    TH_EXPECT_EQ(run("G5 X1 Y1 I1 J1 P1"), PK_GC_E_VALUE_MISSING);
    TH_EXPECT_EQ(run("G5.1 X1 Y1"), PK_GC_E_VALUE_MISSING);
    TH_EXPECT_EQ(run("G5.1 X1 Y1 I1 Z1"), PK_GC_E_BAD_TARGET);
    TH_EXPECT_EQ(run("G18 G5.1 X1 Y1 I1"), PK_GC_E_BAD_TARGET);
    TH_EXPECT_EQ(run("G17 G93 G5.1 X1 Y1 I1 F1"), PK_GC_E_UNSUPPORTED);
    TH_EXPECT_EQ(run("G94 G1 X1 Q1"), PK_GC_E_UNSUPPORTED); /* Q is not a Grbl word */
}

static void test_a_rejected_line_changes_nothing(void)
{
    reset_state();
    TH_ASSERT_EQ(run("G21 G90 G1 X5 F100"), 0);
    struct pk_gc_state before = ST;
    static const char *const bad[] = { "G91 G20 G1 X1 A2", "G91 G2 X1", "G55 G1 X5 Q1",
                                       "G92 G0 X1", "G4 P1 G20 X1 F1 M3 R2" };
    for (unsigned i = 0; i < TH_COUNT(bad); i++) {
        TH_EXPECT(run(bad[i]) != 0);
        TH_EXPECT(memcmp(&before, &ST, sizeof ST) == 0);
    }
}

static void test_jog_rules_are_grbl_s(void)
{
    reset_state();
    static const struct { const char *s; int err; int moves; } jogs[] = {
        { "X1 F100", 0, 1 }, { "X1", 22, 0 }, { "G1 X1 F100", 16, 0 }, { "G4 P1 F100", 16, 0 },
        { "X1 F100 S10", 36, 0 }, { "G53 X1 F100", 0, 1 }, { "F100", 0, 0 },
        { "X1 F100 N5", 0, 1 }, { "G20 X0.1 F10", 0, 1 }, { "X1 F100 M3", 16, 0 },
    };
    for (unsigned i = 0; i < TH_COUNT(jogs); i++) {
        struct pk_gc_block b;
        int rc = parse(jogs[i].s, &b);
        if (rc == 0)
            rc = pk_gcode_jog(&ST, &b, &CMD);
        TH_EXPECT_EQ(rc, jogs[i].err);
        if (rc == 0)
            TH_EXPECT_EQ((CMD.what & PK_GC_DO_MOVE) != 0, jogs[i].moves);
    }
    /* a jog leaves the program's modes alone */
    struct pk_gc_block b;
    TH_ASSERT_EQ(parse("G91 G20 X1 F10", &b), 0);
    TH_ASSERT_EQ(pk_gcode_jog(&ST, &b, &CMD), 0);
    TH_EXPECT(ST.distance == PK_GC_ABSOLUTE && ST.units == PK_GC_MM);
    TH_EXPECT_EQ(CMD.target_um[0], 25400);
    TH_EXPECT_EQ(CMD.feed_umpm, 254000);
}

int th_main(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    static const struct th_case cases[] = {
        TH_CASE(test_case_whitespace_comments_and_block_delete_do_not_change_the_block),
        TH_CASE(test_empty_and_comment_only_lines_parse_to_an_empty_block),
        TH_CASE(test_lengths_are_exact_roundings_of_the_decimal_text_in_mm_and_inch),
        TH_CASE(test_number_syntax_follows_grbl),
        TH_CASE(test_parse_errors_are_grbl_s),
        TH_CASE(test_interpreter_errors_follow_grbl_in_sequence),
        TH_CASE(test_arc_checks_are_grbl_s),
        TH_CASE(test_targets_follow_distance_units_offsets_and_g53),
        TH_CASE(test_g28_g30_go_through_the_given_point_to_the_stored_one),
        TH_CASE(test_feed_dwell_and_spindle_rules),
        TH_CASE(test_program_end_resets_the_groups_grbl_resets),
        TH_CASE(test_g5_rules),
        TH_CASE(test_a_rejected_line_changes_nothing),
        TH_CASE(test_jog_rules_are_grbl_s),
    };
    return th_run(cases, TH_COUNT(cases));
}
