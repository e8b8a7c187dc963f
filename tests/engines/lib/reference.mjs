// Exact Pre(n, r) and Irr(n) of the analytic test sources (SPEC section 3),
// by Gauss-Legendre quadrature over GGX's half-vector distribution: the
// ground truth both our bake and an engine's own filtering are measured
// against. Independent of the C++ code.
import { normalize, dot, sampleGrid, texelDir } from './cube.mjs';

function gaussLegendre(n) {
  const x = new Float64Array(n), w = new Float64Array(n);
  for (let i = 0; i < n; i++) {
    let z = Math.cos(Math.PI * (i + 0.75) / (n + 0.5)), pp = 0;
    for (let it = 0; it < 100; it++) {
      let p1 = 1, p2 = 0;
      for (let j = 0; j < n; j++) { const p3 = p2; p2 = p1; p1 = ((2 * j + 1) * z * p2 - j * p3) / (j + 1); }
      pp = n * (z * p1 - p2) / (z * z - 1);
      const dz = p1 / pp;
      z -= dz;
      if (Math.abs(dz) < 1e-15) break;
    }
    x[i] = z; w[i] = 2 / ((1 - z * z) * pp * pp);
  }
  return { x, w };
}
const GL = new Map();
const rule = (n) => { if (!GL.has(n)) GL.set(n, gaussLegendre(n)); return GL.get(n); };

function frame(n) {
  const a = Math.abs(n[0]) < 0.9 ? [1, 0, 0] : [0, 1, 0];
  const t = normalize([a[1] * n[2] - a[2] * n[1], a[2] * n[0] - a[0] * n[2], a[0] * n[1] - a[1] * n[0]]);
  const b = [n[1] * t[2] - n[2] * t[1], n[2] * t[0] - n[0] * t[2], n[0] * t[1] - n[1] * t[0]];
  return [t, b];
}

// L: (engine direction) -> [r, g, b]. Pre as SPEC defines it (N = V = n).
export function prefiltered(L, n, r, { nu = 96, nphi = 128 } = {}) {
  if (r === 0) return L(n);
  const a2 = r ** 4;
  // u = GGX CDF of theta_h: cos^2 = (1 - u) / (1 + (a2 - 1) u); n.w > 0 <=> theta_h < 45 deg <=> u < 1 / (1 + a2).
  const uMax = 1 / (1 + a2);
  const { x: gx, w: gw } = rule(nu), { x: px, w: pw } = rule(nphi);
  const [t, b] = frame(n);
  const num = [0, 0, 0];
  let den = 0;
  // Split u at a few points so the nodes follow the lobe's scale (GGX's tail is long).
  const cuts = [0, 0.5 * uMax, 0.9 * uMax, 0.99 * uMax, uMax];
  for (let c = 0; c + 1 < cuts.length; c++) {
    const u0 = cuts[c], u1 = cuts[c + 1];
    for (let i = 0; i < nu; i++) {
      const u = u0 + (u1 - u0) * (gx[i] + 1) / 2, wu = gw[i] * (u1 - u0) / 2;
      const c2 = (1 - u) / (1 + (a2 - 1) * u), ch = Math.sqrt(c2), sh = Math.sqrt(Math.max(0, 1 - c2));
      for (let k = 0; k < nphi; k++) {
        const ph = Math.PI * (px[k] + 1), wp = pw[k] * Math.PI;
        const h = [0, 1, 2].map((q) => sh * Math.cos(ph) * t[q] + sh * Math.sin(ph) * b[q] + ch * n[q]);
        const nh = ch;
        const w = [0, 1, 2].map((q) => 2 * nh * h[q] - n[q]);
        const nw = dot(n, w);
        if (nw <= 0) continue;
        // weight of the (u, phi) sample: D (n.h) dOmega_h = du dphi / (2 pi); dOmega_w = 4 (n.h) dOmega_h.
        const wt = wu * wp * 4 * nw;
        const l = L(w);
        num[0] += wt * l[0]; num[1] += wt * l[1]; num[2] += wt * l[2];
        den += wt;
      }
    }
  }
  return num.map((v) => v / den);
}

