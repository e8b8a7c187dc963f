// Filament (WASM, npm `filament`) renders the `filament` preset (KTX1 with
// the `sh` key, no mirror, Filament curve) loaded with createIblFromKtx1, on
// glTF spheres through gltfio's ubershaders: orientation, exact values per
// level, diffuse from the SH, negative controls, contact sheet.
import fs from 'node:fs';
import path from 'node:path';
import { run, b64ToF32, fmt } from './lib/harness.mjs';
import { normalize, mirrorLevel, sampleLod, CURVES, SH_K, SH_MIRROR_NEGATE } from './lib/cube.mjs';
import { readKtx1, packKtx1 } from './lib/ktx1pack.mjs';
import { reflect, mix, pixelNormal, rgbAt, writeSheet, relDiff } from './lib/sphere.mjs';
import { orientationCheck, valueCheck } from './lib/checks.mjs';
import { chainTruth, markerSource, smoothIrradiance } from './lib/reference.mjs';
import { sphereGlb } from './lib/glb.mjs';
import { loadBakes, expectedLevels } from './lib/data.mjs';

const S = 129;
const ENGINE_MIRROR = 'none';        // ENGINES.md: Filament samples its cube at (x, y, z)
const V = [0, 0, 1];
// Filament clamps perceptual roughness to MIN_PERCEPTUAL_ROUGHNESS: 0.089 on
// mobile targets (the web build's materials), 0.045 on desktop.
const MIN_PR = 0.089;
// Half-float drawing buffer (5e-4) and Filament's mobile shaders (mediump
// directions: level 0's sharp lobes move by a fraction of a texel off-centre).
const TOL = { centre: 2e-3, p99: 2e-2 };

// Filament's prefiltered specular for F0 = 1: E * energyCompensation = 1, so
// the pixel is Pre at the dominant direction mix(R, N, roughness^2), lod on
// the Filament curve.
function filamentMetal(levels, r, N) {
  const T = levels.length - 1;
  const pr = Math.min(1, Math.max(r, MIN_PR));
  const R = mix(reflect(V, N), N, pr ** 4);
  return sampleLod(levels, R, CURVES.filament.lod(pr, T));
}

