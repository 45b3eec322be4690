// The CPU side of the picture comparison: `g1tess render`'s PNG decoded, its normal
// panels turned back into unit normals, its orthographic camera reproduced, and the
// comparison of a canvas against it.

import fs from 'node:fs';
import path from 'node:path';
import zlib from 'node:zlib';

import { ROOT } from './harness.mjs';

/// Decodes an 8-bit, non-interlaced RGB or RGBA PNG (what `g1tess render` writes) into
/// { width, height, channels, data }.
export function decodePng(bytes) {
  const sig = [137, 80, 78, 71, 13, 10, 26, 10];
  if (!sig.every((b, i) => bytes[i] === b)) throw new Error('not a PNG');
  let pos = 8;
  let width, height, depth, colour, interlace;
  const idat = [];
  while (pos < bytes.length) {
    const len = bytes.readUInt32BE(pos);
    const type = bytes.toString('latin1', pos + 4, pos + 8);
    const body = bytes.subarray(pos + 8, pos + 8 + len);
    if (type === 'IHDR') {
      width = body.readUInt32BE(0);
      height = body.readUInt32BE(4);
      [depth, colour] = [body[8], body[9]];
      interlace = body[12];
    } else if (type === 'IDAT') {
      idat.push(body);
    } else if (type === 'IEND') {
      break;
    }
    pos += 12 + len;
  }
  const channels = { 2: 3, 6: 4 }[colour];
  if (depth !== 8 || !channels || interlace !== 0) {
    throw new Error(`PNG: depth ${depth}, colour type ${colour}, interlace ${interlace} not read`);
  }
  const raw = zlib.inflateSync(Buffer.concat(idat));
  const stride = width * channels;
  const data = new Uint8Array(height * stride);
  for (let y = 0; y < height; y++) {
    const filter = raw[y * (stride + 1)];
    const line = raw.subarray(y * (stride + 1) + 1, (y + 1) * (stride + 1));
    const out = data.subarray(y * stride, (y + 1) * stride);
    const prev = y > 0 ? data.subarray((y - 1) * stride, y * stride) : new Uint8Array(stride);
    for (let x = 0; x < stride; x++) {
      const a = x >= channels ? out[x - channels] : 0;
      const b = prev[x];
      const c = x >= channels ? prev[x - channels] : 0;
      let p;
      switch (filter) {
        case 0: p = 0; break;
        case 1: p = a; break;
        case 2: p = b; break;
        case 3: p = (a + b) >> 1; break;
        case 4: {
          const pa = Math.abs(b - c), pb = Math.abs(a - c), pc = Math.abs(a + b - 2 * c);
          p = pa <= pb && pa <= pc ? a : pb <= pc ? b : c;
          break;
        }
        default: throw new Error(`PNG: filter ${filter}`);
      }
      out[x] = (line[x] + p) & 255;
    }
  }
  return { width, height, channels, data };
}

/// The colour ramp of `g1tess render`, read from its one copy (src/render/mod.rs, RAMP).
export function readRamp() {
  const src = fs.readFileSync(path.join(ROOT, 'src', 'render', 'mod.rs'), 'utf8');
  const m = src.match(/pub const RAMP: \[\[u8; 3\]; \d+\] = \[([\s\S]*?)\];/);
  if (!m) throw new Error('src/render/mod.rs: RAMP not found');
  const stops = [...m[1].matchAll(/\[(\d+),\s*(\d+),\s*(\d+)\]/g)].map((s) => s.slice(1).map(Number));
  if (stops.length < 2) throw new Error('src/render/mod.rs: RAMP has fewer than 2 stops');
  return stops;
}

