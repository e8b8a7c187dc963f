// three.js r187 renders the `three` preset (KTX2, x-mirror, Filament curve)
// through KTX2Loader: orientation, exact values per level, diffuse (level T
// and the LightProbe SH), the cross-check against three's own PMREMGenerator,
// negative controls, and a contact sheet.
import fs from 'node:fs';
import path from 'node:path';
import { run, b64ToF32, fmt } from './lib/harness.mjs';
import { normalize, dot, mirrorLevel, sampleLevel, sampleLod, halfToFloat, CURVES, SH_MIRROR_NEGATE } from './lib/cube.mjs';
import { readKtx2File, packKtx2 } from './lib/ktx2pack.mjs';
import { readCross } from './lib/exr.mjs';
import { reflect, mix, pixelNormal, rgbAt, writeSheet, relDiff } from './lib/sphere.mjs';
import { orientationCheck, valueCheck } from './lib/checks.mjs';
import { prefiltered, chainTruth, markerSource, smoothIrradiance, discIrradiance } from './lib/reference.mjs';
import { loadBakes, snippetFor, expectedLevels } from './lib/data.mjs';

const S = 129;                       // odd: the centre pixel sees N = V exactly
const ENGINE_MIRROR = 'x';           // ENGINES.md: three samples image cubes at (-x, y, z)
const V = [0, 0, 1];
// Float render target, half texels read exactly: the model matches to ~1e-6;
// the tolerances leave room for other GPUs' filtering precision only.
const TOL = { centre: 1e-3, p99: 2e-3 };

// three's DFG LUT (16 x 16 RG16F, bilinear, clamped) as the shader samples it.
const DFG = await (async () => {
  const src = fs.readFileSync(new URL('./node_modules/three/src/renderers/shaders/DFGLUTData.js', import.meta.url), 'utf8');
  const hex = src.slice(src.indexOf('new Uint16Array(') + 16, src.indexOf(');', src.indexOf('new Uint16Array(')));
  return Float32Array.from(hex.match(/0x[0-9a-f]+/gi).map((h) => parseInt(h, 16)), halfToFloat);
})();
function dfg(rough, nv) {
  const x = Math.min(15, Math.max(0, rough * 16 - 0.5)), y = Math.min(15, Math.max(0, nv * 16 - 0.5));
  const x0 = Math.floor(x), y0 = Math.floor(y), x1 = Math.min(15, x0 + 1), y1 = Math.min(15, y0 + 1), a = x - x0, b = y - y0;
  const at = (i, j, k) => DFG[(j * 16 + i) * 2 + k];
  return [0, 1].map((k) => (1 - a) * (1 - b) * at(x0, y0, k) + a * (1 - b) * at(x1, y0, k) + (1 - a) * b * at(x0, y1, k) + a * b * at(x1, y1, k));
}

// three r187's physical material on a white metal (F0 = 1) at one pixel:
// Ess Pre(R') + (1 - Ess) (level T at N), R' = mix(R, N, rough^4), lod on
// the Filament curve, rough = min(1, max(r, 0.045) + geometryRoughness).
function threeMetal(levels, r, N, geomR) {
  const T = levels.length - 1;
  const rough = Math.min(1, Math.max(r, 0.045) + geomR);
  const R = normalize(mix(reflect(V, N), N, rough ** 4));
  const pre = sampleLod(levels, R, CURVES.filament.lod(rough, T));
  const irr = sampleLevel(levels[T], N);
  const [fa, fb] = dfg(rough, Math.max(0, Math.min(1, N[2])));
  const ess = fa + fb;
  return pre.map((p, k) => ess * p + (1 - ess) * irr[k]);
}

