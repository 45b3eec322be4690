//! The mesh on the device: its patches, the tessellator and the screen-space levels, the
//! validity certificate, and the GLB of the current tessellation.

use std::future::Future;

use g1tess::glam::{Mat4, Vec3};
use g1tess::wgpu;
use g1tess::{
    check_table, GpuTessellator, InnerRule, InputFormat, LoadOptions, Mesh, PatchTable, Precision,
    Result, Scheme, ScreenFrame, ScreenLevels, Verdict,
};

use crate::render::Overlay;

/// The screen-space level cap asked for; lower ones are tried when the device's storage
/// binding limit refuses it.
const CAPS: [u32; 9] = [16, 12, 10, 8, 6, 4, 3, 2, 1];

/// How the surface is tessellated.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Mode {
    /// One level for every patch.
    Uniform { level: u32 },
    /// A level per edge from its projected length, aiming at `target_px` pixels.
    Screen { target_px: f32 },
}

/// The loaded mesh and everything built from it.
pub struct Scene {
    pub mesh: Mesh,
    table: PatchTable,
    pub tess: GpuTessellator,
    screen: ScreenLevels,
    /// The screen-space level cap (prepared).
    pub cap: u32,
    /// The uniform level the buffers hold (`None` after screen-space levels).
    uniform_done: Option<u32>,
    /// The verdict of every patch and their overlay, once certified for this scheme.
    validity: Option<(Vec<Verdict>, Option<Overlay>)>,
}

/// The reader of a file named `name`, by extension.
fn format_of(name: &str) -> Result<InputFormat> {
    let ext = name.rsplit_once('.').map(|(_, e)| e.to_ascii_lowercase());
    match ext.as_deref() {
        Some("obj") => Ok(InputFormat::Obj),
        Some("ply") => Ok(InputFormat::Ply),
        Some("stl") => Ok(InputFormat::Stl),
        Some("glb" | "gltf") => Ok(InputFormat::Gltf),
        Some("pn") => Ok(InputFormat::Pn),
        _ => Err(g1tess::Error::Invalid(format!(
            "{name}: unknown mesh format (open .obj, .ply, .stl, .glb, .gltf or .pn)"
        ))),
    }
}

/// The tessellator of `table`, prepared for the highest cap of `CAPS` the device allows.
fn tessellator(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    mesh: &Mesh,
    table: &PatchTable,
) -> Result<(GpuTessellator, u32)> {
    let mut tess = GpuTessellator::new(device, queue, mesh, table, Precision::F32)?;
    let mut refused = None;
    for cap in CAPS {
        match tess.check_max_level(cap) {
            Ok(_) => {
                tess.prepare(device, cap)?;
                return Ok((tess, cap));
            }
            Err(e) => {
                refused.get_or_insert(e);
            }
        }
    }
    Err(refused.expect("CAPS is not empty"))
}

impl Scene {
    /// Reads the mesh from `bytes`, builds its patches with `scheme`, the tessellator and
    /// the screen-space levels.
    pub fn load(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        name: &str,
        bytes: &[u8],
        scheme: Scheme,
    ) -> Result<Scene> {
        let mesh = Mesh::from_bytes(name, bytes, format_of(name)?, &LoadOptions::default())?;
        let table = PatchTable::build(&mesh, scheme, &Default::default())?;
        let (tess, cap) = tessellator(device, queue, &mesh, &table)?;
        let screen = ScreenLevels::new(device, &mesh)?;
        Ok(Scene {
            mesh,
            table,
            tess,
            screen,
            cap,
            uniform_done: None,
            validity: None,
        })
    }

    /// Rebuilds the patches and the tessellator for `scheme`.
    pub fn set_scheme(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        scheme: Scheme,
    ) -> Result<()> {
        let table = PatchTable::build(&self.mesh, scheme, &Default::default())?;
        let (tess, cap) = tessellator(device, queue, &self.mesh, &table)?;
        (self.table, self.tess, self.cap) = (table, tess, cap);
        self.uniform_done = None;
        self.validity = None;
        Ok(())
    }

    /// The centre of the bounding box and the radius of the sphere about it.
    pub fn bounds(&self) -> (Vec3, f32) {
        let p = &self.mesh.positions;
        let lo = p.iter().fold(p[0], |a, b| a.min(*b));
        let hi = p.iter().fold(p[0], |a, b| a.max(*b));
        let centre = (lo + hi) / 2.0;
        let radius = p.iter().map(|x| x.distance(centre)).fold(0.0, f64::max);
        (centre.as_vec3(), radius as f32)
    }