/// Inverts the ramp: a function from an RGB colour to the value in [−1, 1] whose ramp
/// colour is nearest (sampled every 1/2000, finer than one 8-bit step of any segment).
export function rampInverse(stops) {
  const segments = stops.length - 1;
  const samples = 4001;
  const table = new Float64Array(samples * 3);
  for (let k = 0; k < samples; k++) {
    const v = -1 + (2 * k) / (samples - 1);
    const t = Math.min(Math.max((v + 1) * 0.5 * segments, 0), segments);
    const i = Math.min(Math.floor(t), segments - 1);
    const f = t - i;
    for (let c = 0; c < 3; c++) table[3 * k + c] = stops[i][c] + (stops[i + 1][c] - stops[i][c]) * f;
  }
  const cache = new Map();
  return (r, g, b) => {
    const key = (r << 16) | (g << 8) | b;
    let v = cache.get(key);
    if (v === undefined) {
      let best = Infinity;
      for (let k = 0; k < samples; k++) {
        const d = (table[3 * k] - r) ** 2 + (table[3 * k + 1] - g) ** 2 + (table[3 * k + 2] - b) ** 2;
        if (d < best) [best, v] = [d, -1 + (2 * k) / (samples - 1)];
      }
      cache.set(key, v);
    }
    return v;
  };
}

// The layout of `g1tess render`'s picture (src/render/compose.rs): panels of side P in one
// row, MARGIN apart, the first at (MARGIN, 2 × TITLE).
const MARGIN = 16;
const TITLE = 34;

/// The normal field of a `g1tess render` picture with one row of panels of side `panel`:
/// { size, covered: Uint8Array, normal: Float32Array (3 per pixel, unit) }. A pixel is
/// covered when it differs from the white background in any of the three panels.
export function renderedNormals(png, panel, stops) {
  const inverse = rampInverse(stops);
  const covered = new Uint8Array(panel * panel);
  const normal = new Float32Array(3 * panel * panel);
  for (let y = 0; y < panel; y++) {
    for (let x = 0; x < panel; x++) {
      const n = [0, 0, 0];
      let hit = false;
      for (let c = 0; c < 3; c++) {
        const px = MARGIN + c * (panel + MARGIN) + x;
        const i = ((2 * TITLE + y) * png.width + px) * png.channels;
        const [r, g, b] = png.data.subarray(i, i + 3);
        if (r !== 255 || g !== 255 || b !== 255) hit = true;
        n[c] = inverse(r, g, b);
      }
      const len = Math.hypot(...n) || 1;
      covered[y * panel + x] = hit ? 1 : 0;
      for (let c = 0; c < 3; c++) normal[3 * (y * panel + x) + c] = n[c] / len;
    }
  }
  return { size: panel, covered, normal };
}

const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
const unit = (a) => { const l = Math.hypot(...a); return a.map((x) => x / l); };

/// `g1tess render`'s orthographic camera (src/render/camera.rs, Camera::fit) for
/// `positions` (flat x, y, z), looking along −view with `up`: { right, up, towards,
/// centre (frame coordinates), halfExtent }.
export function orthoCamera(positions, view, up) {
  const z = unit(view);
  const u0 = up.map((x, i) => x - dot(up, z) * z[i]);
  const y = unit(u0);
  const x = cross(y, z);
  const lo = [Infinity, Infinity, Infinity];
  const hi = [-Infinity, -Infinity, -Infinity];
  for (let i = 0; i < positions.length; i += 3) {
    const p = [positions[i], positions[i + 1], positions[i + 2]];
    const q = [dot(p, x), dot(p, y), dot(p, z)];
    for (let c = 0; c < 3; c++) {
      lo[c] = Math.min(lo[c], q[c]);
      hi[c] = Math.max(hi[c], q[c]);
    }
  }
  const half = hi.map((h, c) => 0.5 * (h - lo[c]));
  return {
    right: x,
    up: y,
    towards: z,
    centre: hi.map((h, c) => 0.5 * (h + lo[c])),
    // Camera::MARGIN (1.04): the larger half-extent across the view, 4 % added.
    halfExtent: Math.max(half[0], half[1]) * 1.04,
  };
}

