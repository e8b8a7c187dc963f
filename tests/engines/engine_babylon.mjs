// Babylon.js renders the `babylon` preset (.env: RGBD PNG, x-mirror, Babylon
// curve, SPEC polynomial) loaded with CubeTexture.CreateFromPrefilteredData:
// orientation, exact values per level, diffuse from the polynomial, the
// cross-check against Babylon's own prefiltering (EXRCubeTexture), negative
// controls and a contact sheet.
//
// Babylon's world is left-handed; its glTF loader brings a glTF (right-handed,
// SPEC) scene in under a root turned half a turn about Y and scaled -1 in z,
// X negated overall, so SPEC direction (x, y, z) is Babylon's (-x, y, z)
// (engine_babylon_sun.mjs measures the loader's root). The camera sits at
// (0, 0, 5) looking toward -Z, so a pixel shows what three.js shows from
// (0, 0, 5).
import fs from 'node:fs';
import path from 'node:path';
import { run, b64ToF32, fmt } from './lib/harness.mjs';
import { normalize, mirrorLevel, sampleLod, CURVES, shToPolynomial, mirrorSh } from './lib/cube.mjs';
import { readEnv, packEnv } from './lib/envpack.mjs';
import { reflect, pixelNormal, rgbAt, writeSheet, relDiff } from './lib/sphere.mjs';
import { orientationCheck, valueCheck } from './lib/checks.mjs';
import { prefiltered, chainTruth, markerSource, smoothIrradiance } from './lib/reference.mjs';
import { loadBakes, expectedLevels } from './lib/data.mjs';

const S = 129;
const ENGINE_MIRROR = 'x';           // Babylon samples (-x, y, z) of SPEC: its glTF loader's frame
const EYE = [0, 0, 5];
const MIN_VARIANCE = 0.0005;         // Babylon's alphaG = r^2 + MINIMUMVARIANCE
const LOD_SCALE = 0.8;
// Babylon decodes RGBD into a half-float cube and we read a half-float
// drawing buffer: two half roundings at the centre; off-centre, level 0's
// sharp lobes through SwiftShader's texel-coordinate precision.
const TOL = { centre: 3e-3, p99: 3e-2 };

const toSpec = (d) => [-d[0], d[1], d[2]];
// View-space pixel normal (toward the camera = +z in pixelNormal) -> Babylon world.
const worldN = (N) => [-N[0], N[1], N[2]];  // left-handed, looking toward -Z: right is -X
// The reflection Babylon looks up (world), from the eye position (Babylon
// uses the eye position even for orthographic cameras), no bending.
function lookupWorld(N) {
  const n = worldN(N), P = n;
  const V = normalize([EYE[0] - P[0], EYE[1] - P[1], EYE[2] - P[2]]);
  return reflect(V, n);
}
const babylonLod = (r, N0) => LOD_SCALE * Math.log2(N0 * (r * r + MIN_VARIANCE));

// Babylon 9's PBR on a white metal (F0 = 1): reflectance brdf.y times the
// energy conservation factor 1 / brdf.y = 1, and the radiance mixed with the
// SH irradiance by alphaG (MIX_IBL_RADIANCE_WITH_IRRADIANCE, on by default).
// The specular checks zero the polynomial, leaving (1 - alphaG) Pre(lod).
function babylonMetal(specLevels, r, N) {
  const a = r * r + MIN_VARIANCE;
  return sampleLod(specLevels, toSpec(lookupWorld(N)), babylonLod(r, specLevels[0].n)).map((v) => (1 - a) * v);
}
const ZERO_POLY = { x: [0, 0, 0], y: [0, 0, 0], z: [0, 0, 0], xx: [0, 0, 0], yy: [0, 0, 0], zz: [0, 0, 0], xy: [0, 0, 0], yz: [0, 0, 0], zx: [0, 0, 0] };
// Babylon evaluates a SphericalPolynomial through SphericalHarmonics.FromPolynomial
// and its prescaled basis: relative to band 0, band 1 comes out x 3/2 and band 2 x 4
// (its own cube -> polynomial path applies the cosine-lobe factors A_l twice). So a
// polynomial that renders Irr is SPEC's made from sh9 with bands 1 and 2 scaled by 2/3 and 1/4.
export const babylonPolynomial = (sh9) => shToPolynomial(sh9.map((row) => row.map((v, i) => v * (i === 0 ? 1 : i < 4 ? 2 / 3 : 1 / 4))));

