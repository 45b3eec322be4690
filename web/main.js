// The page around the wasm viewer (pkg/g1tess_web.js, built by scripts/build-web.sh):
// controls, the frame loop, the info panel, and `window.g1tess` for tests and scripts.
import init, { start } from "./pkg/g1tess_web.js";

const $ = (id) => document.getElementById(id);
const canvas = $("view");
let viewer = null;
let meshName = "";
// Bumped by every change of what is tessellated: a count read back for an older state
// is not shown.
let generation = 0;
let countsPending = false;

function setStatus(s) {
  document.body.dataset.status = s;
  $("status").textContent = s.startsWith("error") ? s : "";
}

function fail(e) {
  const msg = String(e && e.message ? e.message : e).split("\n")[0];
  setStatus(`error: ${msg}`);
}

// Runs `f` (a viewer call), reporting its error in the page; true when it succeeded.
function attempt(f) {
  try {
    f();
    return true;
  } catch (e) {
    fail(e);
    return false;
  }
}

function showTriangles(n) {
  $("triangles").textContent = String(n);
}

// After a drawn frame: the triangle count (host-known for a uniform level, read back for
// screen-space levels, one read at a time) and the info panel.
function afterFrame() {
  const now = viewer.triangles_now();
  if (now !== undefined) {
    showTriangles(now);
  } else if (!countsPending) {
    countsPending = true;
    const asked = generation;
    viewer.counts().then(
      (c) => { if (asked === generation && viewer.triangles_now() === undefined) showTriangles(c.triangles); },
      fail,
    ).finally(() => { countsPending = false; });
  }
  $("frame-ms").textContent = viewer.frame_ms().toFixed(1);
}

// Draws one frame now (after a change), then updates the panel.
function drawNow() {
  generation++;
  if (attempt(() => viewer.frame(true))) afterFrame();
}

function loop() {
  if (viewer) {
    try {
      if (viewer.frame(false)) afterFrame();
    } catch (e) {
      fail(e);
    }
  }
  requestAnimationFrame(loop);
}

async function loadBytes(name, bytes) {
  setStatus("loading");
  // Let the page show "loading" before the (synchronous) patch building.
  await new Promise((r) => setTimeout(r, 0));
  if (!attempt(() => viewer.load(name, bytes))) return;
  meshName = name;
  $("patches").textContent = String(viewer.patches());
  $("cap").textContent = String(viewer.level_cap());
  $("validity").textContent = viewer.validity() ?? "";
  drawNow();
  // The first count of screen-space levels is read back before the page says ready.
  try {
    const c = await viewer.counts();
    if (viewer.triangles_now() === undefined) showTriangles(c.triangles);
    setStatus("ready");
  } catch (e) {
    fail(e);
  }
}

async function loadFile(file) {
  if (!viewer) return;
  setStatus("loading");
  const bytes = new Uint8Array(await file.arrayBuffer());
  await loadBytes(file.name, bytes);
}

function applyChange(f) {
  if (!viewer) return;
  if (!attempt(f)) return;
  if (document.body.dataset.status.startsWith("error")) setStatus("ready");
  drawNow();
}

function applyLevels() {
  if ($("mode").value === "uniform") {
    const level = parseInt($("level").value, 10);
    if (!Number.isFinite(level)) return;
    applyChange(() => viewer.set_uniform(level));
  } else {
    const target = parseFloat($("target").value);
    if (!Number.isFinite(target)) return;
    applyChange(() => viewer.set_screen(target));
  }
}

