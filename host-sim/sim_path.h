/*
 * sim_path.h — a reference path as exact primitives, and the distance from the
 * points of an executed path to it, streaming and in bounded memory (host only).
 *
 * A reference path is what the machine was asked to do: the programmed path
 * (straight moves, circular and helical arcs, G5.1 quadratic and G5 cubic
 * Béziers, each with its pen state and G-code line number), or a second one such
 * as the firmware's smoothed curve, fed the same way. Primitives arrive as the
 * program is interpreted; the points of the executed path (the position after
 * each decoded step instant) arrive later, since the machine lags behind the
 * interpreter.
 *
 * Definition. The deviation of a point P is its distance to the reference path
 * held in the window: min over the primitives of the window of the Euclidean
 * distance (in the first `dims` axes, µm) from P to the primitive as a point
 * set. The window holds every primitive added so far, except that old ones
 * the executed path has provably left (see "Bounded memory") are dropped once
 * the window holds `cap` entries or PK_PATH_LEN_MAX of path. So on a program
 * of up to 65,536 entries and 50 m (straight runs count as one entry: "Runs")
 * the figure is exactly the distance to the whole path programmed so far;
 * beyond, to its recent part, which can only make the figure larger, never
 * smaller (the check is conservative).
 *
 * Accuracy. Lines and planar circular arcs are evaluated in closed form
 * (exact up to double rounding, < 1e-6 µm for coordinates below 10 m).
 * Béziers, helices and arcs whose end radius differs from the start radius
 * (a spiral, as LinuxCNC runs them) are minimised by subdivision with bounds:
 * a piece over a parameter interval of length h whose second derivative is
 * bounded by M lies within M h²/8 of its chord, which gives a lower bound for
 * every piece and an upper bound from real points of the curve; pieces whose
 * lower bound cannot beat the best point found are dropped, the others split
 * until the bound gap is below PK_PATH_EPS_UM. The result is the distance to a
 * real point of the curve and exceeds the true minimum by at most
 * PK_PATH_EPS_UM.
 *
 * Speed. Each point is matched against a short candidate list (the primitives
 * within R = d0 + 2m of an anchor point, d0 the anchor's deviation, kept up
 * to date as primitives arrive); while the point stays within m of the anchor
 * no other primitive can be nearer (distance is 1-Lipschitz), so the answer is
 * exact. m adapts to the density of the path. The list is collected through a
 * uniform grid over X and Y (every cell a primitive passes through lists it;
 * the cell size doubles when the grid's fixed node pool would overflow) for
 * small radii, and through a two-level bounding-box hierarchy over the window
 * otherwise; both only ever skip a primitive that cannot be within the radius.
 *
 * Runs. A straight line that continues the previous one exactly (same
 * direction, from its end, same pen state) extends it: a line of a million
 * collinear points is one entry, exact. While the window is short of room
 * (less than a quarter free), a line that continues the previous one within
 * PK_PATH_MERGE_UM (every vertex of the run within that distance of the one
 * segment replacing it, and the segment within it of the run) extends it too;
 * the figures are then within PK_PATH_MERGE_UM of the exact ones, and
 * `approx_um` says so. (The firmware may plan a whole straight run as one
 * block, so a machine can be a whole run of points behind the program.)
 *
 * Bounded memory. The window is a ring of `cap` entries (a power of two,
 * PK_PATH_ENTRY_BYTES each) plus a grid of fixed size, all allocated at init;
 * nothing grows afterwards. A zero-length line that starts where the previous
 * primitive ends adds nothing to the point set and is not stored (repeated
 * points cost nothing). An entry is *released* once it is older, by
 * PK_PATH_BACK entries, than every entry matched by the points of the last two
 * batches (a batch: PK_PATH_LAG_POINTS points, or 16 points or more over which
 * the executed path moved 1 mm), or, once the owner calls
 * pk_path_all_executed (the machine is idle: everything added has run), older
 * than the newest by PK_PATH_BACK. Only released entries are dropped: the
 * oldest when the ring is full, and as many as needed while the window holds
 * more than PK_PATH_LEN_MAX of path (long strokes need no deep window).
 * A primitive that is the same point set as one in the window (a line drawn
 * again, either way, or the same curve again: multi-pass and back-and-forth
 * drawing) replaces it: the older entry is skipped from then on, so a stroke
 * drawn a hundred times costs the matcher one stroke, and the line number
 * reported for it is the latest one.
 * pk_path_room says how many primitives can be added without dropping one that
 * is not released; a producer that cannot wait (a serial sender) may add more:
 * the oldest is then dropped anyway and counted in `forced_drops`, and the
 * figures are upper bounds from then on (the summary says so).
 *
 * Points with no primitive in the window at all (nothing added yet) are
 * counted in `unmatched` and take no part in the figures.
 *
 * Figures (struct pk_path_stats): number of points, the maximum deviation and
 * where (the point, the time, the line of the nearest primitive, its pen
 * state), and the 95th percentile (nearest rank: the smallest v such that at
 * least 95% of the points have deviation <= v) from a histogram with
 * geometric bins: the value reported is the upper edge of the bin holding it,
 * at most PK_PATH_HIST_REL (relative) or PK_PATH_HIST_MIN_UM above the exact
 * nearest-rank value, never below it.
 *
 * Calling context: MAIN (host tools and tests); one struct per reference path;
 * no globals, so several paths and runs can coexist.
 */
