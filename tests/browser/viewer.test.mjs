// The WebGPU viewer (web/) in headless Chromium on SwiftShader, checked against the
// g1tess CLI: the bunny loaded through the file input, its canvas against `g1tess render`
// of the same view, triangle counts against `g1tess tessellate`, a bad file's one-line
// error, the GLB download read back by `g1tess stats`, a screenshot for the README
// (docs/viewer.png), and the timings printed for the notes.
//
// Needs web/pkg (scripts/build-web.sh), target/release/g1tess (or $G1TESS_BIN) and
// Chromium; scripts/test-browser.sh provides all three. In CI (CI=true) anything missing
// fails; elsewhere the tests skip.

import assert from 'node:assert/strict';
import fs from 'node:fs';
import path from 'node:path';
import { after, before, test } from 'node:test';

import { CI, G1TESS, g1tess, g1tessFails, launch, missingBrowser, ROOT, serve, tempDir } from './harness.mjs';
import {
  compareNormals,
  decodePng,
  matchingView,
  objPositions,
  orthoCamera,
  readRamp,
  renderedNormals,
} from './picture.mjs';

const WEB = path.join(ROOT, 'web');
const BUNNY = path.join(ROOT, 'tests', 'data', 'stanford-bunny.obj');
// The README's picture (docs/viewer.png) is rewritten with G1TESS_UPDATE_SCREENSHOT=1;
// otherwise the screenshot goes to out/ (ignored), so a test run leaves the tree clean.
const SCREENSHOT = process.env.G1TESS_UPDATE_SCREENSHOT === '1'
  ? path.join(ROOT, 'docs', 'viewer.png')
  : path.join(ROOT, 'out', 'viewer.png');
const STATUS_TIMEOUT = 180_000;

function missing() {
  if (!fs.existsSync(path.join(WEB, 'index.html')) || !fs.existsSync(path.join(WEB, 'pkg'))) {
    return 'web/index.html or web/pkg missing (run scripts/build-web.sh)';
  }
  if (!fs.existsSync(G1TESS)) return `no g1tess binary at ${G1TESS} (cargo build --release)`;
  return missingBrowser();
}
let why = missing();

/// Skips (or, in CI, fails) a test when something it needs is missing.
function need(t) {
  if (!why) return false;
  if (CI) assert.fail(why);
  t.skip(why);
  return true;
}

let server, browser, page, tmp;
const figures = {};

// Every change of body[data-status], with its time (performance.now()), from the page's
// first script on: window.__status = [{ status, t }]. Values set twice in one task are
// all kept (read from the records' old values).
function watchStatus() {
  window.__status = [];
  new MutationObserver((records) => {
    const body = records[0].target;
    const values = records.slice(1).map((r) => r.oldValue);
    values.push(body.getAttribute('data-status'));
    const t = performance.now();
    for (const status of values) window.__status.push({ status, t });
  }).observe(document, {
    subtree: true,
    attributes: true,
    attributeOldValue: true,
    attributeFilter: ['data-status'],
  });
}

/// Runs `action` and waits for the page's status to settle on something other than
/// `loading` after it; returns { status, t }.
async function settle(action) {
  const mark = await page.evaluate(() => window.__status.length);
  await action();
  const handle = await page.waitForFunction(
    (i) => {
      const after = window.__status.slice(i);
      const last = after[after.length - 1];
      return after.length > 0 && last.status !== 'loading' && last;
    },
    mark,
    { timeout: STATUS_TIMEOUT },
  );
  return handle.jsonValue();
}

const text = (sel) => page.$eval(sel, (e) => ('value' in e && e.tagName !== 'OUTPUT' ? e.value : e.textContent).trim());
const triangles = async () => Number((await page.textContent('#triangles')).replace(/\D/g, ''));

/// Waits until #triangles shows `expected` (counts may come back asynchronously); returns
/// what it shows last.
async function waitTriangles(expected, timeout = 60_000) {
  try {
    await page.waitForFunction(
      (n) => Number(document.querySelector('#triangles').textContent.replace(/\D/g, '')) === n,
      expected,
      { timeout },
    );
  } catch {
    /* the assertion below reports the value */
  }
  return triangles();
}

