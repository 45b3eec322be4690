//! GPU device set-up, kept apart from the work done on it (the split of the wgpu examples).
//!
//! [`GpuContext`] opens an adapter of the platform's native backend ([`BACKENDS`]: Vulkan
//! on Linux, Vulkan or DX12 on Windows, Metal on macOS, the browser's WebGPU on wasm32;
//! never silently GL), requests its full limits and [`wgpu::Features::SHADER_F64`] where offered, and records
//! the adapter's name and driver for reports. Work is done by free functions taking
//! `(&Device, &Queue, ...)`, so a program opens one context (device creation is slow on
//! software drivers) and shares it, in an `Arc`, between the evaluator, the tessellator and
//! its own work:
//!
//! ```no_run
//! let ctx = std::sync::Arc::new(g1tess::GpuContext::new()?);
//! eprintln!("gpu: {}", ctx.describe());
//! let (device, queue) = (&ctx.device, &ctx.queue);
//! # let _ = (device, queue);
//! # Ok::<(), g1tess::Error>(())
//! ```
//!
//! Validation errors that wgpu reports outside an error scope are collected (instead of
//! wgpu's default panic) and turned into [`Error::Gpu`] by [`GpuContext::check`]; results
//! come back through [`read_buffer`] (map, wait, copy out, unmap, errors as `Result`s). A lost
//! device is reported by [`GpuContext::check`] as [`Error::DeviceLost`].
//!
//! On the web (wasm32) nothing blocks: the context is opened by [`GpuContext::new_async`],
//! adapters are listed by [`adapters_async`] and buffers read back by
//! [`read_buffer_async`], each awaited on the browser's event loop. The blocking
//! [`GpuContext::new`] and [`adapters`] are native only; the blocking [`read_buffer`] there
//! returns an error instead of waiting.

pub mod eval;
pub mod readback;
pub mod screen;
pub mod shaders;
pub mod stats;
pub mod tessellator;

pub use crate::eval::Precision;
pub use readback::{read_buffer, read_buffer_async};

use std::sync::{Arc, Mutex};

use crate::{Error, Result};

/// The backends a [`GpuContext`] may open, whatever `WGPU_BACKEND` says: wgpu's primary
/// ones, of which Cargo.toml compiles the platform's own (Vulkan on Linux, where this is
/// Vulkan alone; Vulkan and DX12 on Windows; Metal on macOS; WebGPU on wasm32). Never GL:
/// no silent fallback.
pub const BACKENDS: wgpu::Backends = wgpu::Backends::PRIMARY;

/// [`BACKENDS`] by name, for messages.
#[cfg(target_vendor = "apple")]
const BACKEND_NAMES: &str = "Metal";
#[cfg(windows)]
const BACKEND_NAMES: &str = "Vulkan or DX12";
#[cfg(target_arch = "wasm32")]
const BACKEND_NAMES: &str = "WebGPU";
#[cfg(not(any(windows, target_vendor = "apple", target_arch = "wasm32")))]
const BACKEND_NAMES: &str = "Vulkan";

/// What a machine without an adapter needs, for the error.
#[cfg(target_vendor = "apple")]
const DRIVER_HINT: &str = "GPU evaluation needs a Metal device";
#[cfg(windows)]
const DRIVER_HINT: &str = "GPU evaluation needs a Vulkan or DX12 driver";
#[cfg(target_arch = "wasm32")]
const DRIVER_HINT: &str = "GPU evaluation needs a browser with WebGPU enabled";
#[cfg(not(any(windows, target_vendor = "apple", target_arch = "wasm32")))]
const DRIVER_HINT: &str =
    "GPU evaluation needs a Vulkan driver (e.g. Mesa's lavapipe, package mesa-vulkan-drivers)";

