//! Pictures of the normal field (the paper's figures 13–16): the welded surface drawn
//! headless by a wgpu render pass, coloured by n_x, n_y and n_z in three panels with one
//! colour ramp ([`Shading::Normals`]) or as isophotes of them ([`Shading::Isophotes`]),
//! under an orthographic camera fitted to the surface's bounding box.
//!
//! - [`camera`]: the orthographic camera (a frame and the map into clip space);
//! - [`isophotes`]: the bands of the isophote shading and its fragment shader;
//! - `pipeline` (feature `gpu`): the render pass on a `wgpu::Device`/`Queue` and the
//!   read-back of the panels; its WGSL is `shaders/render.wgsl`, headed by constants
//!   generated from [`RAMP`];
//! - `compose` (feature `cli`): titles, legend and the PNG file.
//!
//! The device is an adapter of the platform's native backend (Vulkan on Linux, lavapipe in
//! tests; see `crate::gpu`), opened once per process by `device`.

use glam::DVec3;

#[cfg(feature = "gpu")]
use crate::gpu::GpuContext;
#[cfg(feature = "gpu")]
use crate::{Error, Result};

pub mod camera;
#[cfg(feature = "cli")]
pub mod compose;
pub mod isophotes;
#[cfg(feature = "gpu")]
pub mod pipeline;

#[cfg(feature = "cli")]
pub use compose::{write_png, Row};
#[cfg(feature = "gpu")]
pub use pipeline::{render_panels, render_tessellated};

/// Background of the panels (white).
pub const BACKGROUND: [u8; 3] = [255, 255, 255];

/// The colour ramp over [−1, 1]: nine stops, linear in between (turbo-like: dark blue,
/// blue, cyan, green, yellow-green, yellow, orange, red, dark red). The one copy: the
/// shader's table is generated from it ([`shader_source`]).
pub const RAMP: [[u8; 3]; 9] = [
    [48, 18, 59],
    [65, 105, 225],
    [32, 170, 230],
    [40, 210, 160],
    [140, 230, 70],
    [230, 215, 50],
    [250, 150, 40],
    [220, 70, 25],
    [122, 4, 3],
];

/// Number of linear segments of the ramp (between consecutive stops).
pub const RAMP_SEGMENTS: usize = RAMP.len() - 1;

/// Colour of value `v` in [−1, 1] (clamped), as the shader computes it (up to rounding).
pub fn ramp(v: f64) -> [u8; 3] {
    let segments = RAMP_SEGMENTS as f64;
    let t = ((v + 1.0) * (0.5 * segments)).clamp(0.0, segments);
    let i = (t.floor() as usize).min(RAMP_SEGMENTS - 1);
    let f = t - i as f64;
    std::array::from_fn(|c| {
        let a = RAMP[i][c] as f64;
        let b = RAMP[i + 1][c] as f64;
        (a + (b - a) * f).round() as u8
    })
}

/// How the panels are coloured.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
pub enum Shading {
    /// Each panel's normal component (n_x, n_y, n_z) through the colour ramp.
    #[default]
    Normals,
    /// Isophotes of the same components: bands of 1/12, alternately light and dark
    /// ([`isophotes`]).
    Isophotes,
}

/// How to draw: [`RenderOptions::default()`] and the `with_*` methods.
#[derive(Clone, Debug)]
#[non_exhaustive]
pub struct RenderOptions {
    /// Side of one square panel in pixels (default 512).
    pub panel: u32,
    /// Direction from the surface towards the camera (default +z).
    pub view: DVec3,
    /// Direction that points up in the picture, projected perpendicular to `view` (default
    /// +y).
    pub up: DVec3,
    /// How the panels are coloured (default: the normal components' colour ramp).
    pub shading: Shading,
}

impl RenderOptions {
    #[cfg(test)]
    /// Sets [`RenderOptions::panel`].
    pub fn with_panel(mut self, panel: u32) -> Self {
        self.panel = panel;
        self
    }

    #[cfg(test)]
    /// Sets [`RenderOptions::view`].
    pub fn with_view(mut self, view: DVec3) -> Self {
        self.view = view;
        self
    }