function wire() {
  $("file").addEventListener("change", (e) => {
    const f = e.target.files[0];
    // Cleared, so that choosing the same file again reloads it.
    e.target.value = "";
    if (f) {
      setStatus("loading");
      loadFile(f);
    }
  });
  canvas.addEventListener("dragover", (e) => { e.preventDefault(); canvas.classList.add("drop"); });
  canvas.addEventListener("dragleave", () => canvas.classList.remove("drop"));
  canvas.addEventListener("drop", (e) => {
    e.preventDefault();
    canvas.classList.remove("drop");
    const f = e.dataTransfer.files[0];
    if (f) loadFile(f);
  });
  $("scheme").addEventListener("change", () => {
    applyChange(() => viewer.set_scheme($("scheme").value));
    $("validity").textContent = viewer.validity() ?? "";
  });
  // A number in #level switches to uniform tessellation at that level.
  $("level").addEventListener("input", () => {
    if (Number.isFinite(parseInt($("level").value, 10))) $("mode").value = "uniform";
    applyLevels();
  });
  $("target").addEventListener("input", () => { $("mode").value = "screen"; applyLevels(); });
  $("mode").addEventListener("change", applyLevels);
  $("shading").addEventListener("change", () => {
    applyChange(() => viewer.set_shading($("shading").value));
    $("validity").textContent = viewer.validity() ?? "";
  });
  $("download").addEventListener("click", async () => {
    try {
      const bytes = await api.glb();
      const a = document.createElement("a");
      a.href = URL.createObjectURL(new Blob([bytes], { type: "model/gltf-binary" }));
      const stem = meshName.replace(/\.[^.]*$/, "") || "mesh";
      const levels = $("mode").value === "uniform" ? `level${$("level").value}` : "screen";
      a.download = `${stem}-${$("scheme").value}-${levels}.glb`;
      a.click();
      setTimeout(() => URL.revokeObjectURL(a.href), 10000);
    } catch (e) {
      fail(e);
    }
  });
  let drag = null;
  canvas.addEventListener("pointerdown", (e) => { drag = [e.clientX, e.clientY]; canvas.setPointerCapture(e.pointerId); });
  canvas.addEventListener("pointerup", () => { drag = null; });
  canvas.addEventListener("pointermove", (e) => {
    if (!drag || !viewer) return;
    viewer.orbit(e.clientX - drag[0], e.clientY - drag[1]);
    drag = [e.clientX, e.clientY];
    generation++;
  });
  canvas.addEventListener("wheel", (e) => {
    e.preventDefault();
    if (viewer) { viewer.zoom(e.deltaY); generation++; }
  }, { passive: false });
}

// For tests and scripts.
const api = {
  // Fixes the camera: {eye: [x,y,z], target: [x,y,z], up: [x,y,z], fovyDeg}.
  setView({ eye, target, up = [0, 1, 0], fovyDeg = 40 }) {
    viewer.set_view(new Float32Array(eye), new Float32Array(target), new Float32Array(up), fovyDeg);
    generation++;
  },
  // Draws one frame and reads the canvas back in the same task (a presented WebGPU canvas
  // reads back empty): {width, height, data: Uint8Array of RGBA rows, top row first}.
  async capture() {
    viewer.frame(true);
    const { width, height } = canvas;
    const copy = document.createElement("canvas");
    copy.width = width;
    copy.height = height;
    const ctx = copy.getContext("2d");
    ctx.drawImage(canvas, 0, 0);
    const rgba = ctx.getImageData(0, 0, width, height).data;
    afterFrame();
    return { width, height, data: new Uint8Array(rgba.buffer) };
  },
  // The counts of the current view's tessellation, read back: {vertices, triangles}.
  async counts() {
    viewer.frame(true);
    return await viewer.counts();
  },
  // The current view's tessellation as a GLB (Uint8Array).
  async glb() {
    viewer.frame(true);
    return await viewer.glb();
  },
  // Loads a mesh from bytes (format from the name's extension), as the file input does.
  load: (name, bytes) => loadBytes(name, bytes),
};
window.g1tess = api;

// The adapter as the browser describes it (wgpu names it by GPUAdapterInfo.description,
// which Chromium may leave empty).
async function adapterInfo() {
  try {
    const a = await navigator.gpu.requestAdapter();
    const i = a.info ?? {};
    const words = [i.vendor, i.architecture, i.device, i.description].filter((w) => w);
    return words.length ? words.join(" ") : "WebGPU adapter";
  } catch {
    return "WebGPU adapter";
  }
}

async function main() {
  wire();
  try {
    await init();
    viewer = await start(canvas);
  } catch (e) {
    fail(e);
    return;
  }
  $("adapter").textContent = viewer.adapter() || (await adapterInfo());
  requestAnimationFrame(loop);
  // ?mesh=URL (same origin) opens a mesh at start.
  const url = new URLSearchParams(location.search).get("mesh");
  if (url) {
    try {
      const r = await fetch(url);
      if (!r.ok) throw new Error(`${url}: HTTP ${r.status}`);
      await loadBytes(url.split("/").pop(), new Uint8Array(await r.arrayBuffer()));
    } catch (e) {
      fail(e);
    }
  } else {
    setStatus("ready");
  }
}

main();