/// An open device (Vulkan, DX12, Metal or WebGPU) with its queue, the adapter's description and limits.
pub struct GpuContext {
    /// The wgpu instance the adapter was found through.
    pub instance: wgpu::Instance,
    /// The adapter (GPU or software rasteriser) the device was opened on.
    pub adapter: wgpu::Adapter,
    /// The open device.
    pub device: wgpu::Device,
    /// The device's queue.
    pub queue: wgpu::Queue,
    /// Name, driver and backend of the adapter.
    pub info: wgpu::AdapterInfo,
    /// The limits the device was opened with (the adapter's own).
    pub limits: wgpu::Limits,
    /// The features the device was opened with.
    pub features: wgpu::Features,
    errors: Arc<Mutex<Vec<String>>>,
    /// The reason the device was lost, once it is.
    lost: Arc<Mutex<Option<String>>>,
}

impl std::fmt::Debug for GpuContext {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GpuContext")
            .field("adapter", &self.describe())
            .finish()
    }
}

impl GpuContext {
    /// Opens the first adapter of `BACKENDS` (high-performance preference). Errors when
    /// there is none: callers decide whether falling back to the CPU is allowed.
    ///
    /// Blocks until the device is open, so it is native only; the web awaits
    /// [`GpuContext::new_async`].
    #[cfg(not(target_arch = "wasm32"))]
    pub fn new() -> Result<GpuContext> {
        pollster::block_on(Self::new_async())
    }

    /// [`GpuContext::new`] without blocking: the same adapter choice, limits, features and
    /// error reporting, as a future. On the web (wasm32, the browser's WebGPU) this is the
    /// constructor, awaited on the browser's event loop (e.g. through
    /// `wasm_bindgen_futures::spawn_local`); natively any executor may drive it.
    ///
    /// ```no_run
    /// # async fn demo() -> g1tess::Result<()> {
    /// let ctx = g1tess::GpuContext::new_async().await?;
    /// eprintln!("gpu: {}", ctx.describe());
    /// # Ok(())
    /// # }
    /// ```
    pub async fn new_async() -> Result<GpuContext> {
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
        desc.backends = BACKENDS;
        let instance = wgpu::Instance::new(desc);
        let adapter = instance
            .request_adapter(&wgpu::RequestAdapterOptions {
                power_preference: wgpu::PowerPreference::HighPerformance,
                force_fallback_adapter: false,
                compatible_surface: None,
                ..Default::default()
            })
            .await
            .map_err(|e| Error::NoAdapter {
                detail: e.to_string(),
                message: format!(
                    "no {BACKEND_NAMES} adapter ({e}); {DRIVER_HINT}; the CPU backend needs none"
                ),
            })?;
        let info = adapter.get_info();
        let limits = adapter.limits();
        let features = adapter.features() & wgpu::Features::SHADER_F64;
        let (device, queue) = adapter
            .request_device(&wgpu::DeviceDescriptor {
                label: Some("g1tess"),
                required_features: features,
                required_limits: limits.clone(),
                experimental_features: wgpu::ExperimentalFeatures::disabled(),
                memory_hints: wgpu::MemoryHints::Performance,
                trace: wgpu::Trace::Off,
            })
            .await
            .map_err(|e| Error::Gpu(format!("{}: cannot open the device: {e}", info.name)))?;
        let errors = Arc::new(Mutex::new(Vec::new()));
        let sink = errors.clone();
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            if let Ok(mut v) = sink.lock() {
                v.push(e.to_string().replace('\n', " "));
            }
        }));
        let lost = Arc::new(Mutex::new(None));
        let lost_sink = lost.clone();
        device.set_device_lost_callback(move |reason, message: String| {
            if let Ok(mut slot) = lost_sink.lock() {
                let text = if message.is_empty() {
                    format!("{reason:?}")
                } else {
                    message.replace('\n', " ")
                };
                slot.get_or_insert(text);
            }
        });
        Ok(GpuContext {
            instance,
            adapter,
            device,
            queue,
            info,
            limits,
            features,
            errors,
            lost,
        })
    }

    /// "NAME (BACKEND, DRIVER DRIVER_INFO, TYPE)", for reports.
    pub fn describe(&self) -> String {
        let i = &self.info;
        format!(
            "{} ({:?}, {} {}, {:?})",
            i.name, i.backend, i.driver, i.driver_info, i.device_type
        )
    }

    /// The limits this crate relies on, for reports: "max storage binding 128 MiB, max
    /// buffer 2048 MiB, 65535 workgroups per dimension, f64 shaders yes".
    pub fn limits_summary(&self) -> String {
        let mib = |b: u64| (b as f64 / (1u64 << 20) as f64).round();
        format!(
            "max storage binding {} MiB, max buffer {} MiB, {} workgroups per dimension, f64 shaders {}",
            mib(self.limits.max_storage_buffer_binding_size),
            mib(self.limits.max_buffer_size),
            self.limits.max_compute_workgroups_per_dimension,
            if self.supports_f64() { "yes" } else { "no" }
        )
    }

    /// Whether the device can run f64 shaders.
    pub fn supports_f64(&self) -> bool {
        self.features.contains(wgpu::Features::SHADER_F64)
    }

    /// Largest size of one storage binding (and of one buffer), in bytes.
    pub fn max_binding_bytes(&self) -> u64 {
        self.limits
            .max_storage_buffer_binding_size
            .min(self.limits.max_buffer_size)
    }

    /// Largest workgroup count of one dispatch dimension.
    pub fn max_workgroups_per_dim(&self) -> u32 {
        self.limits.max_compute_workgroups_per_dimension
    }

    /// Fails with [`Error::DeviceLost`] once the device is lost, else with the validation
    /// errors wgpu reported since the last check, if any.
    pub fn check(&self) -> Result<()> {
        if let Some(reason) = self.lost.lock().ok().and_then(|slot| slot.clone()) {
            return Err(Error::DeviceLost {
                device: self.info.name.clone(),
                reason,
            });
        }
        let mut v = self
            .errors
            .lock()
            .map_err(|_| Error::Gpu("error log poisoned".into()))?;
        if v.is_empty() {
            return Ok(());
        }
        let msg = v.join("; ");
        v.clear();
        Err(Error::Gpu(format!("{}: {msg}", self.info.name)))
    }

    /// Blocks until every submitted command has finished. On the web the browser runs the
    /// queue by itself and this returns at once (wgpu's WebGPU poll is a no-op).
    pub fn wait(&self) -> Result<()> {
        wait(&self.device)
    }
}

