// peers.mjs — the npm peers on the benchmark input, one run per process.
//
//   node bench/peers.mjs PEER N DEPTH
//   PEER: chaikin-smooth | thing | turf
//
// Same random walk as bench/bench_common.h (xorshift32, reflected at ±1 m),
// as [x, y] arrays of doubles. chaikin-smooth is applied DEPTH times (one
// level per call, the package's documented use); @thi.ng/geom-subdiv-curve
// gets DEPTH SUBDIV_CHAIKIN kernels on an open curve; @turf/polygon-smooth
// smooths polygons only, so it gets the walk as a closed ring with
// {iterations: DEPTH}. A warm-up call on 1000 points lets the JIT compile
// first. Prints the same line as the C programs: outputs, seconds (the
// smoothing call only), maxrss_kb, checksum.
import { createRequire } from "node:module";
import { readFileSync } from "node:fs";
import { subdivide, SUBDIV_CHAIKIN } from "@thi.ng/geom-subdiv-curve";
import polygonSmooth from "@turf/polygon-smooth";
import { polygon } from "@turf/helpers";
const require = createRequire(import.meta.url);
const chaikinSmooth = require("chaikin-smooth");

function walk(n) {
  let s = 0x12345678, x = 0, y = 0;
  const step = (v) => {
    s ^= s << 13; s >>>= 0;
    s ^= s >>> 17;
    s ^= s << 5; s >>>= 0;
    v += (s % 2001) - 1000;
    if (v > 1000000) v = 2000000 - v;
    if (v < -1000000) v = -2000000 - v;
    return v;
  };
  const pts = new Array(n);
  for (let i = 0; i < n; i++) { x = step(x); y = step(y); pts[i] = [x, y]; }
  return pts;
}

const peers = {
  "chaikin-smooth": (pts, depth) => { for (let d = 0; d < depth; d++) pts = chaikinSmooth(pts); return pts; },
  thing: (pts, depth) => subdivide(pts, new Array(depth).fill(SUBDIV_CHAIKIN), false),
  turf: (pts, depth) => {
    const ring = pts.concat([pts[0].slice()]);
    const fc = (polygonSmooth.default || polygonSmooth)(polygon([ring]), { iterations: depth });
    return fc.features[0].geometry.coordinates[0];
  },
};

// VmHWM, as the C programs report it (resourceUsage().maxRSS survives exec).
function peakRssKb() {
  const m = /VmHWM:\s+(\d+)/.exec(readFileSync("/proc/self/status", "utf8"));
  return m ? Number(m[1]) : -1;
}

const [peer, nArg, dArg] = process.argv.slice(2);
const fn = peers[peer];
if (!fn) { console.error("usage: node peers.mjs chaikin-smooth|thing|turf N DEPTH"); process.exit(2); }
const n = Number(nArg), depth = Number(dArg);
fn(walk(1000), 2); // warm-up
const input = walk(n);
const t0 = process.hrtime.bigint();
const out = fn(input, depth);
const t1 = process.hrtime.bigint();
let sum = 0n;
for (let i = 0; i < out.length; i += 97) sum += BigInt(Math.trunc(out[i][0]) ^ Math.trunc(out[i][1]));
console.log(`outputs=${out.length} seconds=${Number(t1 - t0) / 1e9} maxrss_kb=${peakRssKb()} checksum=${sum}`);
