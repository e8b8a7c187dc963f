// Babylon .env: read with Babylon's own parser (GetEnvInfo and its image
// splitter) and our PNG decoder; a writer only for deliberately wrong
// exports (negative controls).
//
// Babylon stores each face image bottom row first: its own writer
// (CreateEnvTextureAsync) puts a cube's t = 1 row at the top of the PNG, and
// its loader reads it back that way (measured with Babylon 9.31 in
// engine_babylon.mjs). Levels here are in GL/SPEC order (row 0 = t = 0).
import { GetEnvInfo, CreateRadianceImageDataArrayBufferViews } from '@babylonjs/core/Misc/environmentTextureTools.pure.js';
import { decodePng, encodePng } from './png.mjs';
import { makeLevel } from './cube.mjs';

const GAMMA = 2.2;   // Babylon's toLinearSpace / toGammaSpace exponent

export function rgbdDecode(r8, g8, b8, a8) {
  const d = a8 / 255;
  return [r8, g8, b8].map((v) => (v / 255) ** GAMMA / d);
}
export function rgbdEncode(rgb) {
  const m = Math.max(rgb[0], rgb[1], rgb[2], 1e-7);
  const D = Math.min(1, Math.max(0, Math.floor(Math.max(255 / m, 1)) / 255));
  const out = rgb.map((v) => Math.round(255 * Math.min(1, Math.max(0, (v * D) ** (1 / GAMMA)))));
  out.push(Math.round(255 * D));
  return out;
}

export function readEnv(bytes) {
  const view = new Uint8Array(bytes.buffer, bytes.byteOffset, bytes.byteLength);
  const info = GetEnvInfo(view);
  if (!info) throw new Error('not a Babylon .env file (GetEnvInfo returned null)');
  const images = CreateRadianceImageDataArrayBufferViews(view, info);
  const pngs = [];
  const levels = images.map((faces) => {
    const decoded = faces.map((f) => decodePng(new Uint8Array(f.buffer, f.byteOffset, f.byteLength)));
    pngs.push(decoded);
    const n = decoded[0].width;
    const lv = makeLevel(n, 3);
    decoded.forEach((img, fi) => {
      if (img.width !== n || img.height !== n || img.channels !== 4 || img.bitDepth !== 8) throw new Error(`.env face ${fi}: ${img.width}x${img.height}, ${img.channels} channels, ${img.bitDepth} bit`);
      for (let j = 0; j < n; j++) for (let i = 0; i < n; i++) {
        const p = ((n - 1 - j) * n + i) * 4;
        lv.faces[fi].set(rgbdDecode(img.data[p], img.data[p + 1], img.data[p + 2], img.data[p + 3]), (j * n + i) * 3);
      }
    });
    return lv;
  });
  return { info, levels, pngs };
}

// levels: SPEC-layout levels (already mirrored as wanted); polynomial: {x, y, z, xx, yy, zz, yz, zx, xy}.
export function packEnv(levels, polynomial, lodGenerationScale = 0.8) {
  const imgs = [];
  for (const lv of levels) for (let f = 0; f < 6; f++) {
    const px = new Uint8Array(lv.n * lv.n * 4);
    for (let j = 0; j < lv.n; j++) for (let i = 0; i < lv.n; i++) {
      const p = j * lv.n + i;
      px.set(rgbdEncode([0, 1, 2].map((k) => lv.faces[f][p * lv.c + k])), 4 * ((lv.n - 1 - j) * lv.n + i));
    }
    imgs.push(encodePng(lv.n, lv.n, 4, px));
  }
  let pos = 0;
  const mipmaps = imgs.map((b) => { const e = { length: b.length, position: pos }; pos += b.length; return e; });
  const json = JSON.stringify({ version: 2, width: levels[0].n, imageType: 'image/png', irradiance: polynomial,
                                specular: { mipmaps, lodGenerationScale } });
  const magic = Buffer.from([0x86, 0x16, 0x87, 0x96, 0xf6, 0xd6, 0x96, 0x36]);
  return Buffer.concat([magic, Buffer.from(json, 'latin1'), Buffer.from([0]), ...imgs]);
}
