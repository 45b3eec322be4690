//! What a host program needs around the tessellator: the limits and features to open its
//! device with (checked by [`GpuTessellator::new`], so a device that cannot run a pass is
//! refused with a typed error instead of failing in wgpu's validation later), building
//! every pipeline before the first frame, and the exact counts read back asynchronously.

use std::future::Future;

use crate::gpu::Precision;
use crate::{Error, Result};

use super::levels::{LevelCapacity, LV_STATE_DRAW, LV_STATE_RECORDS};
use super::{GpuTessellator, TessCounts, VERTEX_BYTES};

/// Storage buffers the per-edge passes bind in one compute stage: the patch data and basis
/// table of group 0, the topology, vertices, indices, edge table, levels and state of
/// group 1 (the uniform passes bind 6 of them).
const STORAGE_BUFFERS: u32 = 8;

/// Invocations of the largest workgroup (the per-edge prefix sums).
const SCAN_INVOCATIONS: u32 = 256;

impl GpuTessellator {
    /// The limits a device must allow for every pass of the tessellator and of
    /// [`crate::ScreenLevels`]: wgpu's downlevel defaults with 8 storage
    /// buffers per compute stage (WebGPU's default allows 8), 2 bind groups and
    /// workgroups of 256 invocations. Larger meshes and levels need more
    /// `max_storage_buffer_binding_size` and `max_buffer_size` than these minima: request
    /// the adapter's own (`adapter.limits()`), which [`GpuTessellator::new`] checks
    /// against these.
    pub fn required_limits() -> wgpu::Limits {
        let least = wgpu::Limits::downlevel_defaults();
        wgpu::Limits {
            max_storage_buffers_per_shader_stage: STORAGE_BUFFERS,
            max_bind_groups: least.max_bind_groups.max(2),
            max_compute_invocations_per_workgroup: least
                .max_compute_invocations_per_workgroup
                .max(SCAN_INVOCATIONS),
            max_compute_workgroup_size_x: least.max_compute_workgroup_size_x.max(SCAN_INVOCATIONS),
            max_compute_workgroup_storage_size: least
                .max_compute_workgroup_storage_size
                .max(4 * SCAN_INVOCATIONS),
            ..least
        }
    }

    /// The features a device needs for `precision`: `SHADER_F64` for f64, none for f32.
    pub fn required_features(precision: Precision) -> wgpu::Features {
        match precision {
            Precision::F32 => wgpu::Features::empty(),
            Precision::F64 => wgpu::Features::SHADER_F64,
        }
    }

    /// Checks `device` against [`GpuTessellator::required_limits`] and
    /// [`GpuTessellator::required_features`]: the first limit of the passes' shape below
    /// them (storage buffers per stage, bind groups, workgroup sizes and storage, uniform
    /// binding size) is an [`Error::LimitExceeded`] naming it, a missing feature an
    /// [`Error::MissingFeature`]. Buffer sizes are checked where the buffers are made.
    pub fn check_device(device: &wgpu::Device, precision: Precision) -> Result<()> {
        let missing = Self::required_features(precision) - device.features();
        if missing.contains(wgpu::Features::SHADER_F64) {
            return Err(Error::missing_feature(
                "SHADER_F64",
                "the device was opened without SHADER_F64: f64 tessellation needs it \
                 (request the feature when the adapter offers it); f32 works",
            ));
        }
        // The limits of the passes' shape (bindings, workgroups); buffer sizes are checked
        // buffer by buffer, with the sizes in the message.
        let have = device.limits();
        let least = Self::required_limits();
        let needed = wgpu::Limits {
            max_storage_buffers_per_shader_stage: least.max_storage_buffers_per_shader_stage,
            max_bind_groups: least.max_bind_groups,
            max_compute_invocations_per_workgroup: least.max_compute_invocations_per_workgroup,
            max_compute_workgroup_size_x: least.max_compute_workgroup_size_x,
            max_compute_workgroup_storage_size: least.max_compute_workgroup_storage_size,
            max_uniform_buffer_binding_size: least.max_uniform_buffer_binding_size,
            ..have.clone()
        };
        let mut first: Option<(&'static str, u64, u64)> = None;
        needed.check_limits_with_fail_fn(&have, false, |name, needed, allowed| {
            first.get_or_insert((name, needed, allowed));
        });
        match first {
            None => Ok(()),
            Some((name, needed, allowed)) => Err(Error::limit(
                name,
                needed,
                allowed,
                format!(
                    "the device allows {name} = {allowed}, the tessellator's passes need \
                     {needed}: open it with GpuTessellator::required_limits() (or the \
                     adapter's limits)"
                ),
            )),
        }
    }

    /// Builds every pipeline and sizes every buffer for levels up to `max_level` now, so
    /// that the first frame compiles nothing (the per-edge pipelines, otherwise built by
    /// the first [`GpuTessellator::tessellate_levels`]) and allocates nothing while its
    /// levels stay within the cap. Returns the capacity, as `tessellate_levels` does.
    pub fn prepare(&mut self, device: &wgpu::Device, max_level: u32) -> Result<LevelCapacity> {
        let cap = self.check_max_level(max_level)?;
        self.level_tess(device, max_level)?;
        self.grow_outputs(device, cap.vertices * VERTEX_BYTES, cap.indices * 4);
        Ok(cap)
    }

    /// Records one frame of screen-space tessellation into `encoder`: `screen`'s levels
    /// for `frame` ([`crate::ScreenLevels::record`]), then the per-edge tessellation with
    /// inner levels by `rule` and the cap `frame.max_level`
    /// ([`GpuTessellator::tessellate_levels`]). Nothing is read back; draw with
    /// [`GpuTessellator::draw`] in the same encoder. Errors when `screen` was built from
    /// another mesh (its edge count differs).
    pub fn tessellate_screen(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        screen: &crate::ScreenLevels,
        frame: &crate::ScreenFrame,
        rule: crate::InnerRule,
    ) -> Result<LevelCapacity> {
        if screen.edges() as usize != self.topology.edges {
            return Err(Error::Invalid(format!(
                "screen-space levels of {} edges for a tessellator of {} edges (another mesh)",
                screen.edges(),
                self.topology.edges
            )));
        }
        screen.record(queue, encoder, frame)?;
        self.tessellate_levels(device, queue, encoder, screen.source(rule), frame.max_level)
    }

    /// The exact counts of the last tessellation, for tools and tests (drawing never needs
    /// them: [`GpuTessellator::draw`] reads the indirect arguments on the device). After
    /// [`GpuTessellator::tessellate`] they are known on the host; after
    /// [`GpuTessellator::tessellate_levels`] (whose encoder must have been submitted) they
    /// are copied from the device and read back: `level` is then the level cap. On the
    /// web the future resolves when the browser maps the buffer; natively it waits for the
    /// device first. Errors before any tessellation.
    pub fn read_counts(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
    ) -> impl Future<Output = Result<TessCounts>> + 'static {
        let known = self.counts;
        let pending = match (known, &self.levels, self.level_cap) {
            (Some(_), _, _) => None,
            (None, Some(lt), Some(cap)) => Some((self.copy_level_counts(device, queue, lt), cap)),
            _ => None,
        };
        let device = device.clone();
        async move {
            if let Some(c) = known {
                return Ok(c);
            }
            let Some((staging, level)) = pending else {
                return Err(Error::Invalid(
                    "no tessellation recorded yet: counts follow tessellate or \
                     tessellate_levels"
                        .into(),
                ));
            };
            let words: Vec<u32> = crate::gpu::read_buffer_async(&device, &staging, 8, |b| {
                bytemuck::cast_slice(b).to_vec()
            })
            .await?;
            Ok(TessCounts {
                level,
                vertices: words[1],
                indices: words[0],
            })
        }
    }

