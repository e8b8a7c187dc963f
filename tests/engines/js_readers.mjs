// Issue 12's "readers that are not ours": every preset's files read with
// ktx-parse (KTX2, zstd through three.js's decoder), parse-dds and Babylon's
// DDSTools (DDS), Babylon's GetEnvInfo (.env), and checked against the bake's
// EXR crosses (read with three.js's EXRLoader) and against the exact Pre of
// the analytic marker: containers, roughness tables, texels after the
// preset's mirror, where the six-lobe marker lands, SH forms. Every check
// also runs on a deliberately wrong expectation (mirror, table, SH signs)
// and must fail there.
import fs from 'node:fs';
import path from 'node:path';
import { run, fmt } from './lib/harness.mjs';
import { loadBakes } from './lib/data.mjs';
import { readKtx2, readDds } from './lib/readers.mjs';
import { readKtx1 } from './lib/ktx1pack.mjs';
import { readEnv } from './lib/envpack.mjs';
import { readCross } from './lib/exr.mjs';
import { decodePng } from './lib/png.mjs';
import { CURVES, SH_K, mirrorLevel, mirrorDir, mirrorSh, texelDir, sampleLevel, shToPolynomial, normalize } from './lib/cube.mjs';
import { prefiltered, markerSource } from './lib/reference.mjs';
import { classifyLobe } from './lib/checks.mjs';

// ENGINES.md (and what the engine tests measured): the harness's own table.
const ENGINES = {
  three: { mirror: 'x', curve: 'filament', sh: 'sh9' },
  khronos: { mirror: 'none', curve: 'linear', sh: 'sh9' },
  bevy: { mirror: 'z', curve: 'linear', sh: null },
  filament: { mirror: 'none', curve: 'filament', sh: 'filament' },
  babylon: { mirror: 'x', curve: 'babylon', sh: 'babylon' },
  unity: { mirror: 'x', curve: 'unity', sh: null },
};
const WRONG_MIRROR = { none: 'x', x: 'none', z: 'none' };
const WRONG_CURVE = { filament: 'linear', linear: 'filament', babylon: 'linear', unity: 'linear' };

const tableR = (curve, m, T, N0) => CURVES[curve].r(m, T, N0);

// Largest texel difference allowed by a format's rounding, for channel k of
// the expected texel (r, g, b).
const ROUNDING = {
  rgba16f: () => 0,                                                      // same half as the EXR: bit-exact
  rgba32f: (r, g, b, k, x) => Math.abs(x) * 2 ** -11 + 1e-7,            // the EXR holds the half of it
  e5b9g9r9: (r, g, b) => Math.max(r, g, b) * 2 ** -8 + 1e-7,            // shared exponent, 9-bit mantissas
  r11g11b10f: (r, g, b, k, x) => Math.abs(x) * 2 ** (k === 2 ? -5 : -6) + 1e-6,
  rgbd: (r, g, b, k, x) => 0.01 * Math.max(r, g, b) + 0.01 * Math.abs(x) + 1e-4,   // 8-bit gamma 2.2 and D
};

function compareLevels(got, want, format) {
  let worst = 0, maxAbs = 0;
  const tol = ROUNDING[format];
  for (let f = 0; f < 6; f++) {
    const A = got.faces[f], B = want.faces[f];
    for (let o = 0; o < A.length; o += 3) {
      const r = B[o], g = B[o + 1], b = B[o + 2];
      for (let k = 0; k < 3; k++) {
        const d = Math.abs(A[o + k] - B[o + k]);
        if (d > maxAbs) maxAbs = d;
        const t = tol(r, g, b, k, B[o + k]);
        const q = t > 0 ? d / t : (d > 0 ? Infinity : 0);
        if (q > worst) worst = q;
      }
    }
  }
  return { pass: worst <= 1, worst, maxAbs };
}