await run('filament', async (s) => {
  const bakes = loadBakes(s.p.data);
  const marker = bakes.marker, smooth = bakes.smooth;
  const pre = marker.manifest.presets?.filament;
  if (!pre) throw new Error('marker bake has no presets.filament in its manifest');
  const T = pre.specular.length - 1;
  const tableErr = Math.max(...pre.specular.map((l, m) => Math.abs(l.roughness - CURVES.filament.r(m, T))));
  s.expect('manifest: no mirror, Filament curve', {
    pass: pre.mirror === ENGINE_MIRROR && pre.curve === 'filament' && tableErr < 1e-6,
    message: `mirror ${pre.mirror}, curve ${pre.curve}, ${pre.specular.length} levels ${pre.specular.map((l) => l.face_size).join('/')}, ` +
             `largest |r_m - (1 - sqrt(1 - m/T))| ${fmt(tableErr)}`,
  });

  const file = path.join(marker.dir, pre.dir, pre.files.specular);
  const ktx = readKtx1(new Uint8Array(fs.readFileSync(file)));
  const fileSpec = ktx.levels.map((l) => mirrorLevel(l, ENGINE_MIRROR));
  const specLevels = expectedLevels(marker, pre, fileSpec);
  const roughness = pre.specular.map((l) => l.roughness);

  // Deliberately wrong exports.
  const wrongDir = path.join(s.p.data, 'wrong');
  fs.mkdirSync(wrongDir, { recursive: true });
  const xMirrored = path.join(wrongDir, 'filament_xmirror.ktx');
  fs.writeFileSync(xMirrored, packKtx1(fileSpec.map((l) => mirrorLevel(l, 'x')), { sh: ktx.keyValues.sh }));
  const linear = path.join(wrongDir, 'filament_linear.ktx');
  fs.writeFileSync(linear, packKtx1(bakes.markerLinear(T + 1), { sh: ktx.keyValues.sh }));

  const glb = path.join(wrongDir, '..', 'sphere.glb');
  fs.writeFileSync(glb, sphereGlb());

  const page = await s.start('filament.html');
  const info = await page.evaluate((n) => iblTest.init(n), S);
  s.log(`Filament ${JSON.stringify(info)}`);
  await page.evaluate((u) => iblTest.setSphere(u), s.dataUrl(glb));
  const setKtx = (f) => page.evaluate((u) => iblTest.setIblKtx1(u), s.dataUrl(f));
  const render = async (o) => b64ToF32(await page.evaluate((x) => iblTest.render(x), o));

  const loaded = await setKtx(file);
  const shFile = ktx.keyValues.sh ? ktx.keyValues.sh.trim().split(/\s+/).map(Number) : [];
  s.expect('load: createIblFromKtx1 reads the chain and the sh key', {
    pass: loaded.sh && loaded.sh.length === 27 && shFile.length === 27 && loaded.sh.every((v, i) => Math.abs(v - shFile[i]) <= 1e-6 * Math.max(1, Math.abs(v))),
    message: `${ktx.levels.length} levels, sh key ${shFile.length} floats, engine holds ${loaded.sh ? loaded.sh.length : 0}`,
  });

  // 1. Orientation.
  const desc = marker.sources;
  const lookup = (r) => (N) => normalize(mix(reflect(V, N), N, Math.max(r, MIN_PR) ** 4));
  s.expect('orientation: mirror sphere shows each lobe where it belongs', orientationCheck(await render({ roughness: 0 }), S, desc, lookup(0)));

  // 2. Exact values.
  const ours = [], rows = [];
  const chain = pre.specular.map((l) => ({ n: l.face_size, r: l.roughness }));
  const memo = new Map();
  for (let m = 0; m <= T; m++) {
    const px = await render({ roughness: roughness[m], specularAA: false });
    ours.push(await render({ roughness: roughness[m] }));
    const r = valueCheck(px, S, (x, y, N) => filamentMetal(specLevels, roughness[m], N), { centreTol: TOL.centre, p99Tol: TOL.p99, label: `r ${fmt(roughness[m], 3)}: ` });
    s.expect(`exact values, level ${m} (r = ${fmt(roughness[m], 3)})`, r);
    // Against the same chain with exact texels (Filament's own filter, cmgen, is not in the npm package).
    const pr = Math.max(roughness[m], MIN_PR);
    const truth = chainTruth(markerSource(desc), chain, [0, 0, 1], CURVES.filament.lod(pr, T), memo);
    rows.push({ level: m, roughness: roughness[m], centre: r.metrics.centre, p99: r.metrics.p99,
                centre_vs_exact: relDiff(r.metrics.centreGot, truth) });
    s.log(`level ${m}: centre pixel vs the chain with exact texels ${fmt(rows[m].centre_vs_exact)}`);
  }
  s.metric('exact_values', rows);

  // 3. Diffuse from the sh key under the smooth source. Filament weights SH
  //    irradiance by the material's (1 - E): three renders with SH = ours,
  //    0 and a unit constant give Irr = (ours - zero) / (unit - zero) per pixel.
  const dPre = smooth.manifest.presets.filament;
  await setKtx(path.join(smooth.dir, dPre.dir, dPre.files.specular));
  const matte = { roughness: 1, metallic: 0 };
  const a = await render(matte);
  await page.evaluate(() => iblTest.setSh(new Array(27).fill(0)));
  const z = await render(matte);
  const unit = new Array(27).fill(0); unit[0] = unit[1] = unit[2] = 1;
  await page.evaluate((u) => iblTest.setSh(u), unit);
  const u1 = await render(matte);
  const ratio = (p) => { const out = new Float32Array(p.length); for (let i = 0; i < p.length; i += 4) for (let k = 0; k < 3; k++) out[i + k] = (p[i + k] - z[i + k]) / (u1[i + k] - z[i + k]); return out; };
  const exactIrr = (x, y, N) => smoothIrradiance(smooth.sources, N);
  s.expect('diffuse: irradiance from the sh key = Irr(N)', valueCheck(ratio(a), S, exactIrr, { centreTol: 3e-3, p99Tol: 4e-3, minNV: 0.05 }));
  const shWrong = dPre.sh.coefficients.map((v, i) => (SH_MIRROR_NEGATE.x.includes(Math.floor(i / 3)) ? -v : v));
  await page.evaluate((u) => iblTest.setSh(u), shWrong);
  s.expectFail('sh with x-mirrored signs', valueCheck(ratio(await render(matte)), S, exactIrr, { centreTol: 3e-3, p99Tol: 4e-3, minNV: 0.05 }));
  const shUnscaled = dPre.sh.coefficients.map((v, i) => v / SH_K[Math.floor(i / 3)]);
  await page.evaluate((u) => iblTest.setSh(u), shUnscaled);
  s.expectFail('sh without the k pre-scaling', valueCheck(ratio(await render(matte)), S, exactIrr, { centreTol: 3e-3, p99Tol: 4e-3, minNV: 0.05 }));

  // 4. Negative controls on the specular chain.
  await setKtx(xMirrored);
  s.expectFail('orientation on an x-mirrored export', orientationCheck(await render({ roughness: 0 }), S, desc, lookup(0)));
  await setKtx(linear);
  let fails = 0;
  const msgs = [];
  for (let m = 1; m < T; m++) {
    const r = valueCheck(await render({ roughness: roughness[m], specularAA: false }), S, (x, y, N) => filamentMetal(specLevels, roughness[m], N), { centreTol: TOL.centre, p99Tol: TOL.p99 });
    if (!r.pass) fails++;
    msgs.push(`level ${m}: centre ${fmt(r.metrics.centre)}`);
  }
  s.expectFail('exact values on an export with linear r_m', { pass: fails === 0, message: `${fails} of ${T - 1} inner levels fail (${msgs.join(', ')})` });

  const sheet = writeSheet(path.join(s.p.out, 'filament_sheet.png'), [ours], S);
  console.log(`contact sheet: ${sheet} (iblbake filament preset in Filament; r = ${roughness.map((r) => fmt(r, 3)).join(', ')}; Filament's own filter, cmgen, is not in the npm package)`);
});