    /// Copies the index count (of the indirect arguments) and the vertex records of the
    /// last per-edge tessellation into a new mappable buffer, submitted.
    fn copy_level_counts(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        lt: &super::levels::LevelTess,
    ) -> wgpu::Buffer {
        let staging = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("tess counts staging"),
            size: 16,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("g1tess counts"),
        });
        let state = lt.state();
        encoder.copy_buffer_to_buffer(state, 4 * LV_STATE_DRAW as u64, &staging, 0, 4);
        encoder.copy_buffer_to_buffer(state, 4 * LV_STATE_RECORDS as u64, &staging, 4, 4);
        queue.submit([encoder.finish()]);
        staging
    }
}

#[cfg(test)]
mod tests {
    use crate::{GpuTessellator, InnerRule, PatchTable, Precision, Scheme, ScreenLevels};

    /// The per-edge passes' bind group is made once for a level buffer and kept across
    /// frames; growing the outputs (a higher cap) makes it again, once.
    #[test]
    fn the_level_bind_group_is_kept_across_frames() {
        let ctx = match crate::tests::common::shared_gpu() {
            Ok(ctx) => ctx,
            Err(e) => {
                let ci = std::env::var("CI").is_ok_and(|v| v == "true" || v == "1");
                assert!(!ci, "CI=true and no GPU adapter: {e}");
                eprintln!("SKIP the_level_bind_group_is_kept_across_frames: no GPU adapter ({e})");
                return;
            }
        };
        let (device, queue) = (&ctx.device, &ctx.queue);
        let mesh = crate::tests::common::load("icosphere:1");
        let table = PatchTable::build(&mesh, Scheme::G1, &Default::default()).unwrap();
        let mut tess = GpuTessellator::new(device, queue, &mesh, &table, Precision::F32).unwrap();
        let screen = ScreenLevels::new(device, &mesh).unwrap();
        let frame = |tess: &mut GpuTessellator, cap: u32| {
            let mut encoder = device.create_command_encoder(&Default::default());
            let source = screen.source(InnerRule::Max);
            tess.tessellate_levels(device, queue, &mut encoder, source, cap)
                .unwrap();
            queue.submit([encoder.finish()]);
            tess.level_group.as_ref().map(|(_, g)| g.clone()).unwrap()
        };
        let first = frame(&mut tess, 4);
        assert!(frame(&mut tess, 4) == first && frame(&mut tess, 3) == first);
        let grown = frame(&mut tess, 32);
        assert!(grown != first);
        assert!(frame(&mut tess, 32) == grown);
    }
}
