// What every engine test shares: paths, the server and browser, results,
// negative controls, the exit code.
import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { startServer } from './server.mjs';
import { launchBrowser, openPage } from './browser.mjs';

const HERE = path.dirname(fileURLToPath(import.meta.url));
export const ROOT = path.resolve(HERE, '..');             // tests/engines (or its copy in the build tree)

// Environment (CTest sets these): IBLBAKE_ENGINE_DATA = folder of the bakes
// (made by the fixture), IBLBAKE_ENGINE_OUT = where pictures and reports go.
export function paths() {
  const data = process.env.IBLBAKE_ENGINE_DATA;
  if (!data) throw new Error('IBLBAKE_ENGINE_DATA is not set (the engine_bakes fixture makes it)');
  const out = process.env.IBLBAKE_ENGINE_OUT || path.join(data, 'results');
  fs.mkdirSync(out, { recursive: true });
  return { data, out, nodeModules: path.join(ROOT, 'node_modules'), web: path.join(ROOT, 'web') };
}

export function fmt(x, d = 4) {
  if (x === null || x === undefined) return String(x);
  if (Array.isArray(x)) return '[' + x.map((v) => fmt(v, d)).join(', ') + ']';
  if (typeof x !== 'number') return String(x);
  if (x === 0) return '0';
  const a = Math.abs(x);
  return a >= 1e-3 && a < 1e4 ? x.toFixed(d) : x.toExponential(2);
}

export class Suite {
  constructor(name) {
    this.name = name;
    this.results = [];
    this.t0 = Date.now();
    this.p = paths();
    this.report = { engine: name, checks: [], metrics: {} };
  }

  log(...a) { console.log(...a); }

  // A check that must pass.
  expect(label, r) {
    const ok = !!r.pass;
    this.results.push({ label, ok, kind: 'positive' });
    this.report.checks.push({ label, expected: 'pass', pass: r.pass, message: r.message, metrics: r.metrics });
    console.log(`${ok ? 'PASS' : 'FAIL'}  ${label}: ${r.message}`);
    return ok;
  }

  // A negative control: the same check on a deliberately wrong export must fail.
  expectFail(label, r) {
    const ok = !r.pass;
    this.results.push({ label, ok, kind: 'negative' });
    this.report.checks.push({ label, expected: 'fail', pass: r.pass, message: r.message, metrics: r.metrics });
    console.log(`${ok ? 'PASS' : 'FAIL'}  negative control, ${label}: ${ok ? 'fails as it must' : 'PASSED ON A WRONG EXPORT'}: ${r.message}`);
    return ok;
  }

  metric(key, value) { this.report.metrics[key] = value; }

  async start(pageName) {
    this.server = await startServer({ '/m/': this.p.nodeModules, '/w/': this.p.web, '/d/': this.p.data });
    this.browser = await launchBrowser();
    this.page = await openPage(this.browser.browser, `${this.server.url}/w/${pageName}`);
    return this.page;
  }

  dataUrl(file) {
    const rel = path.relative(this.p.data, file);
    if (rel.startsWith('..')) throw new Error(`${file} is outside the data folder`);
    return '/d/' + rel.split(path.sep).map(encodeURIComponent).join('/');
  }

  async finish() {
    try {
      if (this.browser) await this.browser.close();
      if (this.server) await this.server.close();
    } catch (e) { console.log(`cleanup: ${e.message}`); }
    const failed = this.results.filter((r) => !r.ok);
    const secs = (Date.now() - this.t0) / 1000;
    this.report.seconds = secs;
    const rep = path.join(this.p.out, `${this.name}_report.json`);
    fs.writeFileSync(rep, JSON.stringify(this.report, null, 1));
    console.log(`report: ${rep}`);
    console.log(`${this.name}: ${this.results.length - failed.length}/${this.results.length} checks as expected ` +
                `(${this.results.filter((r) => r.kind === 'negative').length} negative controls) in ${secs.toFixed(1)} s`);
    if (failed.length) {
      console.log(`FAILED: ${failed.map((f) => f.label).join('; ')}`);
      process.exitCode = 1;
    }
  }
}

// Runs main(suite) and always finishes (closing the browser) even on a throw.
export async function run(name, main) {
  const s = new Suite(name);
  try {
    await main(s);
  } catch (e) {
    console.log(`ERROR: ${e.stack || e}`);
    s.results.push({ label: 'harness error', ok: false, kind: 'positive' });
  }
  await s.finish();
}

export function b64ToF32(b64) {
  const buf = Buffer.from(b64, 'base64');
  return new Float32Array(buf.buffer, buf.byteOffset, buf.byteLength / 4);
}
