// Checks shared by the engine tests. Each returns {pass, message, metrics}.
import { normalize, dot, sampleLevel } from './cube.mjs';
import { pixelNormal, rgbAt, relDiff, percentile, pixelAt } from './sphere.mjs';
import { fmt } from './harness.mjs';

// Nearest lobe (by colour direction after removing the floor) of an RGB value.
export function classifyLobe(rgb, desc) {
  const v = rgb.slice(0, 3).map((x) => x - desc.floor);
  const nv = Math.hypot(...v);
  if (!(nv > 1e-4)) return null;
  let best = null, bestCos = -2;
  for (const lobe of desc.lobes) {
    const c = lobe.colour, nc = Math.hypot(...c);
    const cos = (v[0] * c[0] + v[1] * c[1] + v[2] * c[2]) / (nv * nc);
    if (cos > bestCos) { bestCos = cos; best = lobe.name; }
  }
  return best;
}

// The axis lobe nearest a direction, when within maxDeg of it.
export function axisLobe(d, desc, maxDeg = 25) {
  const n = normalize(d);
  let best = null, bestDot = Math.cos((maxDeg * Math.PI) / 180);
  for (const lobe of desc.lobes) { const c = dot(n, lobe.axis); if (c > bestDot) { bestDot = c; best = lobe.name; } }
  return best;
}

// Orientation: every pixel whose lookup direction (world space, SPEC
// orientation, as the engine bends it: lookupDir(N) -> direction) lies
// within 25 degrees of an axis must show that axis's lobe colour. Named
// pixels (centre, +-45 degrees in x and y, near the rim) are reported.
export function orientationCheck(px, S, desc, lookupDir, { minFraction = 0.99 } = {}) {
  let n = 0, ok = 0;
  const wrong = {};
  for (let y = 0; y < S; y++) for (let x = 0; x < S; x++) {
    const N = pixelNormal(S, x, y);
    if (!N || N[2] < 0.05) continue;
    const want = axisLobe(lookupDir(N), desc);
    if (!want) continue;
    const got = classifyLobe(rgbAt(px, S, x, y), desc);
    n++;
    if (got === want) ok++;
    else { const k = `${want}->${got}`; wrong[k] = (wrong[k] || 0) + 1; }
  }
  const s45 = Math.SQRT1_2;
  const named = { centre: [0, 0], right: [s45, 0], left: [-s45, 0], up: [0, s45], down: [0, -s45], rim: [0.985, 0] };
  const shown = {};
  for (const [k, [nx, ny]] of Object.entries(named)) {
    const [x, y] = pixelAt(S, nx, ny);
    shown[k] = classifyLobe(rgbAt(px, S, x, y), desc);
  }
  const frac = n ? ok / n : 0;
  const top = Object.entries(wrong).sort((a, b) => b[1] - a[1]).slice(0, 4).map(([k, v]) => `${k} x${v}`).join(', ');
  return {
    pass: n > 100 && frac >= minFraction,
    message: `${ok}/${n} pixels near an axis show its lobe (${(100 * frac).toFixed(1)} %, need ${100 * minFraction} %); ` +
             `centre ${shown.centre}, right ${shown.right}, left ${shown.left}, up ${shown.up}, down ${shown.down}, rim ${shown.rim}` +
             (top ? `; wrong: ${top}` : ''),
    metrics: { pixels: n, fraction: frac, shown, wrong },
  };
}

// Compares a render with a per-pixel model over the sphere (pixels with
// N.V >= minNV); the centre pixel gets its own tolerance.
export function valueCheck(px, S, model, { centreTol, p99Tol, minNV = 0.3, label = '' }) {
  const c = Math.floor(S / 2);
  const diffs = [];
  let worst = { d: -1 };
  let centre = null;
  for (let y = 0; y < S; y++) for (let x = 0; x < S; x++) {
    const N = pixelNormal(S, x, y);
    if (!N || N[2] < minNV) continue;
    const want = model(x, y, N);
    if (!want) continue;
    const got = rgbAt(px, S, x, y);
    const d = relDiff(got, want);
    diffs.push(d);
    if (d > worst.d) worst = { d, x, y, got: got.slice(0, 3), want };
    if (x === c && y === c) centre = { d, got: got.slice(0, 3), want };
  }
  const p99 = percentile(diffs, 99);
  const pass = centre !== null && centre.d <= centreTol && p99 <= p99Tol;
  return {
    pass,
    message: `${label}centre ${fmt(centre?.got)} vs ${fmt(centre?.want)} (rel ${fmt(centre?.d)}, tol ${centreTol}); ` +
             `p99 over ${diffs.length} px ${fmt(p99)} (tol ${p99Tol}); worst ${fmt(worst.d)} at (${worst.x}, ${worst.y})`,
    metrics: { centre: centre?.d, centreGot: centre?.got, centreWant: centre?.want, p99, max: worst.d, pixels: diffs.length },
  };
}

export { sampleLevel };