    #[cfg(test)]
    /// Sets [`RenderOptions::up`].
    pub fn with_up(mut self, up: DVec3) -> Self {
        self.up = up;
        self
    }

    #[cfg(test)]
    /// Sets [`RenderOptions::shading`].
    pub fn with_shading(mut self, shading: Shading) -> Self {
        self.shading = shading;
        self
    }
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            panel: 512,
            view: DVec3::Z,
            up: DVec3::Y,
            shading: Shading::Normals,
        }
    }
}

/// Three rendered panels (n_x, n_y, n_z), side by side, RGBA rows top to bottom.
#[derive(Clone, Debug)]
pub struct Panels {
    pub panel: u32,
    /// Width 3 × panel, height panel, 4 bytes per pixel.
    pub rgba: Vec<u8>,
}

impl Panels {
    /// RGB of pixel (x, y) of panel `c` (0: n_x, 1: n_y, 2: n_z).
    pub fn pixel(&self, c: usize, x: u32, y: u32) -> [u8; 3] {
        let w = 3 * self.panel as usize;
        let i = 4 * (y as usize * w + c * self.panel as usize + x as usize);
        [self.rgba[i], self.rgba[i + 1], self.rgba[i + 2]]
    }
}

/// Smallest panel side drawn (smaller requests are drawn at this size).
pub const MIN_PANEL: u32 = 16;

/// Largest panel side drawn: the multisampled colour and depth targets of three 4096-pixel
/// panels take 1.6 GB of device memory.
pub const MAX_PANEL: u32 = 4096;

/// Largest panel side `gpu` can draw: three panels side by side must fit in one texture
/// row, and [`MAX_PANEL`].
#[cfg(feature = "gpu")]
pub fn max_panel(gpu: &GpuContext) -> u32 {
    (gpu.device.limits().max_texture_dimension_2d / 3).min(MAX_PANEL)
}

/// Size of the surface drawn for a mesh of `triangles` at grid level `level`, counted
/// before anything is evaluated (the u64 arithmetic cannot overflow for any `usize`
/// triangle count and `u32` level).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SurfaceSize {
    /// Output triangles: level² per input triangle.
    pub triangles: u128,
    /// Vertex records, an upper bound: every grid point of every patch its own.
    pub records: u128,
}

impl SurfaceSize {
    pub fn new(triangles: usize, level: u32) -> SurfaceSize {
        let (t, n) = (triangles as u128, level as u128);
        SurfaceSize {
            triangles: t * n * n,
            records: t * (n + 1) * (n + 2) / 2,
        }
    }

    /// Bytes of host memory the picture of one surface takes at its peak: the stitching
    /// plan (8 bytes per record), the welded f64 surface (position, normal, position id:
    /// 52 bytes per record; 12 bytes per triangle) and the f32 vertex and index arrays
    /// handed to the device (24 bytes per record, 12 per triangle).
    pub fn host_bytes(&self) -> u128 {
        84 * self.records + 24 * self.triangles
    }

    /// Largest device buffer the render pass creates (vertices or indices), in bytes.
    pub fn buffer_bytes(&self) -> u128 {
        (24 * self.records).max(12 * self.triangles)
    }

    /// Whether `gpu` can draw it: each buffer within the device's buffer size, and the
    /// 32-bit indices and index count in range. The error names the adapter and the limit.
    #[cfg(feature = "gpu")]
    pub fn check_device(&self, gpu: &GpuContext) -> Result<()> {
        let max = gpu.device.limits().max_buffer_size as u128;
        if self.buffer_bytes() > max {
            return Err(Error::limit(
                "max_buffer_size",
                u64::try_from(self.buffer_bytes()).unwrap_or(u64::MAX),
                max as u64,
                format!(
                    "{}: a surface of {} triangles needs a {} MB buffer, more than the \
                     device's {} MB",
                    gpu.describe(),
                    self.triangles,
                    self.buffer_bytes() / 1_000_000,
                    max / 1_000_000
                ),
            ));
        }
        if 3 * self.triangles > u32::MAX as u128 || self.records > u32::MAX as u128 {
            return Err(Error::Gpu(format!(
                "{}: a surface of {} triangles exceeds 32-bit vertex indices",
                gpu.describe(),
                self.triangles
            )));
        }
        Ok(())
    }
}
