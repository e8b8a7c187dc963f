// KTX1 (KTX 1.1) cube RGBA16F writer and reader, from the KTX 1.1
// specification; the harness uses the writer only for deliberately wrong
// exports (negative controls), the reader to check our files.
import { floatToHalf, halfToFloat, makeLevel } from './cube.mjs';

const MAGIC = [0xab, 0x4b, 0x54, 0x58, 0x20, 0x31, 0x31, 0xbb, 0x0d, 0x0a, 0x1a, 0x0a];

export function packKtx1(levels, keyValues = {}) {
  const kv = [];
  for (const [k, v] of Object.entries(keyValues)) {
    const bytes = new TextEncoder().encode(`${k}\0${v}\0`);
    const pad = (4 - (bytes.length % 4)) % 4;
    const b = new Uint8Array(4 + bytes.length + pad);
    new DataView(b.buffer).setUint32(0, bytes.length, true);
    b.set(bytes, 4);
    kv.push(b);
  }
  const kvLen = kv.reduce((a, b) => a + b.length, 0);
  const faceBytes = levels.map((l) => l.n * l.n * 8);
  const total = 64 + kvLen + faceBytes.reduce((a, b) => a + 4 + 6 * b, 0);
  const out = new Uint8Array(total);
  const dv = new DataView(out.buffer);
  out.set(MAGIC, 0);
  const hdr = [0x04030201, 0x140b, 2, 0x1908, 0x881a, 0x1908, levels[0].n, levels[0].n, 0, 0, 6, levels.length, kvLen];
  hdr.forEach((v, i) => dv.setUint32(12 + 4 * i, v, true));
  let o = 64;
  for (const b of kv) { out.set(b, o); o += b.length; }
  levels.forEach((l, m) => {
    dv.setUint32(o, faceBytes[m], true); o += 4;
    for (let f = 0; f < 6; f++) {
      for (let p = 0; p < l.n * l.n; p++) {
        for (let k = 0; k < 3; k++) dv.setUint16(o + (p * 4 + k) * 2, floatToHalf(l.faces[f][p * l.c + k]), true);
        dv.setUint16(o + (p * 4 + 3) * 2, 0x3c00, true);
      }
      o += faceBytes[m];
    }
  });
  return out;
}

// Reads a KTX1 cube (RGBA16F, RGBA32F or R11F_G11F_B10F): header, key/values, levels.
export function readKtx1(bytes) {
  const dv = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
  for (let i = 0; i < 12; i++) if (bytes[i] !== MAGIC[i]) throw new Error('not a KTX 1.1 file');
  if (dv.getUint32(12, true) !== 0x04030201) throw new Error('KTX1: big-endian files are not handled');
  const u = (i) => dv.getUint32(12 + 4 * i, true);
  const h = { glType: u(1), glTypeSize: u(2), glFormat: u(3), glInternalFormat: u(4), glBaseInternalFormat: u(5),
              width: u(6), height: u(7), depth: u(8), arrayElements: u(9), faces: u(10), levels: u(11), kvBytes: u(12) };
  const kv = {};
  let o = 64;
  const end = 64 + h.kvBytes;
  while (o < end) {
    const len = dv.getUint32(o, true);
    const s = bytes.subarray(o + 4, o + 4 + len);
    const z = s.indexOf(0);
    kv[new TextDecoder().decode(s.subarray(0, z))] = new TextDecoder().decode(s.subarray(z + 1, s[len - 1] === 0 ? len - 1 : len));
    o += 4 + len + ((4 - (len % 4)) % 4);
  }
  const levels = [];
  const bpp = { 0x881a: 8, 0x8814: 16, 0x8c3a: 4 }[h.glInternalFormat];
  if (!bpp) throw new Error(`KTX1: internal format 0x${h.glInternalFormat.toString(16)} not handled`);
  for (let m = 0; m < Math.max(1, h.levels); m++) {
    const n = Math.max(1, h.width >> m);
    const imageSize = dv.getUint32(o, true); o += 4;
    if (imageSize !== n * n * bpp) throw new Error(`KTX1 level ${m}: imageSize ${imageSize}, expected ${n * n * bpp}`);
    const lv = makeLevel(n, 3);
    for (let f = 0; f < h.faces; f++) {
      for (let p = 0; p < n * n; p++) {
        for (let k = 0; k < 3; k++) {
          if (bpp === 8) lv.faces[f][p * 3 + k] = halfToFloat(dv.getUint16(o + (p * 4 + k) * 2, true));
          else if (bpp === 16) lv.faces[f][p * 3 + k] = dv.getFloat32(o + (p * 4 + k) * 4, true);
        }
        if (bpp === 4) {
          const w = dv.getUint32(o + p * 4, true);
          const uf = (v, mb) => { const e = v >>> mb, mm = v & ((1 << mb) - 1); return e === 0 ? mm * 2 ** (-14 - mb) : (1 + mm / (1 << mb)) * 2 ** (e - 15); };
          lv.faces[f][p * 3] = uf(w & 0x7ff, 6); lv.faces[f][p * 3 + 1] = uf((w >>> 11) & 0x7ff, 6); lv.faces[f][p * 3 + 2] = uf((w >>> 22) & 0x3ff, 5);
        }
      }
      o += imageSize + ((4 - (imageSize % 4)) % 4);
    }
    levels.push(lv);
  }
  return { header: h, keyValues: kv, levels, bytesRead: o };
}
