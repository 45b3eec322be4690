// Chromium on this machine runs WebGPU: an adapter (SwiftShader), a compute shader whose
// results come back exact, and a canvas whose pixels read back in the task that drew them.
// In CI (CI=true) a missing browser or adapter fails here; elsewhere the tests skip.

import assert from 'node:assert/strict';
import path from 'node:path';
import { after, before, test } from 'node:test';

import { CI, launch, missingBrowser, ROOT, serve } from './harness.mjs';

const missing = missingBrowser();
let server, browser;

before(async () => {
  if (missing) return;
  server = await serve(path.join(ROOT, 'tests', 'browser'));
  browser = await launch();
});
after(async () => {
  await browser?.close();
  await server?.close();
});

test('WebGPU compute and canvas read-back in headless Chromium', async (t) => {
  if (missing) {
    if (CI) assert.fail(missing);
    t.skip(missing);
    return;
  }
  const { page } = browser;
  await page.goto(server.url + 'probe.html');
  await page.waitForFunction(() => document.body.dataset.status !== 'loading', null, {
    timeout: 60_000,
  });
  const probe = await page.evaluate(() => window.probe);
  if (probe.error) {
    if (CI) assert.fail(`WebGPU: ${probe.error}`);
    t.skip(`WebGPU: ${probe.error}`);
    return;
  }
  console.log(`WebGPU adapter: ${probe.adapter}${probe.fallback ? ' (fallback)' : ''}`);
  assert.ok(probe.adapter.length > 0, 'the adapter names itself');
  // Integer squares: exact on any adapter.
  assert.deepEqual(probe.squares, Array.from({ length: 64 }, (_, i) => i * i));
  // Clear colour (1, 0.5, 0): 0.5 × 255 = 127.5 rounds to 127 or 128 depending on the
  // format's conversion, hence the one-unit allowance on green.
  const [r, g, b, a] = probe.pixel;
  assert.equal(r, 255);
  assert.ok(Math.abs(g - 127.5) <= 0.5, `green ${g}`);
  assert.equal(b, 0);
  assert.equal(a, 255);
});
