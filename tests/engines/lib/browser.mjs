// Debian's chromium, headless, software WebGL2 (SwiftShader through ANGLE),
// driven by puppeteer-core with a fresh profile that is removed afterwards.
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import puppeteer from 'puppeteer-core';

export const CHROMIUM = process.env.IBLBAKE_CHROMIUM || '/usr/bin/chromium';
export const CHROMIUM_ARGS = [
  '--headless=new', '--no-sandbox', '--use-angle=swiftshader', '--enable-unsafe-swiftshader',
  '--disable-background-networking', '--disable-component-update', '--disable-sync', '--no-first-run',
  '--disable-default-apps', '--disable-extensions', '--mute-audio', '--disable-gpu-watchdog',
];

export async function launchBrowser() {
  if (!fs.existsSync(CHROMIUM)) throw new Error(`chromium not found at ${CHROMIUM} (scripts/install_deps.sh installs Debian's chromium)`);
  const profile = fs.mkdtempSync(path.join(os.tmpdir(), 'iblbake-chromium-'));
  let browser;
  try {
    browser = await puppeteer.launch({ executablePath: CHROMIUM, headless: true, userDataDir: profile,
                                       args: CHROMIUM_ARGS, protocolTimeout: 600000 });
  } catch (e) {
    fs.rmSync(profile, { recursive: true, force: true });
    throw e;
  }
  return {
    browser,
    async close() {
      try { await browser.close(); } finally { fs.rmSync(profile, { recursive: true, force: true }); }
    },
  };
}

// Opens url, forwards the page's console and errors to ours, waits until the
// page sets window.__ready (or throws what it put in window.__error).
export async function openPage(browser, url, { timeout = 240000, log = console.log } = {}) {
  const page = await browser.newPage();
  page.on('console', (m) => { const t = m.type(); if (t === 'error' || t === 'warn' || t === 'warning' || process.env.IBLBAKE_JS_VERBOSE) log(`[page ${t}] ${m.text()}`); });
  page.on('pageerror', (e) => log(`[page error] ${e.message}`));
  // (a stream the page stops reading after its last byte shows as ERR_ABORTED with a response: not a failure)
  page.on('requestfailed', (r) => { if (!r.response()) log(`[page request failed] ${r.url()} ${r.failure()?.errorText}`); });
  await page.goto(url, { waitUntil: 'load', timeout });
  await page.waitForFunction('window.__ready === true || window.__error !== undefined', { timeout, polling: 100 });
  const err = await page.evaluate(() => window.__error);
  if (err !== undefined) throw new Error(`page ${url}: ${err}`);
  return page;
}