#ifndef PLOTKIN_SIM_PATH_H
#define PLOTKIN_SIM_PATH_H

#include <stddef.h>
#include <stdint.h>

/** Accuracy of the subdivision minimisation (curves other than planar arcs), µm. */
#define PK_PATH_EPS_UM 1e-3
/** Histogram: relative width of a bin, and the smallest bin edge (µm). */
#define PK_PATH_HIST_REL 1e-3
#define PK_PATH_HIST_MIN_UM 1e-3
/** Points whose matches hold the oldest primitive (release rule). */
#define PK_PATH_LAG_POINTS 256u
/** Distance within which a run of lines may be held as one (µm; see "Runs"). */
#define PK_PATH_MERGE_UM 1.0
/** Primitives kept behind the oldest match (release rule). */
#define PK_PATH_BACK 64u
/** Default window: primitives (power of two). */
#define PK_PATH_CAP_DEFAULT (1u << 16)
/** Released entries are dropped at once while the window's primitives are
 *  longer than this in all (µm, 50 m): long strokes need no deep window. */
#define PK_PATH_LEN_MAX 5e7

/** Kind of a primitive. */
enum pk_path_kind {
    PK_PATH_LINE = 0,   /**< straight from p0 to p1 */
    PK_PATH_ARC = 1,    /**< circular / helical / spiral arc (see struct pk_path_prim) */
    PK_PATH_QUAD = 2,   /**< quadratic Bézier p0, c[0], p1 (G5.1) */
    PK_PATH_CUBIC = 3   /**< cubic Bézier p0, c[0], c[1], p1 (G5) */
};

/** Plane of an arc: the in-plane axes (u, v) and the linear (helix) axis w. */
enum pk_path_plane {
    PK_PLANE_XY = 0,    /**< G17: u = X, v = Y, w = Z */
    PK_PLANE_ZX = 1,    /**< G18: u = Z, v = X, w = Y */
    PK_PLANE_YZ = 2     /**< G19: u = Y, v = Z, w = X */
};

/**
 * One primitive, coordinates in µm (axes X, Y, Z).
 *
 * ARC: centre (u, v) = centre[] in the plane's axes; the point at angle θ is
 * centre + ρ(θ)(cos θ, sin θ) in (u, v), with ρ going linearly from r0 at θ = a0
 * to r1 at θ = a0 + sweep, and w going linearly from p0's to p1's w. sweep > 0
 * is counter-clockwise seen from +w (G3), < 0 clockwise (G2); |sweep| may
 * exceed 2π (full turns). pk_path_arc builds one from G-code's start, end,
 * centre, direction and turns; p0/p1 are then the arc's true ends.
 */
struct pk_path_prim {
    uint8_t kind;          /**< enum pk_path_kind */
    uint8_t drawn;         /**< 1: pen down / laser firing along it (sim_pen.h); 0: travel */
    uint8_t rapid;         /**< 1: G0 */
    uint8_t plane;         /**< ARC: enum pk_path_plane */
    uint32_t line;         /**< source line number (1 = first line), 0 if none */
    double p0[3], p1[3];   /**< start and end, µm */
    double c[2][3];        /**< QUAD: c[0]; CUBIC: c[0], c[1]; control points, µm */
    double centre[2];      /**< ARC: centre in (u, v), µm */
    double r0, r1;         /**< ARC: radius at the start and at the end, µm */
    double a0, sweep;      /**< ARC: start angle and signed sweep, radians */
};

/**
 * An arc from G-code's terms: start and end (µm, X Y Z), centre (µm, in the
 * plane's (u, v) axes), plane, cw (1 for G2, 0 for G3) and extra full turns
 * (LinuxCNC's P - 1; 0 for Grbl). The sweep is the angle from start to end in
 * the direction asked, in (0, 2π] plus 2π per extra turn (start == end angle:
 * a full circle). Other members (drawn, rapid, line) are zeroed.
 * @return 0, or -1 if the start or the end lies on the centre (no angle)
 */
