/*
 * sim_svg.h — the drawing of a simulated run, written as the run goes, in
 * bounded memory (host only): the programmed path (wide, light; travels
 * dashed) under the executed path decoded from the step pulses (thin, dark;
 * travels dotted).
 *
 * Each path is a stream of points with a pen state (strokes solid, travels
 * dashed). Arcs and Béziers of the programmed path are flattened to chords
 * within eps/2 of the curve. Every stream is thinned on the fly by a cone
 * (sleeve) simplifier with bound eps/2 (eps for straight streams): a point is
 * dropped only if it lies within the bound of the segment that replaces it,
 * and the kept points are points of the stream, so the polyline drawn is
 * within eps of the path it shows, both ways (Hausdorff distance <= eps).
 * Memory: O(1) per stream; the streams go to temporary files (travels and
 * strokes apart, so that travels are drawn underneath) and the SVG (whose
 * viewBox needs the bounding box, known only at the end) is put together by
 * pk_svg_close.
 */
#ifndef PLOTKIN_SIM_SVG_H
#define PLOTKIN_SIM_SVG_H

#include <stdint.h>
#include <stdio.h>
#include "sim_path.h"

/** One thinned polyline stream into a temporary file. (private members) */
struct pk_svg_stream {
    FILE *f[2];              /* travels, strokes (travels are drawn underneath) */
    double eps;
    int open;                /* a <path> element is open */
    int pen;                 /* its pen state */
    unsigned in_elem;        /* points in the open element */
    /* simplifier: last kept point S, last accepted point L, cone around a reference direction */
    int have_s, have_l, have_ref;
    double s[2], l[2], ref, lo, hi, rmax;
    uint64_t points_in, points_out;
};

struct pk_svg {
    struct pk_svg_stream prog, exec;
    double lo[2], hi[2];     /* bounding box, µm */
    double eps_um;
};

/** Start a drawing with tolerance eps_um (> 0). Returns 0, or -1 (no temporary file). */
int pk_svg_open(struct pk_svg *s, double eps_um);

/** A programmed primitive (sim_path.h), with its pen state p->drawn. */
void pk_svg_prim(struct pk_svg *s, const struct pk_path_prim *p);

/** A point of the executed path (µm, X Y) and whether it is drawing. */
void pk_svg_exec_point(struct pk_svg *s, const double xy_um[2], int drawn);

/** Write the SVG to path (title: the file name shown) and free everything.
 *  Returns 0, or -1 on an I/O error (errno set). */
int pk_svg_close(struct pk_svg *s, const char *path, const char *title);

/** Free without writing (error paths). */
void pk_svg_discard(struct pk_svg *s);

#endif
