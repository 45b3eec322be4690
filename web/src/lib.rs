//! g1tess in the browser: a mesh opened from bytes, its patches tessellated every frame on
//! the GPU by `GpuTessellator` (screen-space levels computed on the device, or one uniform
//! level), drawn straight from the tessellator's buffers through WebGPU.
//!
//! `web/main.js` drives a [`Viewer`] made by [`start`]: the page's controls call its
//! setters, `requestAnimationFrame` calls [`Viewer::frame`].

mod camera;
mod glb;
mod render;
mod scene;

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

use g1tess::glam::Vec3;
use g1tess::wgpu;
use g1tess::{GpuTessellator, Precision, Scheme};
use wasm_bindgen::prelude::*;

use camera::Camera;
use render::{Renderer, Shading};
use scene::{Mode, Scene};

/// Screen-space levels aim at segments of this many pixels until the page says otherwise.
const DEFAULT_TARGET_PX: f32 = 8.0;

/// An error for JavaScript: the message as a string.
fn js_err(e: impl std::fmt::Display) -> JsValue {
    JsValue::from_str(&e.to_string())
}

/// Milliseconds since the page's time origin.
fn now_ms() -> f64 {
    web_sys::window()
        .and_then(|w| w.performance())
        .map_or(0.0, |p| p.now())
}

/// The viewer: the device, the canvas's surface, the scene and the view.
#[wasm_bindgen]
pub struct Viewer {
    device: wgpu::Device,
    queue: wgpu::Queue,
    surface: wgpu::Surface<'static>,
    canvas: web_sys::HtmlCanvasElement,
    config: wgpu::SurfaceConfiguration,
    adapter: String,
    renderer: Renderer,
    /// wgpu errors reported outside any scope (validation, out of memory), one line each.
    errors: Arc<Mutex<Vec<String>>>,
    /// A submitted frame the GPU has not finished.
    busy: Arc<AtomicBool>,
    /// The last frame's time from submission to completion (f64 bits, ms).
    frame_ms: Arc<AtomicU64>,
    scene: Option<Scene>,
    scheme: Scheme,
    mode: Mode,
    shading: Shading,
    camera: Camera,
}

/// Opens WebGPU on `canvas`: an adapter, a device with the tessellator's limits (the
/// adapter's buffer sizes), the surface and the pipelines.
#[wasm_bindgen]
pub async fn start(canvas: web_sys::HtmlCanvasElement) -> Result<Viewer, JsValue> {
    let instance = wgpu::Instance::new(wgpu::InstanceDescriptor {
        backends: wgpu::Backends::BROWSER_WEBGPU,
        ..wgpu::InstanceDescriptor::new_without_display_handle()
    });
    let surface = instance
        .create_surface(wgpu::SurfaceTarget::Canvas(canvas.clone()))
        .map_err(|e| js_err(format!("no WebGPU canvas: {e}")))?;
    let adapter = instance
        .request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            force_fallback_adapter: false,
            compatible_surface: Some(&surface),
            ..Default::default()
        })
        .await
        .map_err(|e| js_err(format!("no WebGPU adapter: {e}")))?;
    let offered = adapter.limits();
    let limits = wgpu::Limits {
        max_storage_buffer_binding_size: offered.max_storage_buffer_binding_size,
        max_buffer_size: offered.max_buffer_size,
        ..GpuTessellator::required_limits()
    };
    let (device, queue) = adapter
        .request_device(&wgpu::DeviceDescriptor {
            label: Some("g1tess-web"),
            required_features: GpuTessellator::required_features(Precision::F32),
            required_limits: limits,
            ..Default::default()
        })
        .await
        .map_err(|e| js_err(format!("cannot open the WebGPU device: {e}")))?;
    let errors = Arc::new(Mutex::new(Vec::new()));
    let sink = errors.clone();
    device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
        if let Ok(mut v) = sink.lock() {
            v.push(e.to_string().replace('\n', " "));
        }
    }));
    let size = (canvas.width().max(1), canvas.height().max(1));
    let caps = surface.get_capabilities(&adapter);
    // A linear (not sRGB) format: normal colours 0.5 n + 0.5 land in the pixels as written.
    let format = caps
        .formats
        .iter()
        .copied()
        .find(|f| !f.is_srgb())
        .or_else(|| caps.formats.first().copied())
        .ok_or_else(|| js_err("the canvas offers no texture format"))?;
    let config = wgpu::SurfaceConfiguration {
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
        format,
        alpha_mode: wgpu::CompositeAlphaMode::Opaque,
        ..surface
            .get_default_config(&adapter, size.0, size.1)
            .ok_or_else(|| js_err("the canvas cannot be drawn by this adapter"))?
    };
    surface.configure(&device, &config);
    let renderer = Renderer::new(&device, format, size);
    Ok(Viewer {
        adapter: adapter.get_info().name,
        device,
        queue,
        surface,
        canvas,
        config,
        renderer,
        errors,
        busy: Arc::new(AtomicBool::new(false)),
        frame_ms: Arc::new(AtomicU64::new(0f64.to_bits())),
        scene: None,
        scheme: Scheme::G1,
        mode: Mode::Screen {
            target_px: DEFAULT_TARGET_PX,
        },
        shading: Shading::Normals,
        camera: Camera::fit(Vec3::ZERO, 1.0),
    })
}