await run('babylon', async (s) => {
  const bakes = loadBakes(s.p.data);
  const marker = bakes.marker, smooth = bakes.smooth;
  const pre = marker.manifest.presets?.babylon;
  if (!pre) throw new Error('marker bake has no presets.babylon in its manifest');
  const N0 = pre.specular[0].face_size, T = pre.specular.length - 1;
  const tableErr = Math.max(...pre.specular.map((l, m) => Math.abs(l.roughness - CURVES.babylon.r(m, T, N0))));
  s.expect('manifest: x-mirror, Babylon curve, chain to 1 px', {
    pass: pre.mirror === ENGINE_MIRROR && pre.curve === 'babylon' && tableErr < 1e-6 && pre.specular[T].face_size === 1,
    message: `mirror ${pre.mirror}, curve ${pre.curve}, ${pre.specular.length} levels ${pre.specular.map((l) => l.face_size).join('/')}, ` +
             `largest |r_m - min(1, sqrt(2^(m/0.8)/N0))| ${fmt(tableErr)}`,
  });

  const file = path.join(marker.dir, pre.dir, pre.files.environment);
  const env = readEnv(new Uint8Array(fs.readFileSync(file)));
  const fileSpec = env.levels.map((l) => mirrorLevel(l, ENGINE_MIRROR));
  const specLevels = expectedLevels(marker, pre, fileSpec);
  const roughness = pre.specular.map((l) => l.roughness);

  const wrongDir = path.join(s.p.data, 'wrong');
  fs.mkdirSync(wrongDir, { recursive: true });
  const noMirror = path.join(wrongDir, 'babylon_nomirror.env');
  fs.writeFileSync(noMirror, packEnv(fileSpec, env.info.irradiance));
  const linear = path.join(wrongDir, 'babylon_linear.env');
  fs.writeFileSync(linear, packEnv(bakes.markerLinear(T + 1).map((l) => mirrorLevel(l, ENGINE_MIRROR)), env.info.irradiance));

  const page = await s.start('babylon.html');
  const info = await page.evaluate((n) => iblTest.init(n), S);
  s.log(`Babylon.js ${info.version}, drawing buffer ${info.float ? 'RGBA16F' : info.drawingBufferFormat}`);
  const setEnv = (o) => page.evaluate((x) => iblTest.setEnv(x), o);
  const render = async (o) => b64ToF32((await page.evaluate((x) => iblTest.render(x), o)).pixels);

  const loaded = await setEnv({ kind: 'env', url: s.dataUrl(file) });
  s.expect('load: CreateFromPrefilteredData reads the .env', {
    pass: loaded.size === N0 && Math.abs(loaded.lodGenerationScale - LOD_SCALE) < 1e-9,
    message: `size ${loaded.size}, lodGenerationScale ${loaded.lodGenerationScale}, offset ${loaded.lodGenerationOffset}`,
  });

  const desc = marker.sources;
  const lookupSpec = (N) => normalize(toSpec(lookupWorld(N)));
  const mirrorPx = await render({ roughness: 0 });
  s.expect('orientation: mirror sphere shows each lobe where it belongs', orientationCheck(mirrorPx, S, desc, lookupSpec));
  s.log(`material: ${JSON.stringify(await page.evaluate(() => iblTest.info()))}`);

  const ours = [], oursZ = [], rows = [];
  for (let m = 0; m <= T; m++) ours.push(await render({ roughness: roughness[m] }));    // as users see it
  await page.evaluate((p) => iblTest.setPolynomial(p), ZERO_POLY);
  for (let m = 0; m <= T; m++) {
    const px = await render({ roughness: roughness[m] });
    oursZ.push(px);
    if (1 - (roughness[m] ** 2 + MIN_VARIANCE) < 0.02) {
      s.log(`level ${m} (r = ${fmt(roughness[m], 3)}): Babylon replaces the radiance by the SH irradiance (weight 1 - alphaG = ${fmt(1 - roughness[m] ** 2 - MIN_VARIANCE)}); not checked`);
      rows.push({ level: m, roughness: roughness[m], lod: babylonLod(roughness[m], N0), centre: null, p99: null });
      continue;
    }
    const r = valueCheck(px, S, (x, y, N) => babylonMetal(specLevels, roughness[m], N), { centreTol: TOL.centre, p99Tol: TOL.p99, label: `r ${fmt(roughness[m], 3)}: ` });
    s.expect(`exact values, level ${m} (r = ${fmt(roughness[m], 3)}, lod ${fmt(Math.max(0, babylonLod(roughness[m], N0)), 3)})`, r);
    rows.push({ level: m, roughness: roughness[m], lod: babylonLod(roughness[m], N0), centre: r.metrics.centre, p99: r.metrics.p99 });
  }
  s.metric('exact_values', rows);

  // Diffuse: the file's polynomial under the smooth source (ratio of renders with the
  // polynomial = ours, 0 and a unit constant cancels Babylon's diffuse weights).
  const dPre = smooth.manifest.presets.babylon;
  const dEnv = path.join(smooth.dir, dPre.dir, dPre.files.environment);
  const dInfo = readEnv(new Uint8Array(fs.readFileSync(dEnv))).info;
  await setEnv({ kind: 'env', url: s.dataUrl(dEnv) });
  const matte = { roughness: 1, metallic: 0 };
  const a = await render(matte);
  await page.evaluate((p) => iblTest.setPolynomial(p), ZERO_POLY);
  const z = await render(matte);
  // Babylon's own constant (SphericalPolynomial.addAmbient(1)): xx = yy = zz = 1.
  await page.evaluate((p) => iblTest.setPolynomial(p), { ...ZERO_POLY, xx: [1, 1, 1], yy: [1, 1, 1], zz: [1, 1, 1] });
  const u1 = await render(matte);
  const ratio = (p) => { const out = new Float32Array(p.length); for (let i = 0; i < p.length; i += 4) for (let k = 0; k < 3; k++) out[i + k] = (p[i + k] - z[i + k]) / (u1[i + k] - z[i + k]); return out; };
  const exactIrr = (x, y, N) => smoothIrradiance(smooth.sources, toSpec(worldN(N)));
  const polyFile = dInfo.irradiance;
  s.expect('diffuse: the .env polynomial = Irr(N)', valueCheck(ratio(a), S, exactIrr, { centreTol: 3e-3, p99Tol: 5e-3, minNV: 0.05 }));
  const sh9 = smooth.manifest.sh9;
  await page.evaluate((p) => iblTest.setPolynomial(p), babylonPolynomial(mirrorSh(sh9, 'x')));
  s.expect("diffuse (reference): sh9 x-mirrored, bands scaled for Babylon's evaluation = Irr(N)", valueCheck(ratio(await render(matte)), S, exactIrr, { centreTol: 3e-3, p99Tol: 5e-3, minNV: 0.05 }));
  await page.evaluate((p) => iblTest.setPolynomial(p), babylonPolynomial(sh9));
  s.expectFail('polynomial without the x-mirror', valueCheck(ratio(await render(matte)), S, exactIrr, { centreTol: 3e-3, p99Tol: 5e-3, minNV: 0.05 }));
  await page.evaluate((p) => iblTest.setPolynomial(p), shToPolynomial(mirrorSh(sh9, 'x')));
  s.expectFail("SPEC's polynomial as it is (Babylon's band factors not applied)", valueCheck(ratio(await render(matte)), S, exactIrr, { centreTol: 3e-3, p99Tol: 5e-3, minNV: 0.05 }));
  s.metric('polynomial_file', polyFile);
  s.metric('polynomial_spec_x', shToPolynomial(mirrorSh(sh9, 'x')));

  // Cross-check against Babylon's own prefiltering (EXRCubeTexture, prefilterOnLoad) of the same source.
  const cubeSize = 128;
  const t0 = Date.now();
  const own = await setEnv({ kind: 'exr', url: s.dataUrl(marker.sourceBabylon), size: cubeSize });
  s.log(`Babylon's own prefiltering: ${own.size} px cube from ${path.basename(marker.sourceBabylon)} (same marker, turned to Babylon's lat-long convention) in ${((Date.now() - t0) / 1000).toFixed(1)} s`);
  const L = markerSource(desc);
  const theirs = [], cross = [];
  const c = Math.floor(S / 2);
  const CENTRE_SPEC = toSpec(lookupWorld([0, 0, 1]));  // what the centre pixel reflects, in SPEC
  const memo = new Map();
  const oursChain = pre.specular.map((l) => ({ n: l.face_size, r: l.roughness }));
  const ownChain = Array.from({ length: Math.log2(cubeSize) + 1 }, (_, m) => ({ n: cubeSize >> m, r: m === 0 ? 0 : Math.sqrt(2 ** (m / LOD_SCALE) / cubeSize) }));
  for (let m = 0; m <= T; m++) theirs.push(await render({ roughness: roughness[m] }));   // as users see it
  await page.evaluate((p) => iblTest.setPolynomial(p), ZERO_POLY);
  for (let m = 0; m <= T; m++) {
    const px = await render({ roughness: roughness[m] });
    const alphaG = roughness[m] ** 2 + MIN_VARIANCE;
    if (1 - alphaG < 0.02) continue;
    // Each against the same render of its own chain with exact texels
    // (Babylon's own: 128 >> m px at alpha 2^(m/0.8)/128, HDRFiltering's table).
    const tOurs = chainTruth(L, oursChain, CENTRE_SPEC, babylonLod(roughness[m], N0), memo).map((v) => (1 - alphaG) * v);
    const tOwn = chainTruth(L, ownChain, CENTRE_SPEC, babylonLod(roughness[m], cubeSize), memo).map((v) => (1 - alphaG) * v);
    const eo = relDiff(rgbAt(oursZ[m], S, c, c), tOurs), et = relDiff(rgbAt(px, S, c, c), tOwn);
    cross.push({ level: m, roughness: roughness[m], ours_vs_exact: eo, babylon_vs_exact: et, ours_vs_babylon: relDiff(rgbAt(oursZ[m], S, c, c), rgbAt(px, S, c, c).slice(0, 3)) });
    s.log(`cross-check r ${fmt(roughness[m], 3)}: centre pixel vs its chain with exact texels: ours ${fmt(eo)}, Babylon's prefiltering ${fmt(et)}; ours vs Babylon ${fmt(cross[cross.length - 1].ours_vs_babylon)}`);
  }
  s.metric('cross_check', cross);
  const wo = Math.max(...cross.map((x) => x.ours_vs_exact)), wt = Math.max(...cross.map((x) => x.babylon_vs_exact));
  s.expect("cross-check: ours at least as close to exact Pre as Babylon's prefiltering", {
    pass: wo <= Math.max(wt, 1e-2), message: `largest centre-pixel error against its chain with exact texels: ours ${fmt(wo)}, Babylon ${fmt(wt)}`,
  });

  // Negative controls.
  await setEnv({ kind: 'env', url: s.dataUrl(noMirror) });
  s.expectFail('orientation on an export without the x-mirror', orientationCheck(await render({ roughness: 0 }), S, desc, lookupSpec));
  await setEnv({ kind: 'env', url: s.dataUrl(linear) });
  await page.evaluate((p) => iblTest.setPolynomial(p), ZERO_POLY);
  let fails = 0;
  const msgs = [];
  for (let m = 1; m < T; m++) {
    if (1 - (roughness[m] ** 2 + MIN_VARIANCE) < 0.02) continue;
    const r = valueCheck(await render({ roughness: roughness[m] }), S, (x, y, N) => babylonMetal(specLevels, roughness[m], N), { centreTol: TOL.centre, p99Tol: TOL.p99 });
    if (!r.pass) fails++;
    msgs.push(`level ${m}: centre ${fmt(r.metrics.centre)}`);
  }
  s.expectFail('exact values on an export with linear r_m', { pass: fails === 0, message: `${fails} of ${T - 1} inner levels fail (${msgs.join(', ')})` });

  const sheet = writeSheet(path.join(s.p.out, 'babylon_sheet.png'), [ours, theirs], S);
  console.log(`contact sheet: ${sheet} (top: iblbake babylon preset; bottom: Babylon's own prefiltering, ${cubeSize} px; r = ${roughness.map((r) => fmt(r, 3)).join(', ')})`);
});