async function setUniform(scheme, level) {
  await page.selectOption('#scheme', scheme);
  // fill() types the value and dispatches `input`, which applies it.
  await page.fill('#level', String(level));
}

/// `g1tess tessellate` of the bunny: its JSON summary.
function cliTessellate(scheme, level, out) {
  return JSON.parse(g1tess('tessellate', BUNNY, '--scheme', scheme, '--level', String(level), '-o', out, '--json', '-q'));
}

before(async () => {
  if (why) return;
  tmp = tempDir('g1tess-browser-');
  server = await serve(WEB);
  browser = await launch();
  page = browser.page;
  page.on('pageerror', (e) => console.log(`page error: ${e.message}`));
  await page.addInitScript(watchStatus);
  await page.goto(server.url);
  const first = await page.waitForFunction(
    () => {
      const s = document.body.dataset.status;
      return s && s !== 'loading' && { status: s, t: performance.now() };
    },
    null,
    { timeout: STATUS_TIMEOUT },
  );
  figures.pageReady = await first.jsonValue();
  // Outside CI a viewer that cannot start (no WebGPU adapter) skips the tests; in CI the
  // first test fails on it.
  if (!CI && figures.pageReady.status.startsWith('error: ')) {
    why = `the viewer could not start: ${figures.pageReady.status}`;
  }
});

after(async () => {
  await browser?.close();
  await server?.close();
  if (tmp) fs.rmSync(tmp, { recursive: true, force: true });
  if (Object.keys(figures).length > 0) console.log(`figures: ${JSON.stringify(figures)}`);
});

test('the page starts ready on a WebGPU adapter', async (t) => {
  if (need(t)) return;
  assert.equal(figures.pageReady.status, 'ready');
});

test('the bunny loads through the file input', async (t) => {
  if (need(t)) return;
  const start = await page.evaluate(() => performance.now());
  const done = await settle(() => page.setInputFiles('#file', BUNNY));
  assert.equal(done.status, 'ready');
  figures.bunnyLoadToReadyMs = Math.round(done.t - start);
  figures.pageLoadToBunnyReadyMs = Math.round(done.t);
  const adapter = await text('#adapter');
  console.log(`adapter: ${adapter}`);
  assert.match(adapter, /\w/, 'the adapter is named');
  // 69,451 input triangles: the file's faces, every one a patch.
  assert.equal(Number((await text('#patches')).replace(/\D/g, '')), 69451);
});

