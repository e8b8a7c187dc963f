// Packs cube levels into a KTX2 RGBA16F file with ktx-parse's writer. The
// harness uses it only to make deliberately WRONG exports for the negative
// controls (and to repack an export with one thing changed); our own files
// come from iblbake's writer.
import fs from 'node:fs';
import {
  createDefaultContainer, read, write, VK_FORMAT_R16G16B16A16_SFLOAT, KHR_DF_MODEL_RGBSDA,
  KHR_DF_TRANSFER_LINEAR, KHR_DF_PRIMARIES_BT709, KHR_DF_SAMPLE_DATATYPE_FLOAT, KHR_DF_SAMPLE_DATATYPE_SIGNED,
} from 'ktx-parse';
import { floatToHalf, halfToFloat, makeLevel } from './cube.mjs';

export function packKtx2(levels) {
  const c = createDefaultContainer();
  c.vkFormat = VK_FORMAT_R16G16B16A16_SFLOAT;
  c.typeSize = 2;
  c.pixelWidth = c.pixelHeight = levels[0].n;
  c.pixelDepth = 0;
  c.layerCount = 0;
  c.faceCount = 6;
  c.levelCount = levels.length;
  c.supercompressionScheme = 0;
  const dfd = c.dataFormatDescriptor[0];
  dfd.colorModel = KHR_DF_MODEL_RGBSDA;
  dfd.colorPrimaries = KHR_DF_PRIMARIES_BT709;
  dfd.transferFunction = KHR_DF_TRANSFER_LINEAR;
  dfd.texelBlockDimension = [0, 0, 0, 0];
  dfd.bytesPlane = [8, 0, 0, 0, 0, 0, 0, 0];
  dfd.samples = [0, 1, 2, 15].map((ch, k) => ({
    bitOffset: 16 * k, bitLength: 15, channelType: ch | KHR_DF_SAMPLE_DATATYPE_FLOAT | KHR_DF_SAMPLE_DATATYPE_SIGNED,
    samplePosition: [0, 0, 0, 0], sampleLower: 0xbf800000, sampleUpper: 0x3f800000,
  }));
  c.keyValue = { KTXorientation: 'rd', KTXwriter: 'iblbake engine tests (negative control)' };
  c.levels = levels.map((lv) => {
    const n = lv.n, data = new Uint16Array(6 * n * n * 4);
    for (let f = 0; f < 6; f++) for (let p = 0; p < n * n; p++) {
      for (let k = 0; k < 3; k++) data[(f * n * n + p) * 4 + k] = floatToHalf(lv.faces[f][p * lv.c + k]);
      data[(f * n * n + p) * 4 + 3] = 0x3c00;
    }
    const bytes = new Uint8Array(data.buffer);
    return { levelData: bytes, uncompressedByteLength: bytes.byteLength };
  });
  return write(c);
}

// RGBA16F / RGBA32F KTX2 cube -> levels (RGB), read with ktx-parse.
export function readKtx2Levels(bytes) {
  const c = read(bytes);
  if (c.faceCount !== 6) throw new Error(`not a cube: faceCount ${c.faceCount}`);
  return { container: c, levels: c.levels.map((lv, m) => levelFromBytes(c, lv.levelData, m)) };
}

function levelFromBytes(c, bytes, m) {
  const n = Math.max(1, c.pixelWidth >> m);
  const out = makeLevel(n, 3);
  const buf = bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.byteLength);
  const half = c.vkFormat === 97, flt = c.vkFormat === 109;
  if (!half && !flt) throw new Error(`readKtx2Levels: vkFormat ${c.vkFormat} not handled here`);
  const arr = half ? new Uint16Array(buf) : new Float32Array(buf);
  for (let f = 0; f < 6; f++) for (let p = 0; p < n * n; p++) for (let k = 0; k < 3; k++) {
    const v = arr[(f * n * n + p) * 4 + k];
    out.faces[f][p * 3 + k] = half ? halfToFloat(v) : v;
  }
  return out;
}

export const readKtx2File = (file) => readKtx2Levels(new Uint8Array(fs.readFileSync(file)));