await run('three', async (s) => {
  const bakes = loadBakes(s.p.data);
  const marker = bakes.marker, smooth = bakes.smooth;
  const pre = marker.manifest.presets?.three;
  if (!pre) throw new Error('marker bake has no presets.three in its manifest');

  // Manifest against ENGINES.md.
  const T = pre.specular.length - 1;
  const tableErr = Math.max(...pre.specular.map((l, m) => Math.abs(l.roughness - CURVES.filament.r(m, T))));
  s.expect('manifest: mirror x, Filament curve', {
    pass: pre.mirror === ENGINE_MIRROR && pre.curve === 'filament' && tableErr < 1e-6,
    message: `mirror ${pre.mirror}, curve ${pre.curve}, ${pre.specular.length} levels ${pre.specular.map((l) => l.face_size).join('/')}, ` +
             `largest |r_m - (1 - sqrt(1 - m/T))| ${fmt(tableErr)}`,
  });

  // The preset's levels as three sees them (file) and in SPEC orientation (the truth the renders must show).
  const file = path.join(marker.dir, pre.dir, pre.files.specular);
  const fileLevels = readKtx2File(file).levels;
  const fileSpec = fileLevels.map((l) => mirrorLevel(l, ENGINE_MIRROR));
  const specLevels = expectedLevels(marker, pre, fileSpec);
  const roughness = pre.specular.map((l) => l.roughness);

  // Deliberately wrong exports for the negative controls.
  const wrongDir = path.join(s.p.data, 'wrong');
  fs.mkdirSync(wrongDir, { recursive: true });
  const noMirror = path.join(wrongDir, 'three_nomirror.ktx2');
  fs.writeFileSync(noMirror, packKtx2(fileSpec));                       // SPEC faces, no mirror
  const linear = path.join(wrongDir, 'three_linear.ktx2');
  const linLevels = bakes.markerLinear(T + 1).map((l) => mirrorLevel(l, ENGINE_MIRROR));
  fs.writeFileSync(linear, packKtx2(linLevels));                          // right mirror, linear r_m = m/T

  const page = await s.start('three.html');
  const info = await page.evaluate((n) => iblTest.init(n), S);
  s.log(`three.js r${info.revision}, WebGL2 ${info.webgl2}`);
  const snippet = snippetFor('three');
  const setKtx2 = (f) => page.evaluate((u, sn) => iblTest.setEnv({ kind: 'ktx2', url: u, snippet: sn }), s.dataUrl(f), snippet);
  const render = async (opts) => b64ToF32(await page.evaluate((o) => iblTest.render(o), opts));

  const loaded = await setKtx2(file);
  s.expect('load: KTX2Loader + cube repack gives a PMREM cube', {
    pass: loaded.levels === pre.specular.length && loaded.size === pre.specular[0].face_size && loaded.isPMREMTexture && !loaded.isRenderTargetTexture,
    message: `${snippet ? 'documented snippet' : 'harness loader'}: ${loaded.levels} levels, ${loaded.size} px, isPMREMTexture ${loaded.isPMREMTexture}, render target ${loaded.isRenderTargetTexture}`,
  });

  // Per-pixel normal and geometry roughness as three computes them.
  const probe = b64ToF32(await page.evaluate(() => iblTest.probe()));
  const probeAt = (x, y) => { const p = rgbAt(probe, S, x, y); return { N: normalize(p.slice(0, 3)), g: p[3] }; };
  const c = Math.floor(S / 2);
  s.metric('geometry_roughness_centre', probeAt(c, c).g);
  s.log(`geometry roughness at the centre pixel ${fmt(probeAt(c, c).g)} (the sphere is ${S} px across)`);

  // 1. Orientation: mirror sphere.
  const desc = marker.sources;
  const lookup = (r) => (N) => normalize(mix(reflect(V, N), N, Math.min(1, Math.max(r, 0.045)) ** 4));
  const mirrorPx = await render({ roughness: 0 });
  s.expect('orientation: mirror sphere shows each lobe where it belongs', orientationCheck(mirrorPx, S, desc, lookup(0)));

  // 2. Exact values at each level's roughness.
  const ours = [];
  const centreRows = [];
  for (let m = 0; m <= T; m++) {
    const px = await render({ roughness: roughness[m] });
    ours.push(px);
    const model = (x, y) => { const p = probeAt(x, y); return threeMetal(specLevels, roughness[m], p.N, p.g); };
    const r = valueCheck(px, S, model, { centreTol: TOL.centre, p99Tol: TOL.p99, label: `r ${fmt(roughness[m], 3)}: ` });
    s.expect(`exact values, level ${m} (r = ${fmt(roughness[m], 3)})`, r);
    centreRows.push({ level: m, roughness: roughness[m], centre: r.metrics.centre, p99: r.metrics.p99 });
  }
  s.metric('exact_values', centreRows);

  // 3. Diffuse under the smooth source: level T (= Irr) through the IBL path, and sh9 through a LightProbe.
  const dPre = smooth.manifest.presets.three;
  const dFile = path.join(smooth.dir, dPre.dir, dPre.files.specular);
  const dSpec = readKtx2File(dFile).levels.map((l) => mirrorLevel(l, ENGINE_MIRROR));
  await setKtx2(dFile);
  const exactIrr = (x, y, N) => smoothIrradiance(smooth.sources, N);
  const diffIbl = await render({ roughness: 1, metalness: 0, specularIntensity: 0 });
  s.expect('diffuse: matte sphere under the smooth source = Irr(N) (level T)', valueCheck(diffIbl, S, exactIrr, { centreTol: 4e-3, p99Tol: 8e-3, minNV: 0.05 }));
  s.metric('diffuse_level_T_vs_dT', valueCheck(diffIbl, S, (x, y, N) => sampleLevel(dSpec[dSpec.length - 1], N), { centreTol: 1, p99Tol: 1 }).metrics);
  await page.evaluate(() => iblTest.setEnv({ kind: 'none' }));
  const sh9 = [0, 1, 2].map((ch) => Array.from({ length: 9 }, (_, i) => dPre.sh.coefficients[3 * i + ch]));
  await page.evaluate((sh) => iblTest.setProbe(sh), sh9);
  const diffSh = await render({ roughness: 1, metalness: 0, specularIntensity: 0 });
  s.expect('diffuse: LightProbe with the manifest sh = Irr(N)', valueCheck(diffSh, S, exactIrr, { centreTol: 3e-3, p99Tol: 4e-3, minNV: 0.05 }));
  const shMirrored = sh9.map((row) => row.map((v, i) => (SH_MIRROR_NEGATE.x.includes(i) ? -v : v)));
  await page.evaluate((sh) => iblTest.setProbe(sh), shMirrored);
  const diffShWrong = await render({ roughness: 1, metalness: 0, specularIntensity: 0 });
  s.expectFail('LightProbe with x-mirrored sh', valueCheck(diffShWrong, S, exactIrr, { centreTol: 3e-3, p99Tol: 4e-3, minNV: 0.05 }));
  await page.evaluate(() => iblTest.setProbe(null));

  // 4. Cross-check against three's own PMREMGenerator of the same source:
  //    the centre pixel of a close-up (geometry roughness ~0, so material
  //    roughness r_m reads level m alone for m >= 1) against the same render
  //    of a chain whose texels are exact (chainTruth: each level's texels hold
  //    Pre at their centres, so the chain's own grid interpolation cancels),
  //    for our levels and for three's own.
  const L = markerSource(desc);
  const close = async () => {
    await page.evaluate(() => iblTest.setZoom(1 / 64));
    const pr = b64ToF32(await page.evaluate(() => iblTest.probe()));
    const out = [];
    for (let m = 0; m <= T; m++) out.push(rgbAt(b64ToF32(await page.evaluate((o) => iblTest.render(o), { roughness: roughness[m] })), S, c, c).slice(0, 3));
    await page.evaluate(() => iblTest.setZoom(1));
    return { g: rgbAt(pr, S, c, c)[3], px: out };
  };
  await setKtx2(file);
  const oursClose = await close();
  const pm = await page.evaluate((u) => iblTest.setEnv({ kind: 'pmrem', url: u }), s.dataUrl(marker.source));
  s.log(`three's PMREMGenerator: ${pm.size} px cube, ${pm.levels} levels (Filament-curve roughness over its own T = ${pm.levels - 1}), from ${path.basename(marker.source)}`);
  const pmChain = Array.from({ length: pm.levels }, (_, m) => ({ n: pm.size >> m, r: CURVES.filament.r(m, pm.levels - 1) }));
  const theirs = [];
  for (let m = 0; m <= T; m++) theirs.push(await render({ roughness: roughness[m] }));
  const theirsClose = await close();
  const cross = [];
  const chain = pre.specular.map((l) => ({ n: l.face_size, r: l.roughness }));
  const memo = new Map();
  for (let m = 0; m <= T; m++) {
    const rough = Math.min(1, Math.max(roughness[m], 0.045) + oursClose.g);
    const preT = chainTruth(L, chain, [0, 0, 1], CURVES.filament.lod(rough, T), memo), irr = chainTruth(L, chain, [0, 0, 1], T, memo);
    const [fa, fb] = dfg(rough, 1);
    const truth = preT.map((v, k) => (fa + fb) * v + (1 - fa - fb) * irr[k]);
    const Tp = pmChain.length - 1;
    const preP = chainTruth(L, pmChain, [0, 0, 1], CURVES.filament.lod(rough, Tp), memo), irrP = chainTruth(L, pmChain, [0, 0, 1], Tp, memo);
    const truthP = preP.map((v, k) => (fa + fb) * v + (1 - fa - fb) * irrP[k]);
    const eo = relDiff(oursClose.px[m], truth), et = relDiff(theirsClose.px[m], truthP);
    cross.push({ level: m, roughness: roughness[m], material_roughness: rough, ours_vs_exact: eo, pmrem_vs_exact: et,
                 ours_vs_pmrem: relDiff(oursClose.px[m], theirsClose.px[m]) });
    s.log(`cross-check r ${fmt(roughness[m], 3)}: centre pixel vs its chain with exact texels: ours ${fmt(eo)}, PMREMGenerator ${fmt(et)}; ours vs PMREM ${fmt(cross[cross.length - 1].ours_vs_pmrem)}`);
  }
  s.metric('cross_check', cross);
  const inner = cross.filter((x) => x.level > 0);     // level 0: roughness is clamped to 0.045, a blend of levels 0 and 1
  const worstOurs = Math.max(...inner.map((x) => x.ours_vs_exact)), worstTheirs = Math.max(...inner.map((x) => x.pmrem_vs_exact));
  s.expect('cross-check: ours at least as close to the exact split sum as PMREMGenerator (levels 1..T)', {
    pass: worstOurs <= Math.max(worstTheirs, 5e-3),
    message: `largest centre-pixel error: ours ${fmt(worstOurs)}, PMREMGenerator ${fmt(worstTheirs)}`,
  });

  // 5. Negative controls: the same checks on deliberately wrong exports.
  await setKtx2(noMirror);
  s.expectFail('orientation on an export without the x-mirror', orientationCheck(await render({ roughness: 0 }), S, desc, lookup(0)));
  await setKtx2(linear);
  let linFails = 0;
  const linMsgs = [];
  for (let m = 1; m < T; m++) {
    const px = await render({ roughness: roughness[m] });
    const model = (x, y) => { const p = probeAt(x, y); return threeMetal(specLevels, roughness[m], p.N, p.g); };
    const r = valueCheck(px, S, model, { centreTol: TOL.centre, p99Tol: TOL.p99 });
    if (!r.pass) linFails++;
    linMsgs.push(`level ${m}: centre ${fmt(r.metrics.centre)}`);
  }
  s.expectFail('exact values on an export with linear r_m', { pass: linFails === 0, message: `${linFails} of ${T - 1} inner levels fail (${linMsgs.join(', ')})` });

  // 6. The sun as a light (issue 27): a white diffuse sphere lit by the
  //    sun-free three preset plus the light from sun.gltf renders as one lit
  //    by the original environment alone, within 1 %.
  const sunOrig = bakes.other('sun', 'sun.exr'), sunSplit = bakes.other('sun_split', 'sun.exr');
  const matte = { roughness: 1, metalness: 0, specularIntensity: 0 };
  await setKtx2(path.join(sunOrig.dir, sunOrig.manifest.presets.three.dir, sunOrig.manifest.presets.three.files.specular));
  const withSun = await render(matte);
  const splitPre = sunSplit.manifest.presets.three;
  await setKtx2(path.join(sunSplit.dir, splitPre.dir, splitPre.files.specular));
  const noSun = await render(matte);
  const gltfUrl = s.dataUrl(path.join(sunSplit.dir, sunSplit.manifest.sun.files.gltf));
  const loadedSun = await page.evaluate((u) => iblTest.setSun({ url: u }), gltfUrl);
  const want = splitPre.sun.direction;
  const dirErr = Math.acos(Math.min(1, loadedSun.direction.reduce((a, v, k) => a + v * want[k], 0))) * 180 / Math.PI;
  s.expect('sun.gltf: GLTFLoader gives one DirectionalLight along the three preset\'s sun direction, colour x intensity = E', {
    pass: loadedSun.lights === 1 && dirErr < 1e-3 &&
          loadedSun.color.every((c, k) => Math.abs(c * loadedSun.intensity - sunSplit.manifest.sun.illuminance[k]) <= 1e-4 * sunSplit.manifest.sun.illuminance[k]),
    message: `${loadedSun.lights} light(s), direction ${fmt(loadedSun.direction)} (off the preset's by ${fmt(dirErr)} deg), ` +
             `colour ${fmt(loadedSun.color)} x intensity ${fmt(loadedSun.intensity)} vs E ${fmt(sunSplit.manifest.sun.illuminance)}`,
  });
  const lit = await render(matte);
  // Away from the sun's terminator (|N.d| >= 0.1, about one texel of the
  // 16 px level T on either side) the two renders agree within 1 %. Along
  // it the original's level T cannot hold the kink of max(0, N.d) (a 16 px
  // cube interpolates across it), and the light does: there the split is
  // measured against the exact irradiance (the smooth sky's closed form plus
  // the disc's own cosine integral) and must be at least as close as the
  // original environment.
  const sunDesc = sunSplit.sources.sun, D = normalize(sunDesc.direction);
  const band = 0.1;
  const sameAsOriginal = (px, nearToo = false) => valueCheck(px, S, (x, y, N) =>
    (nearToo || Math.abs(dot(N, D)) >= band ? rgbAt(withSun, S, x, y).slice(0, 3) : null),
  { centreTol: 0.01, p99Tol: 0.01, minNV: 0.05 });
  const sunCheck = sameAsOriginal(lit);
  sunCheck.message += ` (pixels with N.V >= 0.05 and |N.d| >= ${band})`;
  s.expect('sun: sun-free three preset + sun.gltf = the original environment alone (white diffuse sphere, 1 %)', sunCheck);
  const discIrr = (N) => discIrradiance(sunDesc, N);
  let farSplit = { d: 0 }, farOrig = { d: 0 };
  for (let y = 0; y < S; y++) for (let x = 0; x < S; x++) {
    const N = pixelNormal(S, x, y);
    if (!N || N[2] < 0.05 || Math.abs(dot(N, D)) < band) continue;
    const sky = smoothIrradiance(sunSplit.sources, N), disc = discIrr(N);
    const exact = sky.map((v, k) => v + disc[k]);
    const a = relDiff(rgbAt(lit, S, x, y), exact), b = relDiff(rgbAt(withSun, S, x, y), exact);
    if (a > farSplit.d) farSplit = { d: a, x, y, N };
    if (b > farOrig.d) farOrig = { d: b, x, y, N };
  }
  s.expect('sun: away from the terminator the split is within 1 % of the exact irradiance at every pixel', {
    pass: farSplit.d <= 0.01,
    message: `largest error against the exact irradiance (the smooth sky's closed form + the disc's cosine integral): ` +
             `sun-free preset + light ${fmt(farSplit.d)} at (${farSplit.x}, ${farSplit.y}); the original preset ${fmt(farOrig.d)} at (${farOrig.x}, ${farOrig.y})`,
  });
  let nearSplit = 0, nearOrig = 0, nearPx = 0;
  for (let y = 0; y < S; y++) for (let x = 0; x < S; x++) {
    const N = pixelNormal(S, x, y);
    if (!N || N[2] < 0.05 || Math.abs(dot(N, D)) >= band) continue;
    const sky = smoothIrradiance(sunSplit.sources, N), disc = discIrr(N);
    const exact = sky.map((v, k) => v + disc[k]);
    nearSplit = Math.max(nearSplit, relDiff(rgbAt(lit, S, x, y), exact));
    nearOrig = Math.max(nearOrig, relDiff(rgbAt(withSun, S, x, y), exact));
    nearPx++;
  }
  s.expect('sun: along the terminator the split is at least as close to the exact irradiance as the original', {
    pass: nearPx > 100 && nearSplit <= nearOrig,
    message: `${nearPx} px with |N.d| < ${band}: largest error against the exact irradiance ${fmt(nearSplit)} (sun-free preset + light) vs ${fmt(nearOrig)} (original preset)`,
  });
  s.metric('sun', { share: sunSplit.manifest.sun.irradiance_share, ...sunCheck.metrics, terminator: { pixels: nearPx, split: nearSplit, original: nearOrig },
                    exact_away_from_terminator: { split: farSplit.d, original: farOrig.d },
                    without_light: sameAsOriginal(noSun).metrics });
  s.expectFail('the sun-free preset alone (no light)', sameAsOriginal(noSun, true));
  await page.evaluate((u) => iblTest.setSun({ url: u, mirrorX: true }), gltfUrl);
  s.expectFail('the light x-mirrored like the preset\'s cube storage', sameAsOriginal(await render(matte), true));
  await page.evaluate(() => iblTest.setSun(null));

  // 7. Contact sheet: our bake (top) beside three's own PMREM (bottom).
  const sheet = writeSheet(path.join(s.p.out, 'three_sheet.png'), [ours, theirs], S);
  console.log(`contact sheet: ${sheet} (top: iblbake three preset; bottom: three.js PMREMGenerator; r = ${roughness.map((r) => fmt(r, 3)).join(', ')})`);
});
