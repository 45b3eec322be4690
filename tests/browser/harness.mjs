// What the browser tests share: a static file server for web/ (or any folder) on
// 127.0.0.1, Chromium launched from /usr/bin/chromium with WebGPU on SwiftShader and a
// fresh profile, and the g1tess CLI the page is checked against.

import { spawnSync } from 'node:child_process';
import fs from 'node:fs';
import http from 'node:http';
import os from 'node:os';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

import { chromium } from 'playwright-core';

export const ROOT = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '..', '..');

/// In CI a missing browser or WebGPU adapter fails the tests; elsewhere it skips them.
export const CI = process.env.CI === 'true';

export const CHROMIUM = process.env.CHROMIUM ?? '/usr/bin/chromium';

/// The flags of the issue: new headless mode, WebGPU on Chromium's built-in SwiftShader
/// Vulkan (Dawn refuses Mesa's lavapipe), ANGLE on SwiftShader too.
export const CHROMIUM_ARGS = [
  '--headless=new',
  '--no-sandbox',
  '--enable-unsafe-webgpu',
  '--enable-features=Vulkan',
  '--use-vulkan=swiftshader',
  '--use-angle=swiftshader',
];

const MIME = {
  '.html': 'text/html; charset=utf-8',
  '.js': 'text/javascript; charset=utf-8',
  '.mjs': 'text/javascript; charset=utf-8',
  '.css': 'text/css; charset=utf-8',
  '.json': 'application/json',
  '.wasm': 'application/wasm',
  '.png': 'image/png',
  '.svg': 'image/svg+xml',
  '.ico': 'image/x-icon',
  '.obj': 'text/plain',
  '.glb': 'model/gltf-binary',
};

/// Serves the files under `dir` on 127.0.0.1 at a free port (the system picks it).
/// Resolves to { url, close() }.
export async function serve(dir) {
  const root = fs.realpathSync(dir);
  const server = http.createServer((req, res) => {
    let rel;
    try {
      rel = decodeURIComponent(new URL(req.url, 'http://127.0.0.1').pathname);
    } catch {
      res.writeHead(400).end();
      return;
    }
    if (rel.endsWith('/')) rel += 'index.html';
    const file = path.join(root, path.normalize(rel));
    if (!file.startsWith(root + path.sep)) {
      res.writeHead(403).end();
      return;
    }
    fs.readFile(file, (err, body) => {
      if (err) {
        res.writeHead(404, { 'content-type': 'text/plain' }).end('not found');
        return;
      }
      const type = MIME[path.extname(file).toLowerCase()] ?? 'application/octet-stream';
      res.writeHead(200, { 'content-type': type, 'cache-control': 'no-store' }).end(body);
    });
  });
  await new Promise((resolve, reject) => {
    server.once('error', reject);
    server.listen(0, '127.0.0.1', resolve);
  });
  const { port } = server.address();
  return {
    url: `http://127.0.0.1:${port}/`,
    close: () => new Promise((resolve) => server.close(resolve)),
  };
}

/// Chromium with a fresh profile (a new temporary --user-data-dir, removed on close).
/// Playwright refuses --user-data-dir among the arguments, so the profile is given to
/// launchPersistentContext; headless stays false there because --headless=new is passed
/// explicitly. Resolves to { context, page, close() }.
export async function launch() {
  const profile = fs.mkdtempSync(path.join(os.tmpdir(), 'g1tess-chromium-'));
  let context;
  try {
    context = await chromium.launchPersistentContext(profile, {
      executablePath: CHROMIUM,
      headless: false,
      args: CHROMIUM_ARGS,
      viewport: { width: 1200, height: 800 },
      acceptDownloads: true,
    });
  } catch (e) {
    fs.rmSync(profile, { recursive: true, force: true });
    throw e;
  }
  const page = context.pages()[0] ?? (await context.newPage());
  return {
    context,
    page,
    close: async () => {
      await context.close();
      fs.rmSync(profile, { recursive: true, force: true });
    },
  };
}

/// Why the browser tests cannot run here, or null when they can: no Chromium at
/// CHROMIUM. (A missing WebGPU adapter is found by the probe once the browser runs.)
export function missingBrowser() {
  return fs.existsSync(CHROMIUM) ? null : `no Chromium at ${CHROMIUM}`;
}

/// The g1tess binary: $G1TESS_BIN, else target/release/g1tess (scripts/test-browser.sh
/// builds it).
export const G1TESS = path.resolve(ROOT, process.env.G1TESS_BIN ?? path.join('target', 'release', 'g1tess'));

/// Runs the CLI; throws with its stderr when it fails. Returns stdout.
export function g1tess(...args) {
  const r = spawnSync(G1TESS, args, { encoding: 'utf8', maxBuffer: 1 << 28 });
  if (r.error) throw r.error;
  if (r.status !== 0) {
    throw new Error(`g1tess ${args.join(' ')}: exit ${r.status}: ${r.stderr.trim()}`);
  }
  return r.stdout;
}

/// Runs the CLI in `cwd` where it must fail; returns its stderr.
export function g1tessFails(cwd, ...args) {
  const r = spawnSync(G1TESS, args, { cwd, encoding: 'utf8' });
  if (r.error) throw r.error;
  if (r.status === 0) throw new Error(`g1tess ${args.join(' ')} succeeded`);
  return r.stderr;
}

/// A fresh temporary folder for one test file's outputs.
export function tempDir(prefix) {
  return fs.mkdtempSync(path.join(os.tmpdir(), prefix));
}
