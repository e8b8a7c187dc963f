// Reads EXR crosses with three.js's EXRLoader (not our writer's code).
import fs from 'node:fs';
import { FloatType } from 'three';
import { EXRLoader } from 'three/examples/jsm/loaders/EXRLoader.js';
import { crossToLevel } from './cube.mjs';

export function readExr(file) {
  const loader = new EXRLoader();
  loader.setDataType(FloatType);
  const buf = fs.readFileSync(file);
  const r = loader.parse(buf.buffer.slice(buf.byteOffset, buf.byteOffset + buf.byteLength));
  const { width, height, data } = r;
  const channels = data.length / (width * height);
  // EXRLoader returns rows bottom-up (WebGL's flipY convention): turn them top-down.
  const out = new Float32Array(data.length);
  const row = width * channels;
  for (let y = 0; y < height; y++) out.set(data.subarray((height - 1 - y) * row, (height - y) * row), y * row);
  return { width, height, channels, data: out };
}

export const readCross = (file) => crossToLevel(readExr(file));