/// Vertex positions of an OBJ file (its `v` lines), flat x, y, z.
export function objPositions(text) {
  const out = [];
  for (const line of text.split('\n')) {
    if (line.startsWith('v ')) {
      const [, a, b, c] = line.trim().split(/\s+/);
      out.push(+a, +b, +c);
    }
  }
  return out;
}

/// The perspective view (viewer's setView) that reproduces `cam` on a canvas of
/// `width` × `height` pixels whose rows match a `g1tess render` panel of side `height`:
/// a narrow field of view (0.2°) from far away, so that the perspective's scale varies
/// by under 0.2 % across the surface's depth, and the target moved by half a pixel when
/// width − height is odd, so that pixel centres coincide. Also returns the column offset
/// of panel column 0 in the canvas.
export function matchingView(cam, width, height) {
  const fovyDeg = 0.2;
  const distance = cam.halfExtent / Math.tan(((fovyDeg / 2) * Math.PI) / 180);
  const pixel = (2 * cam.halfExtent) / height;
  const offset = Math.floor((width - height) / 2);
  const shift = ((width - height) / 2 - offset) * pixel;
  const world = (f) => [0, 1, 2].map((i) => f[0] * cam.right[i] + f[1] * cam.up[i] + f[2] * cam.towards[i]);
  const target = world([cam.centre[0] + shift, cam.centre[1], cam.centre[2]]);
  const eye = target.map((t, i) => t + distance * cam.towards[i]);
  return { view: { eye, target, up: cam.up, fovyDeg }, offset };
}

/// Compares a canvas capture ({ width, height, data: RGBA }) in the viewer's normal
/// colours (0.5 n + 0.5) against the CPU normals `cpu` (renderedNormals), the panel's
/// column 0 at canvas column `offset`. The canvas's background is its corner pixel.
/// Returns { iou, mismatched, boundary, meanDiff, p99Diff, compared }.
export function compareNormals(capture, cpu, offset) {
  const { width, height, data } = capture;
  const bg = data.subarray(0, 3);
  const P = cpu.size;
  const canvasCovered = (x, y) => {
    const i = 4 * (y * width + x);
    return data[i] !== bg[0] || data[i + 1] !== bg[1] || data[i + 2] !== bg[2];
  };
  const cpuAt = (x, y) => x >= 0 && x < P && y >= 0 && y < P && cpu.covered[y * P + x] === 1;
  let inter = 0, union = 0, boundary = 0;
  const diffs = [];
  for (let y = 0; y < Math.min(height, P); y++) {
    for (let cx = 0; cx < width; cx++) {
      const x = cx - offset;
      if (x < 0 || x >= P) continue;
      const a = cpuAt(x, y);
      const b = canvasCovered(cx, y);
      if (a && b) inter++;
      if (a || b) union++;
      const interior = (f) => f(x - 1, y) && f(x + 1, y) && f(x, y - 1) && f(x, y + 1);
      if (a && !interior(cpuAt)) boundary++;
      // Colours only well inside both silhouettes (edge pixels of the CPU picture are
      // blends of its 4× multisampling with the background).
      const canvasAt = (px, py) => px + offset >= 0 && px + offset < width && py >= 0 && py < height && canvasCovered(px + offset, py);
      if (a && b && interior(cpuAt) && interior(canvasAt)) {
        const i = 4 * (y * width + cx);
        let d = 0;
        for (let c = 0; c < 3; c++) {
          const expect = 255 * (0.5 * cpu.normal[3 * (y * P + x) + c] + 0.5);
          d = Math.max(d, Math.abs(data[i + c] - expect));
        }
        diffs.push(d);
      }
    }
  }
  diffs.sort((p, q) => p - q);
  const mean = diffs.reduce((s, d) => s + d, 0) / Math.max(diffs.length, 1);
  return {
    iou: inter / Math.max(union, 1),
    mismatched: union - inter,
    boundary,
    meanDiff: mean,
    p99Diff: diffs[Math.floor(0.99 * (diffs.length - 1))] ?? NaN,
    compared: diffs.length,
  };
}
