//! A headless wgpu program that embeds g1tess's GPU tessellator: it opens a device of its
//! own, tessellates the Stanford bunny with the G1 scheme on that device, draws the welded
//! surface with a render pass straight from the tessellator's vertex and index buffers
//! (no geometry comes back to the host) and writes the picture, the bunny's unit normal
//! components n_x, n_y, n_z side by side, as a PNG.
//!
//! ```text
//! cargo run --release --example wgpu_viewer -- [OUT.png] [LEVEL] [PANEL]
//! ```
//!
//! Defaults: `wgpu_viewer.png`, level 8, 512-pixel panels. `draw_cpu` draws the same mesh
//! tessellated on the CPU through the same pipeline (`tests/viewer.rs` compares the two).

use glam::DVec3;

use g1tess::Camera;
use g1tess::{draw, upload, Geometry, IndexCount};
use g1tess::{stitch, CpuEvaluator, GpuTessellator, Mesh, PatchTable, Precision, Scheme};

/// The mesh drawn.
pub const BUNNY: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/stanford-bunny.obj");

/// Opens a device of the example's own on the first adapter wgpu finds (default limits,
/// no optional features: the tessellator works in f32 on any device).
pub fn open_device() -> Result<(wgpu::Device, wgpu::Queue), String> {
    let instance =
        wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
    let adapter = pollster::block_on(instance.request_adapter(&Default::default()))
        .map_err(|e| format!("no adapter: {e}"))?;
    pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        label: Some("wgpu_viewer"),
        ..Default::default()
    }))
    .map_err(|e| format!("{}: cannot open the device: {e}", adapter.get_info().name))
}

/// The bunny and its G1 patches.
pub fn bunny() -> g1tess::Result<(Mesh, PatchTable)> {
    let mesh = Mesh::load(BUNNY, &Default::default())?;
    let table = PatchTable::build(&mesh, Scheme::G1, &Default::default())?;
    Ok((mesh, table))
}

/// The camera: looking along −z with y up, fitted to the input vertices (the host knows
/// them; the curved surface stays within the camera's 4 % margin of their box).
pub fn camera_rows(mesh: &Mesh) -> g1tess::Result<[[f32; 4]; 3]> {
    Ok(Camera::fit(&mesh.positions, DVec3::Z, DVec3::Y)?.rows())
}

/// Tessellates `table` at `level` on the device and draws it from the tessellator's own
/// buffers into three `panel`-pixel panels; returns the picture's RGBA rows.
pub fn draw_gpu(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    mesh: &Mesh,
    table: &PatchTable,
    level: u32,
    panel: u32,
) -> g1tess::Result<Vec<u8>> {
    let mut tess = GpuTessellator::new(device, queue, mesh, table, Precision::F32)?;
    let mut encoder = device.create_command_encoder(&Default::default());
    tess.tessellate(device, queue, &mut encoder, level)?;
    queue.submit([encoder.finish()]);
    let geometry = Geometry {
        vertices: tess.vertices(),
        indices: tess.indices(),
        count: IndexCount::Indirect(tess.indirect()),
    };
    draw(device, queue, &geometry, &camera_rows(mesh)?, panel)
}

/// The same picture of the surface tessellated on the CPU (f64 reference, stitched),
/// uploaded into buffers of the tessellator's vertex layout and drawn by the same pipeline.
pub fn draw_cpu(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    mesh: &Mesh,
    table: &PatchTable,
    level: u32,
    panel: u32,
) -> g1tess::Result<Vec<u8>> {
    let (surface, _, _) = stitch(mesh, table, &CpuEvaluator::default(), level)?;
    let (vertices, indices, count) = upload(device, &surface);
    let geometry = Geometry {
        vertices: &vertices,
        indices: &indices,
        count: IndexCount::Direct(count),
    };
    draw(device, queue, &geometry, &camera_rows(mesh)?, panel)
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let out = args.first().cloned().unwrap_or("wgpu_viewer.png".into());
    let number = |i: usize, default: u32| -> u32 {
        args.get(i).map_or(default, |a| {
            a.parse().unwrap_or_else(|_| {
                eprintln!("error: '{a}' is not a whole number");
                std::process::exit(2)
            })
        })
    };
    let (level, panel) = (number(1, 8), number(2, 512).clamp(16, 4096));
    let run = || -> Result<(), String> {
        let (device, queue) = open_device()?;
        let (mesh, table) = bunny().map_err(|e| e.to_string())?;
        let rgba =
            draw_gpu(&device, &queue, &mesh, &table, level, panel).map_err(|e| e.to_string())?;
        let file = std::fs::File::create(&out).map_err(|e| format!("{out}: {e}"))?;
        let mut png = png::Encoder::new(std::io::BufWriter::new(file), 3 * panel, panel);
        png.set_color(png::ColorType::Rgba);
        png.set_depth(png::BitDepth::Eight);
        png.write_header()
            .and_then(|mut w| w.write_image_data(&rgba))
            .map_err(|e| format!("{out}: {e}"))?;
        println!(
            "{out}: {} triangles at level {level}, tessellated and drawn on the device",
            mesh.triangles.len() * (level * level) as usize
        );
        Ok(())
    };
    if let Err(e) = run() {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
}
