// Cube-map math of SPEC.md section 2 and ENGINES.md section 1, written from
// the documents (not from our C++): face table, texel directions, mirrors,
// roughness curves, SH, and a reference sampler that does what a GLES 3 GPU
// does with a mip-mapped cube (seamless bilinear per level, linear between
// levels).

// SPEC 2: face f at (s, t) in [0, 1]^2 -> unnormalised engine direction.
export function faceDir(f, s, t) {
  const sc = 2 * s - 1, tc = 2 * t - 1;
  switch (f) {
    case 0: return [1, -tc, -sc];
    case 1: return [-1, -tc, sc];
    case 2: return [sc, 1, tc];
    case 3: return [sc, -1, -tc];
    case 4: return [sc, -tc, 1];
    case 5: return [-sc, -tc, -1];
    default: throw new Error(`bad face ${f}`);
  }
}

export function normalize(v) {
  const l = Math.hypot(v[0], v[1], v[2]);
  return [v[0] / l, v[1] / l, v[2] / l];
}
export const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];

// Engine direction -> {f, s, t} by the OpenGL major-axis rule.
export function dirToFace(d) {
  const [x, y, z] = d;
  const ax = Math.abs(x), ay = Math.abs(y), az = Math.abs(z);
  let f, sc, tc, ma;
  if (ax >= ay && ax >= az) { ma = ax; if (x > 0) { f = 0; sc = -z; tc = -y; } else { f = 1; sc = z; tc = -y; } }
  else if (ay >= az) { ma = ay; if (y > 0) { f = 2; sc = x; tc = z; } else { f = 3; sc = x; tc = -z; } }
  else { ma = az; if (z > 0) { f = 4; sc = x; tc = -y; } else { f = 5; sc = -x; tc = -y; } }
  return { f, s: (sc / ma + 1) / 2, t: (tc / ma + 1) / 2 };
}

export const texelDir = (f, i, j, n) => normalize(faceDir(f, (i + 0.5) / n, (j + 0.5) / n));

// Mirrors (ENGINES 1): the content a mirrored cube holds at c is SPEC's at m(c).
export function mirrorDir(mirror, d) {
  switch (mirror) {
    case 'none': return d;
    case 'x': return [-d[0], d[1], d[2]];
    case 'y': return [d[0], -d[1], d[2]];
    case 'z': return [d[0], d[1], -d[2]];
    default: throw new Error(`unknown mirror '${mirror}'`);
  }
}
// SH9 coefficients negated by a mirror (ENGINES 1; P = 1, y, z, x, xy, yz, 3z^2-1, xz, x^2-y^2).
export const SH_MIRROR_NEGATE = { none: [], x: [3, 4, 7], y: [1, 4, 5], z: [2, 5, 7] };

// A cube level: {n, c (channels), faces: [6 x Float32Array(n*n*c)]}, rows top to bottom.
export function makeLevel(n, c = 3) {
  return { n, c, faces: Array.from({ length: 6 }, () => new Float32Array(n * n * c)) };
}

// Re-indexes a SPEC level into the mirrored cube an engine reads, by
// directions (texel centres map to texel centres under axis mirrors).
export function mirrorLevel(level, mirror) {
  const out = makeLevel(level.n, level.c);
  for (let f = 0; f < 6; f++) for (let j = 0; j < level.n; j++) for (let i = 0; i < level.n; i++) {
    const src = nearestTexel(level, mirrorDir(mirror, texelDir(f, i, j, level.n)));
    const o = (j * level.n + i) * level.c;
    for (let k = 0; k < level.c; k++) out.faces[f][o + k] = level.faces[src.f][src.o + k];
  }
  return out;
}

export function nearestTexel(level, d) {
  const { f, s, t } = dirToFace(d);
  const n = level.n;
  const i = Math.min(n - 1, Math.max(0, Math.floor(s * n)));
  const j = Math.min(n - 1, Math.max(0, Math.floor(t * n)));
  return { f, i, j, o: (j * n + i) * level.c };
}

// Texel (i, j) of face f, where i or j may lie one texel outside the face:
// the neighbour face's texel at that spot (seamless filtering), found by
// projecting the outside texel centre onto the cube.
export const CUBE_FILTER = { mode: 'seamless' };   // 'seamless' (GLES 3) or 'clamp' (per-face clamp to edge)