#[wasm_bindgen]
impl Viewer {
    /// Loads a mesh from a file's bytes (format from `name`'s extension), builds its
    /// patches with the current scheme and frames it.
    pub fn load(&mut self, name: &str, bytes: &[u8]) -> Result<(), JsValue> {
        let scene =
            Scene::load(&self.device, &self.queue, name, bytes, self.scheme).map_err(js_err)?;
        let (centre, radius) = scene.bounds();
        self.camera = Camera::fit(centre, radius);
        self.scene = Some(scene);
        self.take_errors()
    }

    /// Switches the scheme (a CLI name: g1, pn, phong, nagata, flat, ...).
    pub fn set_scheme(&mut self, name: &str) -> Result<(), JsValue> {
        let scheme = Scheme::parse(name).map_err(js_err)?;
        if let Some(scene) = &mut self.scene {
            scene
                .set_scheme(&self.device, &self.queue, scheme)
                .map_err(js_err)?;
        }
        self.scheme = scheme;
        if let (Shading::Validity, Some(scene)) = (self.shading, &mut self.scene) {
            scene.certify(&self.device);
        }
        self.take_errors()
    }

    /// Uniform tessellation at `level` from the next frame on.
    pub fn set_uniform(&mut self, level: u32) -> Result<(), JsValue> {
        if let Some(scene) = &self.scene {
            scene.check_level(level).map_err(js_err)?;
        }
        self.mode = Mode::Uniform { level };
        Ok(())
    }

    /// Screen-space levels aiming at `target_px` pixels per segment, from the next frame on.
    pub fn set_screen(&mut self, target_px: f32) -> Result<(), JsValue> {
        if !(target_px.is_finite() && target_px > 0.0) {
            return Err(js_err(format!(
                "a screen-space target of {target_px} pixels: give a positive number"
            )));
        }
        self.mode = Mode::Screen { target_px };
        Ok(())
    }

    /// Shading: normals, lit, wireframe or validity (which certifies every patch once
    /// per scheme, on the CPU).
    pub fn set_shading(&mut self, name: &str) -> Result<(), JsValue> {
        self.shading = Shading::parse(name).map_err(js_err)?;
        if let (Shading::Validity, Some(scene)) = (self.shading, &mut self.scene) {
            scene.certify(&self.device);
        }
        Ok(())
    }

    /// Fixes the camera: eye, target and up (3 numbers each), vertical field of view.
    pub fn set_view(
        &mut self,
        eye: &[f32],
        target: &[f32],
        up: &[f32],
        fovy_deg: f32,
    ) -> Result<(), JsValue> {
        let v = |a: &[f32], what: &str| match a {
            [x, y, z] if a.iter().all(|c| c.is_finite()) => Ok(Vec3::new(*x, *y, *z)),
            _ => Err(js_err(format!("setView: {what} must be 3 finite numbers"))),
        };
        let (eye, target, up) = (v(eye, "eye")?, v(target, "target")?, v(up, "up")?);
        if eye == target || up.cross(target - eye).length() == 0.0 {
            return Err(js_err(
                "setView: eye equals target, or up is along the view",
            ));
        }
        if !(fovy_deg > 0.0 && fovy_deg < 180.0) {
            return Err(js_err("setView: fovyDeg must be between 0 and 180"));
        }
        self.camera.eye = eye;
        self.camera.target = target;
        self.camera.up = up;
        self.camera.fovy_deg = fovy_deg;
        Ok(())
    }

    /// Turns the camera about its target by a drag of (`dx`, `dy`) pixels.
    pub fn orbit(&mut self, dx: f32, dy: f32) {
        self.camera.orbit(dx * 0.01, dy * 0.01);
    }

    /// Zooms by a wheel's `delta` (positive: away).
    pub fn zoom(&mut self, delta: f32) {
        self.camera.zoom((delta * 0.001).exp());
    }

