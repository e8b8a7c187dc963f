// Pixels of the test renders: a unit sphere filling an S x S orthographic
// view, camera on the view axis; read-back rows are bottom to top (GL).
import fs from 'node:fs';
import { normalize, dot } from './cube.mjs';
import { encodePng, linearToSrgb8 } from './png.mjs';

// The view-space normal at pixel (x, y) (analytic sphere), or null outside.
export function pixelNormal(S, x, y) {
  const px = ((x + 0.5) / S) * 2 - 1, py = ((y + 0.5) / S) * 2 - 1;
  const q = px * px + py * py;
  if (q >= 1) return null;
  return [px, py, Math.sqrt(1 - q)];
}

export const reflect = (V, N) => { const d = dot(N, V); return [2 * d * N[0] - V[0], 2 * d * N[1] - V[1], 2 * d * N[2] - V[2]]; };
export const mix = (a, b, t) => [0, 1, 2].map((k) => a[k] * (1 - t) + b[k] * t);

// The pixel whose centre shows normal (nx, ny) (view space, y up).
export function pixelAt(S, nx, ny) {
  return [Math.round(((nx + 1) / 2) * S - 0.5), Math.round(((ny + 1) / 2) * S - 0.5)];
}

export const rgbAt = (px, S, x, y) => { const o = (y * S + x) * 4; return [px[o], px[o + 1], px[o + 2], px[o + 3]]; };

// Largest relative difference of two RGB triples, relative to the expected
// value's channel sum (so dark channels next to bright ones do not blow up).
export function relDiff(got, want) {
  const s = Math.max(1e-6, want[0] + want[1] + want[2]);
  return Math.max(Math.abs(got[0] - want[0]), Math.abs(got[1] - want[1]), Math.abs(got[2] - want[2])) / (s / 3);
}

export function percentile(values, p) {
  if (!values.length) return NaN;
  const v = Float64Array.from(values).sort();
  return v[Math.min(v.length - 1, Math.floor((p / 100) * v.length))];
}

// Contact sheet: rows of renders (each S x S float RGBA, rows bottom-up),
// each row labelled by its position; written as an sRGB PNG.
export function writeSheet(file, rows, S, { scale = 1, gap = 4 } = {}) {
  const cols = Math.max(...rows.map((r) => r.length));
  const W = cols * S + (cols + 1) * gap, H = rows.length * S + (rows.length + 1) * gap;
  const img = new Uint8Array(W * H * 3).fill(40);
  rows.forEach((row, ri) => row.forEach((px, ci) => {
    if (!px) return;
    const ox = gap + ci * (S + gap), oy = gap + ri * (S + gap);
    for (let y = 0; y < S; y++) for (let x = 0; x < S; x++) {
      const s = ((S - 1 - y) * S + x) * 4, d = ((oy + y) * W + ox + x) * 3;
      if (px[s + 3] === 0 && px[s] === 0 && px[s + 1] === 0 && px[s + 2] === 0) continue;
      for (let k = 0; k < 3; k++) img[d + k] = linearToSrgb8(px[s + k] * scale);
    }
  }));
  fs.writeFileSync(file, encodePng(W, H, 3, img));
  return file;
}