// Texel (i, j) of face f of an n x n grid, where i or j may lie one texel
// outside the face: the neighbour face's texel at that spot (seamless
// filtering), found by projecting the outside texel centre onto the cube.
// get(f, i, j) returns a texel's channels.
function gridTexel(n, get, f, i, j) {
  if (CUBE_FILTER.mode === 'clamp') { i = Math.min(n - 1, Math.max(0, i)); j = Math.min(n - 1, Math.max(0, j)); }
  if (i >= 0 && i < n && j >= 0 && j < n) return get(f, i, j);
  const outI = i < 0 || i >= n, outJ = j < 0 || j >= n;
  if (outI && outJ) {
    // No texel sits beyond a cube corner: like SwiftShader (and most GPUs),
    // use the mean of the three texels that meet there.
    const ic = Math.min(n - 1, Math.max(0, i)), jc = Math.min(n - 1, Math.max(0, j));
    const a = gridTexel(n, get, f, ic, jc), b = gridTexel(n, get, f, i, jc), c = gridTexel(n, get, f, ic, j);
    return Array.from(a, (v, k) => (v + b[k] + c[k]) / 3);
  }
  const { f: g, s, t } = dirToFace(faceDir(f, (i + 0.5) / n, (j + 0.5) / n));
  return get(g, Math.min(n - 1, Math.max(0, Math.floor(s * n))), Math.min(n - 1, Math.max(0, Math.floor(t * n))));
}

// Seamless bilinear sample at direction d of an n x n cube grid with c channels.
export function sampleGrid(n, c, d, get) {
  const { f, s, t } = dirToFace(d);
  const u = s * n - 0.5, v = t * n - 0.5;
  const i0 = Math.floor(u), j0 = Math.floor(v);
  const a = u - i0, b = v - j0;
  const out = new Array(c).fill(0);
  const w = [[(1 - a) * (1 - b), i0, j0], [a * (1 - b), i0 + 1, j0], [(1 - a) * b, i0, j0 + 1], [a * b, i0 + 1, j0 + 1]];
  for (const [wk, i, j] of w) {
    if (wk === 0) continue;
    const px = gridTexel(n, get, f, i, j);
    for (let k = 0; k < c; k++) out[k] += wk * px[k];
  }
  return out;
}

// Seamless bilinear sample of one level at direction d.
export function sampleLevel(level, d) {
  const n = level.n, c = level.c;
  return sampleGrid(n, c, d, (f, i, j) => level.faces[f].subarray((j * n + i) * c, (j * n + i + 1) * c));
}

// Trilinear: levels[] largest first, lod clamped to [0, levels.length - 1].
export function sampleLod(levels, d, lod) {
  const top = levels.length - 1;
  const l = Math.min(top, Math.max(0, lod));
  const l0 = Math.floor(l), l1 = Math.min(top, l0 + 1), w = l - l0;
  const a = sampleLevel(levels[l0], d);
  if (w === 0 || l0 === l1) return a;
  const b = sampleLevel(levels[l1], d);
  return a.map((x, k) => x * (1 - w) + b[k] * w);
}

// Roughness <-> lod curves (ENGINES 1). T = M - 1.
export const CURVES = {
  linear: { lod: (r, T) => T * r, r: (m, T) => (T === 0 ? 0 : m / T) },
  filament: { lod: (r, T) => T * r * (2 - r), r: (m, T) => (T === 0 ? 0 : 1 - Math.sqrt(1 - m / T)) },
  unity: { lod: (r) => 6 * r * (1.7 - 0.7 * r), r: (m) => (m >= 6 ? 1 : (1.7 - Math.sqrt(2.89 - 2.8 * m / 6)) / 1.4) },
  babylon: {
    lod: (r, T, N0, scale = 0.8) => scale * Math.log2(N0 * r * r),
    r: (m, T, N0, scale = 0.8) => (m === 0 ? 0 : Math.min(1, Math.sqrt(2 ** (m / scale) / N0))),
  },
};

// SPEC 5: real SH basis in three.js order.
export function shBasis(d) {
  const [x, y, z] = d;
  return [0.282095, 0.488603 * y, 0.488603 * z, 0.488603 * x, 1.092548 * x * y, 1.092548 * y * z,
          0.315392 * (3 * z * z - 1), 1.092548 * x * z, 0.546274 * (x * x - y * y)];
}
// ENGINES 1: k_i = (A_l / pi) c_lm.
export const SH_K = [0.282095, 0.325735, 0.325735, 0.325735, 0.273137, 0.273137, 0.078848, 0.273137, 0.136569];
// Irr(n) from sh9 [[9 r], [9 g], [9 b]] (radiance coefficients).
export function shIrradiance(sh9, d) {
  const [x, y, z] = d;
  const P = [1, y, z, x, x * y, y * z, 3 * z * z - 1, x * z, x * x - y * y];
  return [0, 1, 2].map((ch) => P.reduce((acc, p, i) => acc + SH_K[i] * sh9[ch][i] * p, 0));
}