int pk_path_arc(struct pk_path_prim *out, const double start[3], const double end[3],
                const double centre[2], enum pk_path_plane plane, int cw, unsigned turns);

/** A straight line (other members zeroed). */
void pk_path_line(struct pk_path_prim *out, const double a[3], const double b[3]);

/**
 * Distance (µm) from pt to the primitive as a point set, in the first dims
 * axes (2 or 3; the others are ignored), with the accuracy stated above
 * (exact for lines and planar circular arcs, else within PK_PATH_EPS_UM above
 * the true minimum). If t_out is not NULL it receives the parameter of the
 * nearest point (line, Béziers: t in [0, 1]; arc: the fraction of the sweep).
 * Reentrant.
 */
double pk_path_prim_dist(const struct pk_path_prim *p, const double pt[3], unsigned dims,
                         double *t_out);

/**
 * Number of equal parameter pieces whose chords lie within tol_um (> 0) of the
 * primitive (1 for a line; from the bound on its second derivative otherwise;
 * at most 1,000,000).
 */
unsigned pk_path_prim_flatten_n(const struct pk_path_prim *p, double tol_um);

/** Point of the primitive at parameter t (as t_out above), µm. */
void pk_path_prim_eval(const struct pk_path_prim *p, double t, double out[3]);

/** Figures of one reference path (read them at any time). */
struct pk_path_stats {
    uint64_t points;        /**< points measured (matched ones) */
    uint64_t unmatched;     /**< points measured while the window was empty */
    double max_um;          /**< largest deviation, µm (0 with no points) */
    double max_at_um[3];    /**< the point where it occurred */
    uint64_t max_tick;      /**< the time stamp given with that point */
    uint32_t max_line;      /**< line number of the nearest primitive there (0: none) */
    uint32_t max_line_last; /**< its last line, if it holds a run of lines (else max_line) */
    uint8_t max_drawn;      /**< pen state of that primitive */
    uint64_t prims;         /**< primitives added (stored or not) */
    uint64_t stored;        /**< primitives stored (zero-length repeats are not) */
    uint64_t repeats;       /**< stored ones that replaced the same point set in the window */
    uint64_t merged;        /**< lines that extended the previous one exactly */
    uint64_t merged_approx; /**< lines that extended it within PK_PATH_MERGE_UM */
    double approx_um;       /**< 0: figures exact as stated; else they are within this */
    uint64_t dropped;       /**< primitives dropped from the full window, released */
    uint64_t forced_drops;  /**< dropped before they were released: figures are upper bounds */
    uint64_t rebuilds;      /**< candidate-list rebuilds (cost diagnostics) */
};

/** Private: one stored primitive and its bounding box. */
struct pk_path_ent {
    struct pk_path_prim p;
    float lo[3], hi[3];     /**< bounding box, rounded outwards */
    uint8_t dead;           /**< a later entry is the same point set (a repeated stroke) */
    uint8_t in_grid;        /**< registered in the grid (else in the long list) */
    uint32_t stamp;         /**< last grid query that visited it */
    uint32_t line_last;     /**< last line of a run held as this entry */
    double cone_ref, cone_lo, cone_hi; /**< a line's run: directions its end may take */
};

/** Private: the grid over X and Y that finds the entries near a point. */
struct pk_path_gslot { int64_t key; uint32_t head; uint32_t used; };
struct pk_path_gnode { uint32_t seq; uint32_t next; };  /* seq: its low 32 bits */

/** Private: a bounding box of a block (32 entries) or a group (1024). */
struct pk_path_box { double lo[3], hi[3]; uint64_t seq0; };

/** Private: a candidate for the current anchor. */
struct pk_path_cand { uint64_t seq; double d_anchor; };

#define PK_PATH_CAND_MAX 64u
#ifndef PK_PATH_GRID_SLOTS
#define PK_PATH_GRID_SLOTS (1u << 17)
#endif
#ifndef PK_PATH_GRID_NODES
#define PK_PATH_GRID_NODES (1u << 20)
#endif
#ifndef PK_PATH_LONG_MAX
#define PK_PATH_LONG_MAX 1024u
#endif
#define PK_PATH_HIST_BINS 24000u