await run('js_readers', async (s) => {
  const bakes = loadBakes(s.p.data);
  const marker = bakes.marker;
  const man = marker.manifest;
  const desc = marker.sources;
  const L = markerSource(desc);
  // SPEC's chain of a bake, read once: a preset's twin levels are compared with
  // the crosses of the same bake (levels integrated together with other
  // presets' levels may differ from another bake's within the integration error).
  const crossCache = new Map();
  const specLevelsOf = (b) => {
    if (!crossCache.has(b.dir))
      crossCache.set(b.dir, b.manifest.specular.map((l, m) => ({ level: b.crossLevel(m), n: l.face_size, r: l.roughness })));
    return crossCache.get(b.dir);
  };
  const irradiance = readCross(path.join(marker.dir, man.irradiance.file));
  const sh9 = man.sh9;
  const memo = new Map();
  const exactPre = (n, r, f, i, j) => {
    const key = `${n}/${r}/${f}/${i}/${j}`;
    if (!memo.has(key)) memo.set(key, prefiltered(L, texelDir(f, i, j, n), r, { nu: 32, nphi: 64 }));
    return memo.get(key);
  };
  // Sample texels of an n x n grid (SPEC space): face centres and a fixed spread.
  const samples = (n) => {
    const out = [];
    for (let f = 0; f < 6; f++) {
      out.push([f, Math.floor(n / 2), Math.floor(n / 2)]);
      out.push([f, Math.floor(n / 5), Math.floor((3 * n) / 4)]);
    }
    return out;
  };

  const formatsBake = loadBakes(s.p.data).other('marker_formats');
  const cases = [];
  for (const [name, bake] of [['three', marker], ['khronos', marker], ['bevy', marker], ['filament', marker], ['babylon', marker], ['unity', marker],
                              ['khronos:rgba32f', formatsBake], ['bevy:rgba16f', formatsBake], ['filament:r11g11b10f', formatsBake], ['unity:rgba32f', formatsBake]]) {
    const engine = name.split(':')[0];
    const pre = bake.manifest.presets?.[engine];
    if (!pre) throw new Error(`${bake.dir}: no presets.${engine} in the manifest`);
    cases.push({ name, engine, pre, bake, dir: path.join(bake.dir, pre.dir) });
  }

  for (const { name, engine, pre, bake, dir } of cases) {
    const E = ENGINES[engine];
    const file = path.join(dir, pre.files.specular || pre.files.environment);
    const bytes = new Uint8Array(fs.readFileSync(file));
    let levels, format, facts;
    // 1. The container, read by another library.
    if (pre.container === 'ktx2') {
      const k = await readKtx2(bytes);
      const c = k.container, dfd = c.dataFormatDescriptor[0];
      levels = k.levels; format = k.format;
      facts = {
        pass: c.faceCount === 6 && c.layerCount === 0 && c.pixelDepth === 0 && c.pixelWidth === pre.specular[0].face_size &&
              c.pixelHeight === c.pixelWidth && c.levels.length === pre.specular.length && format === pre.format &&
              c.supercompressionScheme === (pre.supercompression === 'zstd' ? 2 : 0) && c.keyValue.KTXorientation?.replace(/\0$/, '') === 'rd' &&
              dfd.colorModel === 1 && dfd.colorPrimaries === 1 && dfd.transferFunction === 1 &&
              c.typeSize === { rgba16f: 2, rgba32f: 4, e5b9g9r9: 4 }[format],
        message: `ktx-parse: vkFormat ${c.vkFormat} (${format}), typeSize ${c.typeSize}, ${c.pixelWidth} px, ${c.levels.length} levels, faces ${c.faceCount}, ` +
                 `layers ${c.layerCount}, supercompression ${c.supercompressionScheme}, KTXorientation ${JSON.stringify(c.keyValue.KTXorientation)}, ` +
                 `DFD model ${dfd.colorModel} primaries ${dfd.colorPrimaries} transfer ${dfd.transferFunction}`,
      };
    } else if (pre.container === 'dds') {
      const d = readDds(bytes);
      levels = d.levels; format = d.format;
      facts = {
        pass: d.info.isCube && d.info.width === pre.specular[0].face_size && d.info.mipmapCount === pre.specular.length && format === pre.format,
        message: `${d.parsed ? 'parse-dds + ' : ''}Babylon DDSTools: DXGI ${d.info.dxgiFormat} (${format}), ${d.info.width} px, ${d.info.mipmapCount} levels, cube ${d.info.isCube}` +
                 (d.parsed ? `, parse-dds: ${d.parsed.format}, ${d.parsed.images.length} images` : ''),
      };
    } else if (pre.container === 'ktx1') {
      const k = readKtx1(bytes);
      levels = k.levels;
      format = { 0x881a: 'rgba16f', 0x8814: 'rgba32f', 0x8c3a: 'r11g11b10f' }[k.header.glInternalFormat];
      facts = {
        pass: k.header.faces === 6 && k.header.width === pre.specular[0].face_size && k.header.levels === pre.specular.length &&
              format === pre.format && k.bytesRead === bytes.byteLength && typeof k.keyValues.sh === 'string',
        message: `KTX1: glInternalFormat 0x${k.header.glInternalFormat.toString(16)} (${format}), glType 0x${k.header.glType.toString(16)}, ` +
                 `${k.header.width} px, ${k.header.levels} levels, ${k.header.faces} faces, keys ${Object.keys(k.keyValues).join(', ')}`,
      };
      facts.sh = k.keyValues.sh;
    } else if (pre.container === 'env') {
      const e = readEnv(bytes);
      levels = e.levels; format = 'rgbd';
      facts = {
        pass: e.info.version === 2 && e.info.width === pre.specular[0].face_size && e.levels.length === pre.specular.length &&
              e.info.specular.lodGenerationScale === 0.8 && e.pngs.every((lv) => lv.every((p) => p.chunks.every((t) => ['IHDR', 'IDAT', 'IEND'].includes(t)))),
        message: `Babylon GetEnvInfo: version ${e.info.version}, width ${e.info.width}, ${e.levels.length} levels, lodGenerationScale ${e.info.specular.lodGenerationScale}, ` +
                 `PNG chunks ${[...new Set(e.pngs.flat().flatMap((p) => p.chunks))].join('/')}`,
      };
      facts.polynomial = e.info.irradiance;
    }
    s.expect(`${name}: container read by another library`, facts);

    // 2. Roughness table against the curve's formula.
    const T = pre.specular.length - 1, N0 = pre.specular[0].face_size;
    const tableErr = (curve) => Math.max(...pre.specular.map((l, m) => Math.abs(l.roughness - tableR(curve, m, T, N0))));
    s.expect(`${name}: roughness table = ${E.curve} curve`, { pass: pre.mirror === E.mirror && pre.curve === E.curve && tableErr(E.curve) < 1e-6,
      message: `manifest mirror ${pre.mirror}, curve ${pre.curve}; largest |r_m - formula| ${fmt(tableErr(E.curve))}` });
    s.expectFail(`${name}: roughness table against the ${WRONG_CURVE[E.curve]} curve`, { pass: tableErr(WRONG_CURVE[E.curve]) < 1e-6,
      message: `largest |r_m - ${WRONG_CURVE[E.curve]}| ${fmt(tableErr(WRONG_CURVE[E.curve]))}` });

    // 3. Levels SPEC's chain holds too (same size and roughness): texels = the
    //    EXR cross after the mirror, within the format's rounding.
    const twins = [], specLevels = specLevelsOf(bake);
    pre.specular.forEach((l, m) => {
      const sm = specLevels.findIndex((x) => x.n === l.face_size && Math.abs(x.r - l.roughness) < 1e-9);
      if (sm >= 0) twins.push([m, sm]);
    });
    const cmp = (mirror) => twins.map(([m, sm]) => ({ m, sm, ...compareLevels(levels[m], mirrorLevel(specLevels[sm].level, mirror), format) }));
    const good = cmp(E.mirror);
    s.expect(`${name}: levels ${twins.map((t) => t[0]).join(', ')} = SPEC's EXR crosses after the ${E.mirror} mirror`, {
      pass: twins.length > 0 && good.every((x) => x.pass),
      message: good.map((x) => `level ${x.m}: largest |diff| ${fmt(x.maxAbs)} (${fmt(x.worst)} of the ${format} rounding)`).join('; '),
    });
    const bad = cmp(WRONG_MIRROR[E.mirror]);
    s.expectFail(`${name}: the same against the ${WRONG_MIRROR[E.mirror]} mirror`, { pass: bad.every((x) => x.pass),
      message: bad.map((x) => `level ${x.m}: ${fmt(x.worst)} of the rounding`).join('; ') });

    // 4. Every level against the exact Pre of the marker at its roughness.
    const refErr = (rOf, few = false) => {
      let worst = 0;
      const per = [];
      pre.specular.forEach((l, m) => {
        let lw = 0;
        // (the negative control needs only the face centres of the levels whose roughness differs)
        if (few && Math.abs(rOf(m) - l.roughness) < 1e-9) { per.push(0); return; }
        for (const [f, i, j] of samples(l.face_size).filter((x, k) => !few || k % 2 === 0)) {
          const want = exactPre(l.face_size, rOf(m), f, i, j);
          // the SPEC texel (f, i, j) sits in the file at mirror(direction): a texel centre of the same grid
          const d = mirrorDir(E.mirror, texelDir(f, i, j, l.face_size));
          const got = sampleLevel(levels[m], d);
          const e = Math.max(...[0, 1, 2].map((k) => Math.abs(got[k] - want[k]))) / Math.max(1e-6, (want[0] + want[1] + want[2]) / 3);
          lw = Math.max(lw, e);
        }
        per.push(lw);
        worst = Math.max(worst, lw);
      });
      return { worst, per };
    };
    const refTol = format === 'rgbd' || format === 'r11g11b10f' ? 0.05 : 0.03;
    const ref = refErr((m) => pre.specular[m].roughness);
    s.expect(`${name}: every level = exact Pre at its r_m (marker, ${samples(8).length} texels a level)`, { pass: ref.worst <= refTol,
      message: `largest relative error per level ${ref.per.map((e) => fmt(e, 3)).join(', ')} (tol ${refTol})` });
    s.metric(`${name}_level_error_vs_exact`, ref.per);
    const refWrong = refErr((m) => Math.min(1, tableR(WRONG_CURVE[E.curve], m, T, N0)), true);
    s.expectFail(`${name}: levels against Pre at the ${WRONG_CURVE[E.curve]} curve's r_m`, { pass: refWrong.worst <= refTol,
      message: `largest relative error ${fmt(refWrong.worst)}` });

    // 5. The six-lobe marker lands where ENGINES.md says (level 0).
    const lands = (mirror) => {
      const shown = desc.lobes.map((lobe) => classifyLobe(sampleLevel(levels[0], normalize(mirrorDir(mirror, lobe.axis))), desc));
      return { pass: shown.every((g, i) => g === desc.lobes[i].name), message: desc.lobes.map((l, i) => `${l.name} at ${mirror === 'none' ? '' : mirror + '-mirrored '}${l.name}: ${shown[i]}`).join(', ') };
    };
    s.expect(`${name}: the marker's lobes land at their ${E.mirror}-mirrored axes`, lands(E.mirror));
    s.expectFail(`${name}: the marker's lobes at the ${WRONG_MIRROR[E.mirror]}-mirrored axes`, lands(WRONG_MIRROR[E.mirror]));

    // 6. SH in the engine's form, signs after the engine's mirror.
    if (E.sh) {
      const flat = (sh) => Array.from({ length: 27 }, (_, i) => sh[i % 3][Math.floor(i / 3)]);
      let got, want, wrong;
      if (E.sh === 'sh9') {
        got = pre.sh.coefficients; want = flat(sh9); wrong = flat(mirrorSh(sh9, 'x'));
      } else if (E.sh === 'filament') {
        got = facts.sh.trim().split(/\s+/).map(Number);
        const k = (sh) => flat(sh.map((row) => row.map((v, i) => v * SH_K[i])));
        want = k(sh9); wrong = k(mirrorSh(sh9, 'x'));
      } else {
        const P = (p) => ['x', 'y', 'z', 'xx', 'yy', 'zz', 'xy', 'yz', 'zx'].flatMap((key) => p[key]);
        // What Babylon renders as Irr (engine_babylon measures it): sh9 x-mirrored, bands 1 and 2 x 2/3 and 1/4.
        const scaled = (sh) => sh.map((row) => row.map((v, i) => v * (i === 0 ? 1 : i < 4 ? 2 / 3 : 1 / 4)));
        got = P(facts.polynomial); want = P(shToPolynomial(scaled(mirrorSh(sh9, 'x')))); wrong = P(shToPolynomial(scaled(sh9)));
      }
      const d = (a, b) => Math.max(...a.map((v, i) => Math.abs(v - b[i])));
      s.expect(`${name}: SH (${E.sh} form, ${E.sh === 'babylon' ? 'x' : 'no'} mirror)`, { pass: got.length === 27 && d(got, want) < 1e-5,
        message: `largest |difference| ${fmt(d(got, want))}` });
      s.expectFail(`${name}: SH against ${E.sh === 'babylon' ? 'unmirrored' : 'x-mirrored'} signs`, { pass: d(got, wrong) < 1e-5, message: `largest |difference| ${fmt(d(got, wrong))}` });
    }

    // 7. Diffuse cubes (khronos, bevy): the irradiance cross after the mirror.
    if (pre.files.diffuse) {
      const dk = await readKtx2(new Uint8Array(fs.readFileSync(path.join(dir, pre.files.diffuse))));
      const r = compareLevels(dk.levels[0], mirrorLevel(irradiance, E.mirror), dk.format);
      s.expect(`${name}: diffuse.ktx2 = irradiance.exr after the ${E.mirror} mirror`, { pass: dk.levels.length === 1 && r.pass,
        message: `${dk.format}, ${dk.levels[0].n} px, largest |diff| ${fmt(r.maxAbs)} (${fmt(r.worst)} of the rounding)` });
      const rw = compareLevels(dk.levels[0], mirrorLevel(irradiance, WRONG_MIRROR[E.mirror]), dk.format);
      s.expectFail(`${name}: diffuse.ktx2 against the ${WRONG_MIRROR[E.mirror]} mirror`, { pass: rw.pass, message: `${fmt(rw.worst)} of the rounding` });
    }
    // 8. The khronos LUT: at roughness ~0 the integrals are A = 1 - (1 - v)^5, B = (1 - v)^5.
    if (pre.files.lut) {
      const png = decodePng(new Uint8Array(fs.readFileSync(path.join(dir, pre.files.lut))));
      const N = png.width;
      let worst = 0, worstSwap = 0;
      for (let i = 0; i < N; i++) {
        const v = (i + 0.5) / N, A = 1 - (1 - v) ** 5, B = (1 - v) ** 5;
        const o = i * png.channels, a = png.data[o] / 65535, b = png.data[o + 1] / 65535;
        worst = Math.max(worst, Math.abs(a - A), Math.abs(b - B));
        worstSwap = Math.max(worstSwap, Math.abs(b - A), Math.abs(a - B));
      }
      s.expect(`${name}: brdf_lut.png row 0 (r ~ 0) holds A = 1 - (1 - v)^5, B = (1 - v)^5`, { pass: png.bitDepth === 16 && png.height === N && worst < 2e-3,
        message: `${N} x ${png.height}, ${png.bitDepth}-bit, ${png.channels} channels, largest difference ${fmt(worst)}` });
      s.expectFail(`${name}: brdf_lut.png row 0 with A and B swapped`, { pass: worstSwap < 2e-3, message: `largest difference ${fmt(worstSwap)}` });
    }
  }
});