// Irr(n) = (1/pi) integral L max(0, n.w) dw, by a product rule on the hemisphere.
export function irradiance(L, n, { nt = 64, nphi = 128 } = {}) {
  const { x: gx, w: gw } = rule(nt), { x: px, w: pw } = rule(nphi);
  const [t, b] = frame(n);
  const s = [0, 0, 0];
  for (let i = 0; i < nt; i++) {
    const mu = (gx[i] + 1) / 2, wmu = gw[i] / 2;        // mu = cos theta in [0, 1]
    const st = Math.sqrt(1 - mu * mu);
    for (let k = 0; k < nphi; k++) {
      const ph = Math.PI * (px[k] + 1), wp = pw[k] * Math.PI;
      const w = [0, 1, 2].map((q) => st * Math.cos(ph) * t[q] + st * Math.sin(ph) * b[q] + mu * n[q]);
      const l = L(w), wt = wmu * wp * mu / Math.PI;
      s[0] += wt * l[0]; s[1] += wt * l[1]; s[2] += wt * l[2];
    }
  }
  return s;
}

// The analytic sources of make_sources.py, from its sources.json.
export function markerSource(desc) {
  const k = desc.lobe_sharpness, floor = desc.floor;
  return (w) => {
    const d = normalize(w);
    const out = [floor, floor, floor];
    for (const lobe of desc.lobes) {
      const e = Math.exp(k * (dot(d, lobe.axis) - 1));
      out[0] += e * lobe.colour[0]; out[1] += e * lobe.colour[1]; out[2] += e * lobe.colour[2];
    }
    return out;
  };
}
const quad = (q, n) => q.reduce((acc, row, i) => acc + n[i] * dot(row, n), 0);
export function smoothSource(desc) {
  const { c, d, q } = desc.smooth;
  return (w) => { const n = normalize(w); return [0, 1, 2].map((ch) => c[ch] + dot(d[ch], n) + quad(q[ch], n)); };
}
// Exact irradiance of the smooth source: c + (2/3) D.n + (1/4) n^T Q n (Q traceless: band 2 only).
export function smoothIrradiance(desc, n) {
  const { c, d, q } = desc.smooth;
  n = normalize(n);
  return [0, 1, 2].map((ch) => c[ch] + (2 / 3) * dot(d[ch], n) + 0.25 * quad(q[ch], n));
}

// Irradiance of a uniform sun disc (sources.json's `sun`: direction, radius_deg,
// radiance) at normal N: (1/pi) integral over the disc of L max(0, N.w) dw, a
// polar midpoint rule (24 x 48) about the disc's centre. Exact where the disc
// straddles the horizon, where a point light is not.
export function discIrradiance(sun, N) {
  const D = normalize(sun.direction), rad = sun.radius_deg * Math.PI / 180;
  const a = Math.abs(D[0]) < 0.9 ? [1, 0, 0] : [0, 1, 0];
  const t1 = normalize([a[1] * D[2] - a[2] * D[1], a[2] * D[0] - a[0] * D[2], a[0] * D[1] - a[1] * D[0]]);
  const t2 = [D[1] * t1[2] - D[2] * t1[1], D[2] * t1[0] - D[0] * t1[2], D[0] * t1[1] - D[1] * t1[0]];
  let sum = 0;
  const nr = 24, np = 48;
  for (let i = 0; i < nr; i++) {
    const th = (i + 0.5) * rad / nr, st = Math.sin(th), ct = Math.cos(th);
    for (let k = 0; k < np; k++) {
      const ph = (k + 0.5) * 2 * Math.PI / np, cp = Math.cos(ph) * st, sp = Math.sin(ph) * st;
      sum += Math.max(0, dot(N, [0, 1, 2].map((q) => D[q] * ct + t1[q] * cp + t2[q] * sp))) * st;
    }
  }
  const f = sum * (rad / nr) * (2 * Math.PI / np) / Math.PI;
  return sun.radiance.map((l) => l * f);
}

// What a render of a mip chain shows when every texel is exact: the chain's
// levels [{n, r}] hold Pre(texel centre, r) exactly, sampled as the GPU does
// (seamless bilinear, linear between levels at lod). Separates a filter's
// error from the interpolation error of the chain's own grid.
export function chainTruth(L, chain, d, lod, memo = new Map()) {
  const top = chain.length - 1, l = Math.min(top, Math.max(0, lod));
  const l0 = Math.floor(l), l1 = Math.min(top, l0 + 1), w = l - l0;
  const at = (m) => sampleGrid(chain[m].n, 3, d, (f, i, j) => {
    const key = `${m}/${chain[m].n}/${chain[m].r}/${f}/${i}/${j}`;
    if (!memo.has(key)) memo.set(key, prefiltered(L, texelDir(f, i, j, chain[m].n), chain[m].r));
    return memo.get(key);
  });
  const a = at(l0);
  if (w === 0 || l1 === l0) return a;
  const b = at(l1);
  return a.map((v, k) => v * (1 - w) + b[k] * w);
}