// Half floats.
export function halfToFloat(h) {
  const s = (h & 0x8000) ? -1 : 1, e = (h >> 10) & 0x1f, m = h & 0x3ff;
  if (e === 0) return s * m * 2 ** -24;
  if (e === 31) return m ? NaN : s * Infinity;
  return s * (1 + m / 1024) * 2 ** (e - 15);
}
const _f32 = new Float32Array(1), _u32 = new Uint32Array(_f32.buffer);
export function floatToHalf(v) {   // round to nearest even
  _f32[0] = v;
  const x = _u32[0], sign = (x >>> 16) & 0x8000;
  let e = ((x >>> 23) & 0xff) - 127 + 15, m = x & 0x7fffff;
  if (((x >>> 23) & 0xff) === 0xff) return sign | 0x7c00 | (m ? 0x200 : 0);
  if (e >= 31) return sign | 0x7c00;
  if (e <= 0) {
    if (e < -10) return sign;
    m |= 0x800000;
    const shift = 14 - e, half = 1 << (shift - 1), rest = m & ((1 << shift) - 1);
    let r = m >>> shift;
    if (rest > half || (rest === half && (r & 1))) r++;
    return sign | r;
  }
  let r = m >>> 13;
  const rest = m & 0x1fff;
  let h = sign | (e << 10) | r;
  if (rest > 0x1000 || (rest === 0x1000 && (r & 1))) h++;
  return h;
}
export const roundHalf = (v) => halfToFloat(floatToHalf(v));

// Shared E5B9G9R9 decode (Vulkan / GL rule).
export function decodeE5B9G9R9(u) {
  const r = u & 0x1ff, g = (u >>> 9) & 0x1ff, b = (u >>> 18) & 0x1ff, e = (u >>> 27) & 0x1f;
  const sc = 2 ** (e - 15 - 9);
  return [r * sc, g * sc, b * sc];
}
// B10G11R11 unsigned floats.
function ufloat(v, mbits) {
  const e = v >>> mbits, m = v & ((1 << mbits) - 1);
  if (e === 0) return m * 2 ** (-14 - mbits);
  if (e === 31) return m ? NaN : Infinity;
  return (1 + m / (1 << mbits)) * 2 ** (e - 15);
}
export function decodeB10G11R11(u) {
  return [ufloat(u & 0x7ff, 6), ufloat((u >>> 11) & 0x7ff, 6), ufloat((u >>> 22) & 0x3ff, 5)];
}

// Horizontal cross (SPEC 2) -> level. img: {width, height, channels, data (rows top to bottom)}.
const CROSS_CELLS = [[2, 1], [0, 1], [1, 0], [1, 2], [1, 1], [3, 1]];  // +X -X +Y -Y +Z -Z
export function crossToLevel(img, c = 3) {
  const n = img.width / 4;
  if (img.height !== 3 * n || !Number.isInteger(n)) throw new Error(`not a horizontal cross: ${img.width} x ${img.height}`);
  const lvl = makeLevel(n, c);
  for (let f = 0; f < 6; f++) {
    const [cx, cy] = CROSS_CELLS[f];
    for (let j = 0; j < n; j++) for (let i = 0; i < n; i++) {
      const src = ((cy * n + j) * img.width + cx * n + i) * img.channels, dst = (j * n + i) * c;
      for (let k = 0; k < c; k++) lvl.faces[f][dst + k] = img.data[src + k];
    }
  }
  return lvl;
}
export function crossUnusedMax(img) {
  const n = img.width / 4;
  let m = 0;
  for (const [cx, cy] of [[0, 0], [2, 0], [3, 0], [0, 2], [2, 2], [3, 2]])
    for (let j = 0; j < n; j++) for (let i = 0; i < n; i++)
      for (let k = 0; k < 3; k++) m = Math.max(m, Math.abs(img.data[((cy * n + j) * img.width + cx * n + i) * img.channels + k]));
  return m;
}

// ENGINES 1: SPEC sh9 (radiance, [[9 r], [9 g], [9 b]]) -> the quadratic
// without constant term that evaluates to Irr (Babylon's SphericalPolynomial).
export function shToPolynomial(sh9) {
  const k = SH_K;
  const per = (f) => [0, 1, 2].map((c) => f(sh9[c]));
  const C = (L) => k[0] * L[0] - k[6] * L[6];
  return {
    x: per((L) => k[3] * L[3]), y: per((L) => k[1] * L[1]), z: per((L) => k[2] * L[2]),
    xx: per((L) => C(L) + k[8] * L[8]), yy: per((L) => C(L) - k[8] * L[8]), zz: per((L) => C(L) + 3 * k[6] * L[6]),
    xy: per((L) => k[4] * L[4]), yz: per((L) => k[5] * L[5]), zx: per((L) => k[7] * L[7]),
  };
}
export function polynomialIrradiance(p, d) {
  const [x, y, z] = d;
  return [0, 1, 2].map((c) => p.x[c] * x + p.y[c] * y + p.z[c] * z + p.xx[c] * x * x + p.yy[c] * y * y + p.zz[c] * z * z +
                               p.xy[c] * x * y + p.yz[c] * y * z + p.zx[c] * z * x);
}
export const mirrorSh = (sh9, mirror) => sh9.map((row) => row.map((v, i) => (SH_MIRROR_NEGATE[mirror].includes(i) ? -v : v)));
