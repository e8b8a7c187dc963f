// Reads our containers with readers that are not ours: ktx-parse (KTX2, with
// three.js's zstd decoder), parse-dds (DDS RGBA32F) and Babylon's DDSTools
// (DDS RGBA16F), Babylon's .env parser. Every reader returns cube levels in
// GL/SPEC face order (row 0 = t = 0), file orientation (mirror not undone).
import { read as readKtx2Container } from 'ktx-parse';
import parseDDS from 'parse-dds';
import { DDSTools } from '@babylonjs/core/Misc/dds.pure.js';
import { ZSTDDecoder } from 'three/examples/jsm/libs/zstddec.module.js';
import { makeLevel, halfToFloat, decodeE5B9G9R9 } from './cube.mjs';

let zstd = null;
async function zstdDecoder() {
  if (!zstd) { zstd = new ZSTDDecoder(); await zstd.init(); }
  return zstd;
}

const VK = { 97: 'rgba16f', 109: 'rgba32f', 123: 'e5b9g9r9' };

function levelFrom(n, bytes, format) {
  const lv = makeLevel(n, 3);
  const dv = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
  const texel = { rgba16f: 8, rgba32f: 16, e5b9g9r9: 4 }[format];
  if (bytes.byteLength !== 6 * n * n * texel) throw new Error(`${format} level of ${n} px: ${bytes.byteLength} bytes, expected ${6 * n * n * texel}`);
  for (let f = 0; f < 6; f++) for (let p = 0; p < n * n; p++) {
    const o = (f * n * n + p) * texel;
    let c;
    if (format === 'rgba16f') c = [0, 1, 2].map((k) => halfToFloat(dv.getUint16(o + 2 * k, true)));
    else if (format === 'rgba32f') c = [0, 1, 2].map((k) => dv.getFloat32(o + 4 * k, true));
    else c = decodeE5B9G9R9(dv.getUint32(o, true));
    lv.faces[f].set(c, p * 3);
  }
  return lv;
}

export async function readKtx2(bytes) {
  const c = readKtx2Container(bytes);
  const format = VK[c.vkFormat];
  if (!format) throw new Error(`KTX2 vkFormat ${c.vkFormat} not handled`);
  const levels = [];
  for (let m = 0; m < c.levels.length; m++) {
    let data = c.levels[m].levelData;
    if (c.supercompressionScheme === 2) data = (await zstdDecoder()).decode(data, Number(c.levels[m].uncompressedByteLength));
    else if (c.supercompressionScheme !== 0) throw new Error(`KTX2 supercompression ${c.supercompressionScheme} not handled`);
    levels.push(levelFrom(Math.max(1, c.pixelWidth >> m), data, format));
  }
  return { container: c, format, levels };
}

// DDS cube, face-major (each face with its whole mip chain): RGBA32F through
// parse-dds, RGBA16F (DXGI 10) through Babylon's DDSTools header parser.
export function readDds(bytes) {
  const info = DDSTools.GetDDSInfo(bytes);
  if (!info.isCube) throw new Error('DDS is not a cube');
  const n0 = info.width, M = info.mipmapCount;
  const faceTexel = { 10: 8, 2: 16 }[info.dxgiFormat];
  if (!faceTexel) throw new Error(`DDS DXGI format ${info.dxgiFormat} not handled`);
  const format = info.dxgiFormat === 10 ? 'rgba16f' : 'rgba32f';
  const levels = Array.from({ length: M }, (_, m) => makeLevel(Math.max(1, n0 >> m), 3));
  let parsed = null;
  if (format === 'rgba32f') parsed = parseDDS(bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.byteLength));
  const dv = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
  let o = 4 + 124 + 20;
  for (let f = 0; f < 6; f++) for (let m = 0; m < M; m++) {
    const n = Math.max(1, n0 >> m);
    if (parsed) {
      const img = parsed.images[f * M + m];
      if (img.offset !== o || img.shape[0] !== n) throw new Error(`parse-dds places face ${f} level ${m} at ${img.offset} (${img.shape}), we at ${o} (${n})`);
    }
    for (let p = 0; p < n * n; p++) {
      const c = format === 'rgba16f'
        ? [0, 1, 2].map((k) => halfToFloat(dv.getUint16(o + p * 8 + 2 * k, true)))
        : [0, 1, 2].map((k) => dv.getFloat32(o + p * 16 + 4 * k, true));
      levels[m].faces[f].set(c, p * 3);
    }
    o += n * n * faceTexel;
  }
  if (o !== bytes.byteLength) throw new Error(`DDS: ${bytes.byteLength - o} bytes after the last face`);
  return { info, parsed, format, levels };
}