/// The adapters of `BACKENDS` this process can open (name, driver, device type), without
/// opening a device; empty where there is no driver. Callers choosing between the GPU and
/// the CPU read `device_type`: [`wgpu::DeviceType::Cpu`] is a software rasteriser (lavapipe,
/// WARP) running on the same cores as the CPU backend.
///
/// Blocks while the adapters are listed, so it is native only; the web awaits
/// [`adapters_async`].
#[cfg(not(target_arch = "wasm32"))]
pub fn adapters() -> Vec<wgpu::AdapterInfo> {
    pollster::block_on(adapters_async())
}

/// [`adapters`] without blocking, as a future. On the web (wasm32) it lists the browser's
/// default WebGPU adapter, or none where WebGPU is missing.
pub async fn adapters_async() -> Vec<wgpu::AdapterInfo> {
    let mut desc = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
    desc.backends = BACKENDS;
    let instance = wgpu::Instance::new(desc);
    instance
        .enumerate_adapters(BACKENDS)
        .await
        .iter()
        .map(|a| a.get_info())
        .collect()
}

/// Blocks until every submitted command of `device` has finished (returns at once on the
/// web, where the browser runs the queue).
pub fn wait(device: &wgpu::Device) -> Result<()> {
    device
        .poll(wgpu::PollType::wait_indefinitely())
        .map(|_| ())
        .map_err(|e| Error::Gpu(format!("device poll: {e}")))
}

/// A bind group of `layout` binding `buffers` whole at bindings 0, 1, 2, … in order.
pub(crate) fn bind_buffers(
    device: &wgpu::Device,
    label: &str,
    layout: &wgpu::BindGroupLayout,
    buffers: &[&wgpu::Buffer],
) -> wgpu::BindGroup {
    let entries: Vec<wgpu::BindGroupEntry<'_>> = buffers
        .iter()
        .enumerate()
        .map(|(b, buf)| wgpu::BindGroupEntry {
            binding: b as u32,
            resource: buf.as_entire_binding(),
        })
        .collect();
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some(label),
        layout,
        entries: &entries,
    })
}