    /// Whether uniform tessellation at `level` fits the device.
    pub fn check_level(&self, level: u32) -> Result<()> {
        self.tess.check_level(level)
    }

    /// Records this frame's tessellation: screen-space levels every frame, a uniform
    /// level once.
    pub fn tessellate(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        mode: Mode,
        view_proj: Mat4,
        (width, height): (u32, u32),
    ) -> Result<()> {
        match mode {
            Mode::Uniform { level } if self.uniform_done != Some(level) => {
                self.tess.tessellate(device, queue, encoder, level)?;
                self.uniform_done = Some(level);
            }
            Mode::Uniform { .. } => {}
            Mode::Screen { target_px } => {
                let frame = ScreenFrame {
                    view_proj,
                    viewport: [width as f32, height as f32],
                    target_px,
                    max_level: self.cap,
                };
                let rule = InnerRule::Max;
                let screen = &self.screen;
                self.tess
                    .tessellate_screen(device, queue, encoder, screen, &frame, rule)?;
                self.uniform_done = None;
            }
        }
        Ok(())
    }

    /// Certifies every patch (once per scheme) and marks the input triangles of folded
    /// patches red, of undecided ones yellow.
    pub fn certify(&mut self, device: &wgpu::Device) {
        if self.validity.is_some() {
            return;
        }
        let verdicts = check_table(&self.table);
        let mut marked = Vec::new();
        for (t, v) in verdicts.iter().enumerate() {
            let colour = match v {
                Verdict::Valid => continue,
                Verdict::Folded { .. } => [1.0, 0.1, 0.1, 0.6],
                Verdict::Undecided => [1.0, 0.85, 0.0, 0.6],
            };
            let corners = self.mesh.triangles[t]
                .map(|i| self.mesh.positions[i as usize].as_vec3().to_array());
            marked.push((corners, colour));
        }
        let overlay = Overlay::new(device, &marked);
        self.validity = Some((verdicts, overlay));
    }

    /// The validity overlay, when certified and some patch is not valid.
    pub fn overlay(&self) -> Option<&Overlay> {
        self.validity.as_ref()?.1.as_ref()
    }

    /// "V valid, F folded, U undecided", when certified.
    pub fn validity_summary(&self) -> Option<String> {
        let (verdicts, _) = self.validity.as_ref()?;
        let (mut valid, mut folded, mut undecided) = (0, 0, 0);
        for v in verdicts {
            match v {
                Verdict::Valid => valid += 1,
                Verdict::Folded { .. } => folded += 1,
                Verdict::Undecided => undecided += 1,
            }
        }
        Some(format!(
            "{valid} valid, {folded} folded, {undecided} undecided"
        ))
    }

    /// The current tessellation as a GLB: its counts read back, then that many vertices
    /// (24 bytes) and indices copied out of the tessellator's buffers and read back.
    pub fn glb(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
    ) -> impl Future<Output = Result<Vec<u8>>> + 'static {
        let counts = self.tess.read_counts(device, queue);
        let (vertices, indices) = (self.tess.vertices().clone(), self.tess.indices().clone());
        let (device, queue) = (device.clone(), queue.clone());
        let name = self.mesh.name.clone();
        async move {
            let c = counts.await?;
            let vb = c.vertices as u64 * 24;
            let ib = c.indices as u64 * 4;
            let staging = |size: u64| {
                device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("glb staging"),
                    size: size.max(4),
                    usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                })
            };
            let (sv, si) = (staging(vb), staging(ib));
            let mut encoder = device.create_command_encoder(&Default::default());
            encoder.copy_buffer_to_buffer(&vertices, 0, &sv, 0, vb);
            encoder.copy_buffer_to_buffer(&indices, 0, &si, 0, ib);
            queue.submit([encoder.finish()]);
            let v = g1tess::read_buffer_async(&device, &sv, vb, |b| b.to_vec()).await?;
            let i = g1tess::read_buffer_async(&device, &si, ib, |b| b.to_vec()).await?;
            Ok(crate::glb::glb(&name, &v, &i))
        }
    }
}
