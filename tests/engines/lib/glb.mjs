// A glTF binary (GLB) of one UV sphere of radius 1 with one metallic-roughness
// material, for engines that take materials from glTF (Filament's gltfio).
// The pole axis is +Y; a vertex ring passes through +Z (the camera's side).

export function sphereGlb({ segments = 256, rings = 128, baseColor = [1, 1, 1, 1], metallic = 1, roughness = 0 } = {}) {
  const pos = [], nrm = [], idx = [];
  for (let j = 0; j <= rings; j++) {
    const th = (j / rings) * Math.PI;
    for (let i = 0; i <= segments; i++) {
      const ph = (i / segments) * 2 * Math.PI;
      const x = -Math.cos(ph) * Math.sin(th), y = Math.cos(th), z = Math.sin(ph) * Math.sin(th);
      pos.push(x, y, z); nrm.push(x, y, z);
    }
  }
  const row = segments + 1;
  for (let j = 0; j < rings; j++) for (let i = 0; i < segments; i++) {
    const a = j * row + i, b = a + row;
    if (j !== 0) idx.push(a, b, a + 1);
    if (j !== rings - 1) idx.push(a + 1, b, b + 1);
  }
  const P = new Float32Array(pos), N = new Float32Array(nrm), I = new Uint32Array(idx);
  const bin = new Uint8Array(P.byteLength + N.byteLength + I.byteLength);
  bin.set(new Uint8Array(P.buffer), 0);
  bin.set(new Uint8Array(N.buffer), P.byteLength);
  bin.set(new Uint8Array(I.buffer), P.byteLength + N.byteLength);
  const gltf = {
    asset: { version: '2.0', generator: 'iblbake engine tests' },
    scene: 0, scenes: [{ nodes: [0] }], nodes: [{ mesh: 0, name: 'sphere' }],
    meshes: [{ primitives: [{ attributes: { POSITION: 0, NORMAL: 1 }, indices: 2, material: 0 }] }],
    materials: [{ name: 'm', pbrMetallicRoughness: { baseColorFactor: baseColor, metallicFactor: metallic, roughnessFactor: roughness } }],
    buffers: [{ byteLength: bin.byteLength }],
    bufferViews: [
      { buffer: 0, byteOffset: 0, byteLength: P.byteLength, target: 34962 },
      { buffer: 0, byteOffset: P.byteLength, byteLength: N.byteLength, target: 34962 },
      { buffer: 0, byteOffset: P.byteLength + N.byteLength, byteLength: I.byteLength, target: 34963 },
    ],
    accessors: [
      { bufferView: 0, componentType: 5126, count: P.length / 3, type: 'VEC3', min: [-1, -1, -1], max: [1, 1, 1] },
      { bufferView: 1, componentType: 5126, count: N.length / 3, type: 'VEC3' },
      { bufferView: 2, componentType: 5125, count: I.length, type: 'SCALAR' },
    ],
  };
  let json = new TextEncoder().encode(JSON.stringify(gltf));
  const jsonPad = (4 - (json.length % 4)) % 4, binPad = (4 - (bin.length % 4)) % 4;
  const total = 12 + 8 + json.length + jsonPad + 8 + bin.length + binPad;
  const out = new Uint8Array(total);
  const dv = new DataView(out.buffer);
  dv.setUint32(0, 0x46546c67, true); dv.setUint32(4, 2, true); dv.setUint32(8, total, true);
  dv.setUint32(12, json.length + jsonPad, true); dv.setUint32(16, 0x4e4f534a, true);
  out.set(json, 20); out.fill(0x20, 20 + json.length, 20 + json.length + jsonPad);
  const b0 = 20 + json.length + jsonPad;
  dv.setUint32(b0, bin.length + binPad, true); dv.setUint32(b0 + 4, 0x004e4942, true);
  out.set(bin, b0 + 8);
  return out;
}