test('the canvas matches g1tess render of the same view', async (t) => {
  if (need(t)) return;
  const level = 3;
  await page.selectOption('#shading', 'normals');
  await setUniform('g1', level);
  const size = await page.evaluate(async () => {
    const c = await window.g1tess.capture();
    return [c.width, c.height];
  });
  const [width, height] = size;
  // The CPU picture: one panel per normal component, of side = the canvas's height.
  const png = path.join(tmp, 'render.png');
  g1tess('render', BUNNY, '--scheme', 'g1', '--level', String(level), '--size', String(height),
    '--view', '0,0,1', '--up', '0,1,0', '--backend', 'cpu', '-q', '-o', png);
  // The camera `render` fitted: the bounding box of the same surface (level 3, g1).
  const obj = path.join(tmp, 'surface.obj');
  cliTessellate('g1', level, obj);
  const cam = orthoCamera(objPositions(fs.readFileSync(obj, 'utf8')), [0, 0, 1], [0, 1, 0]);
  const { view, offset } = matchingView(cam, width, height);
  const capture = await page.evaluate(async (v) => {
    window.g1tess.setView(v);
    const c = await window.g1tess.capture();
    let s = '';
    for (let i = 0; i < c.data.length; i += 0x8000) s += String.fromCharCode(...c.data.subarray(i, i + 0x8000));
    return { width: c.width, height: c.height, data: btoa(s) };
  }, view);
  capture.data = new Uint8Array(Buffer.from(capture.data, 'base64'));
  assert.equal(capture.data.length, 4 * width * height);
  const cpu = renderedNormals(decodePng(fs.readFileSync(png)), height, readRamp());
  const r = compareNormals(capture, cpu, offset);
  figures.picture = { width, height, ...r };
  console.log(`canvas vs g1tess render (${width}x${height}): ${JSON.stringify(r)}`);
  // Coverage: the two pictures are drawn from the same surface and camera (the
  // perspective's 0.2° field of view departs from the orthographic map by under 0.2 % of
  // the half-extent, a third of a pixel), but the CPU picture is 4× multisampled and the
  // canvas single-sampled, so a silhouette pixel may fall either way: the pixels covered
  // by one picture only are at most the CPU silhouette's boundary pixels, twice (one on
  // each side).
  assert.ok(r.boundary > 0 && r.mismatched <= 2 * r.boundary, `${r.mismatched} pixels differ in coverage, ${r.boundary} on the silhouette`);
  // Colours, well inside both silhouettes: the canvas shows 0.5 n + 0.5 in 8 bits, the
  // CPU panels n through a 9-stop ramp that the test inverts (median error of |n| about
  // 7e-4, 0.1 of a colour unit). Pixels straddling an edge between surface regions (an
  // ear in front of the head) may show either region on either side after a sub-pixel
  // shift, and the ramp's inversion is off where 4× multisampling blended two colours, so
  // the bound is on the mean (4 colour units of 255) and the 99th percentile (16), the
  // largest difference of a component, not on every pixel.
  assert.ok(r.compared > 1000, `${r.compared} pixels compared`);
  assert.ok(r.meanDiff <= 4, `mean colour difference ${r.meanDiff}`);
  assert.ok(r.p99Diff <= 16, `99th percentile colour difference ${r.p99Diff}`);
});

test('scheme and level switches give the CLI triangle counts', async (t) => {
  if (need(t)) return;
  const cases = [['g1', 1], ['pn', 2], ['phong', 3], ['nagata', 2], ['flat', 4], ['g1', 5]];
  for (const [scheme, level] of cases) {
    await setUniform(scheme, level);
    const cli = cliTessellate(scheme, level, path.join(tmp, `t-${scheme}-${level}.ply`));
    const shown = await waitTriangles(cli.triangles);
    assert.equal(shown, cli.triangles, `#triangles for ${scheme} level ${level}`);
    const counts = await page.evaluate(() => window.g1tess.counts());
    assert.equal(counts.triangles, cli.triangles, `counts() for ${scheme} level ${level}`);
    console.log(`${scheme} level ${level}: ${shown} triangles (CLI ${cli.triangles}), ${counts.vertices} vertices (CLI ${cli.vertices} welded, ${cli.vertex_records} records)`);
  }
  // The scheme reaches the picture: at level 2, flat and G1 draw different normals.
  const hash = async () => page.evaluate(async () => {
    const c = await window.g1tess.capture();
    let h = 0;
    for (let i = 0; i < c.data.length; i++) h = (h * 31 + c.data[i]) | 0;
    return h;
  });
  await setUniform('flat', 2);
  const flat = await hash();
  await setUniform('g1', 2);
  assert.notEqual(await hash(), flat, 'flat and G1 pictures differ');
});