    /// Draws a frame: tessellates (every frame with screen-space levels, once per change
    /// with a uniform level), draws the surface and presents. Returns false, drawing
    /// nothing, while the previous frame is still on the GPU, unless `force`.
    pub fn frame(&mut self, force: bool) -> Result<bool, JsValue> {
        self.take_errors()?;
        if self.scene.is_none() || (!force && self.busy.load(Ordering::Acquire)) {
            return Ok(false);
        }
        let size = (self.canvas.width().max(1), self.canvas.height().max(1));
        if size != (self.config.width, self.config.height) {
            self.config.width = size.0;
            self.config.height = size.1;
            self.surface.configure(&self.device, &self.config);
            self.renderer.resize(&self.device, size);
        }
        let texture = match self.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(t)
            | wgpu::CurrentSurfaceTexture::Suboptimal(t) => t,
            _ => {
                self.surface.configure(&self.device, &self.config);
                return Ok(false);
            }
        };
        let target = texture.texture.create_view(&Default::default());
        let view_proj = self.camera.view_proj(size.0 as f32 / size.1 as f32);
        let mut encoder = self.device.create_command_encoder(&Default::default());
        let scene = self.scene.as_mut().expect("checked above");
        scene
            .tessellate(
                &self.device,
                &self.queue,
                &mut encoder,
                self.mode,
                view_proj,
                size,
            )
            .map_err(js_err)?;
        self.renderer.draw(
            &self.device,
            &self.queue,
            &mut encoder,
            &target,
            &scene.tess,
            (view_proj, self.camera.eye),
            self.shading,
            scene.overlay(),
        );
        let start = now_ms();
        self.queue.submit([encoder.finish()]);
        self.queue.present(texture);
        self.busy.store(true, Ordering::Release);
        let (busy, ms) = (self.busy.clone(), self.frame_ms.clone());
        self.queue.on_submitted_work_done(move || {
            ms.store((now_ms() - start).to_bits(), Ordering::Relaxed);
            busy.store(false, Ordering::Release);
        });
        self.take_errors()?;
        Ok(true)
    }

    /// The counts of the last tessellation: a promise of `{vertices, triangles}` (read
    /// back from the GPU after per-edge levels).
    pub fn counts(&self) -> Result<js_sys::Promise, JsValue> {
        let scene = self
            .scene
            .as_ref()
            .ok_or_else(|| js_err("no mesh loaded"))?;
        let pending = scene.tess.read_counts(&self.device, &self.queue);
        Ok(wasm_bindgen_futures::future_to_promise(async move {
            let c = pending.await.map_err(js_err)?;
            let out = js_sys::Object::new();
            js_sys::Reflect::set(&out, &"vertices".into(), &c.vertices.into())?;
            js_sys::Reflect::set(&out, &"triangles".into(), &c.triangles().into())?;
            Ok(out.into())
        }))
    }

    /// Triangles of the last tessellation when known on the host (uniform levels).
    pub fn triangles_now(&self) -> Option<u32> {
        self.scene.as_ref()?.tess.counts().map(|c| c.triangles())
    }

    /// The last tessellation as a glTF binary: a promise of a `Uint8Array`.
    pub fn glb(&self) -> Result<js_sys::Promise, JsValue> {
        let scene = self
            .scene
            .as_ref()
            .ok_or_else(|| js_err("no mesh loaded"))?;
        let pending = scene.glb(&self.device, &self.queue);
        Ok(wasm_bindgen_futures::future_to_promise(async move {
            let bytes = pending.await.map_err(js_err)?;
            Ok(js_sys::Uint8Array::from(&bytes[..]).into())
        }))
    }

    /// Input triangles (patches).
    pub fn patches(&self) -> u32 {
        self.scene
            .as_ref()
            .map_or(0, |s| s.mesh.triangles.len() as u32)
    }

    /// The screen-space level cap this device allows for the mesh (16 unless its storage
    /// binding limit needs less).
    pub fn level_cap(&self) -> u32 {
        self.scene.as_ref().map_or(0, |s| s.cap)
    }

    /// "V valid, F folded, U undecided" after validity shading certified the patches.
    pub fn validity(&self) -> Option<String> {
        self.scene.as_ref()?.validity_summary()
    }

    /// The adapter's name.
    pub fn adapter(&self) -> String {
        self.adapter.clone()
    }

    /// The last frame's time from submission to completion on the GPU, in ms.
    pub fn frame_ms(&self) -> f64 {
        f64::from_bits(self.frame_ms.load(Ordering::Relaxed))
    }
}

impl Viewer {
    /// The first wgpu error reported since the last call, as an error.
    fn take_errors(&self) -> Result<(), JsValue> {
        let mut errors = self.errors.lock().map_err(js_err)?;
        let first = errors.drain(..).next();
        match first {
            Some(e) => Err(js_err(format!("WebGPU: {e}"))),
            None => Ok(()),
        }
    }
}