/** A reference path and its figures. Set up with pk_path_init. */
struct pk_path {
    unsigned dims;
    uint32_t cap;                     /* ring size (power of two) */
    struct pk_path_ent *ring;         /* cap entries */
    struct pk_path_box *blk, *grp;    /* cap/32 + 1 and cap/1024 + 1 boxes */
    uint64_t head;                    /* seq of the next entry */
    uint64_t tail;                    /* seq of the oldest entry held */
    double last_end[3];               /* end of the newest primitive added */
    int has_last;
    /* release rule */
    uint64_t lag_min_cur, lag_min_prev; /* smallest matched seq in this / the previous batch */
    unsigned lag_n;
    double lag_from[3];               /* executed point where the batch began */
    uint64_t released;                /* entries below this seq may be dropped */
    /* candidate list around the anchor */
    int anchor_ok;
    double anchor[3], anchor_d, m_um, r_um, m_valid_um;
    unsigned dense_skip;              /* full searches left before the next rebuild try */
    struct pk_path_cand cand[PK_PATH_CAND_MAX];
    unsigned n_cand;
    uint64_t cursor;                  /* seq of the last point's nearest entry */
    double m_min_um;                  /* smallest anchor radius (half the smallest step) */
    /* figures */
    struct pk_path_stats st;
    uint32_t *hist;                   /* PK_PATH_HIST_BINS counts */
    double *edge;                     /* PK_PATH_HIST_BINS + 1 bin edges */
    uint64_t *dup;                    /* 2 cap slots: seq + 1 of entries by geometry (0: empty) */
    /* the grid */
    int grid_on;
    double cell_um;
    struct pk_path_gslot *gslot;      /* PK_PATH_GRID_SLOTS */
    struct pk_path_gnode *gnode;      /* PK_PATH_GRID_NODES */
    uint32_t g_nodes, g_slots_used;
    uint32_t stamp;
    uint64_t *longl;                  /* seqs of entries too long for the grid */
    uint32_t n_long;
    uint64_t grid_rebuilds;
    double win_len_um;                /* total X-Y length of the entries held */
    uint64_t dup_inserts;             /* since the table was last rebuilt */
    uint64_t hist_zero;               /* deviations below PK_PATH_HIST_MIN_UM */
};

/** Bytes of memory per window entry (for the memory bound). */
#define PK_PATH_ENTRY_BYTES (sizeof(struct pk_path_ent) + sizeof(struct pk_path_box) / 32u + 2u + 16u)

/**
 * Set up an empty path. dims: 2 or 3 axes measured; cap: window size (rounded
 * up to a power of two, at least 1024; 0: PK_PATH_CAP_DEFAULT); step_um: the
 * smallest step length of the machine (sets the smallest anchor radius; > 0).
 * Memory: cap * PK_PATH_ENTRY_BYTES + PK_PATH_HIST_BINS * 12 bytes + the grid
 * (PK_PATH_GRID_SLOTS * 16 + PK_PATH_GRID_NODES * 8 bytes), allocated
 * here and never grown. @return 0, or -1 out of memory (then pk_path_free).
 */
int pk_path_init(struct pk_path *pa, unsigned dims, uint32_t cap, double step_um);
void pk_path_free(struct pk_path *pa);

/**
 * Add a primitive at the end of the path (copied). A zero-length line that
 * starts where the previous primitive ended is counted and not stored.
 * Primitives need not join (a reference path may consist of separate strokes).
 * If the window is full the oldest entry is dropped (forced_drops counts it if
 * it was not released).
 */
void pk_path_add(struct pk_path *pa, const struct pk_path_prim *p);

/** Primitives that can be added now without a forced drop. */
size_t pk_path_room(const struct pk_path *pa);

/** The executed path has caught up with everything added (the machine is idle):
 *  all but the last PK_PATH_BACK entries become released. */
void pk_path_all_executed(struct pk_path *pa);

/**
 * Measure one point of the executed path (µm; axes beyond dims ignored) with
 * a time stamp for the figures. Returns its deviation (µm), or -1 if the
 * window is empty (counted as unmatched). If line/drawn are not NULL they
 * receive the nearest primitive's line number and pen state.
 */
double pk_path_measure(struct pk_path *pa, const double pt[3], uint64_t tick, uint32_t *line,
                       uint8_t *drawn);

/** The exact distance from pt to the window (no candidate list, no figures
 *  updated): a brute-force reference for tests. -1 if the window is empty. */
double pk_path_window_dist(const struct pk_path *pa, const double pt[3]);

/** The 95th percentile (or any quantile q in (0, 1]) of the deviations
 *  measured, µm, as stated above; 0 with no points. */
double pk_path_quantile(const struct pk_path *pa, double q);

#endif