test('the downloaded GLB reads back with the CLI counts', async (t) => {
  if (need(t)) return;
  const [scheme, level] = ['pn', 3];
  await setUniform(scheme, level);
  const cliGlb = path.join(tmp, 'cli.glb');
  const cli = cliTessellate(scheme, level, cliGlb);
  assert.equal(await waitTriangles(cli.triangles), cli.triangles);
  const [download] = await Promise.all([page.waitForEvent('download', { timeout: 120_000 }), page.click('#download')]);
  const file = path.join(tmp, 'viewer.glb');
  await download.saveAs(file);
  const mine = JSON.parse(g1tess('stats', file, '--json', '-q'));
  const theirs = JSON.parse(g1tess('stats', cliGlb, '--json', '-q'));
  console.log(`GLB: viewer ${mine.triangles} triangles, ${mine.vertices} vertices; CLI ${theirs.triangles}, ${theirs.vertices}; tessellate ${cli.triangles}, ${cli.vertices}`);
  assert.equal(mine.triangles, cli.triangles, 'triangles of the viewer GLB = g1tess tessellate');
  assert.equal(theirs.triangles, cli.triangles);
  // Vertices: both files weld the shared grid points of neighbouring patches, so the
  // counts after reading agree with tessellate's welded count.
  assert.equal(mine.vertices, cli.vertices, 'vertices of the viewer GLB = g1tess tessellate');
});

test('screen-space levels: frame time and triangles per second, screenshot', async (t) => {
  if (need(t)) return;
  await page.selectOption('#shading', 'lit');
  await page.selectOption('#scheme', 'g1');
  // The viewer's own framing (setView was changed by the picture test): reload the file.
  await settle(() => page.setInputFiles('#file', BUNNY));
  await page.selectOption('#mode', 'screen');
  await page.fill('#target', '8');
  // Frame time: forced frames one after another, each awaited to the GPU's completion
  // (counts() draws a frame and reads back 8 bytes of counts after it), after 3 warm-up
  // frames (the first frames build the per-edge pipelines). The median of 10.
  const timing = await page.evaluate(async () => {
    for (let i = 0; i < 3; i++) await window.g1tess.counts();
    const ms = [];
    let counts;
    for (let i = 0; i < 10; i++) {
      const t0 = performance.now();
      counts = await window.g1tess.counts();
      ms.push(performance.now() - t0);
    }
    ms.sort((p, q) => p - q);
    return { ms, counts, shown: Number(document.querySelector('#frame-ms').textContent) };
  });
  const frameMs = timing.ms[5];
  const counts = timing.counts;
  figures.screen = {
    targetPx: 8,
    triangles: counts.triangles,
    frameMsMedian: Math.round(frameMs * 10) / 10,
    frameMsRange: [Math.round(timing.ms[0]), Math.round(timing.ms[9])],
    pageFrameMs: timing.shown,
    trianglesPerSecond: Math.round(counts.triangles / (frameMs / 1000)),
  };
  console.log(`screen-space (8 px): ${JSON.stringify(figures.screen)}`);
  // Screen-space levels are at least 1 per edge: at least one triangle per patch.
  assert.ok(counts.triangles >= 69451, `${counts.triangles} triangles`);
  assert.ok(frameMs > 0, 'a frame time was measured');
  // The canvas (800 × 600 with a 12-pixel margin) and the panel beside it.
  fs.mkdirSync(path.dirname(SCREENSHOT), { recursive: true });
  await page.screenshot({ path: SCREENSHOT, clip: { x: 0, y: 0, width: 1096, height: 624 } });
  assert.ok(fs.statSync(SCREENSHOT).size > 10_000, `${SCREENSHOT} written`);
});

test('a bad file gives a one-line error in the page', async (t) => {
  if (need(t)) return;
  const done = await settle(() => page.setInputFiles('#file', {
    name: 'bad.obj',
    mimeType: 'text/plain',
    buffer: Buffer.from('v 0 0\nf 1 2 9\n'),
  }));
  console.log(`bad file: ${done.status}`);
  assert.ok(done.status.startsWith('error: '), done.status);
  assert.ok(!/[\r\n]/.test(done.status), 'one line');
  // The library's message, as the CLI prints it: the file, the line, what is wrong.
  const bad = path.join(tmp, 'bad.obj');
  fs.writeFileSync(bad, 'v 0 0\nf 1 2 9\n');
  const cli = g1tessFails(tmp, 'stats', 'bad.obj').split('\n').find((l) => l.startsWith('error: '));
  assert.equal(done.status, cli, 'the same message as the CLI');
});
