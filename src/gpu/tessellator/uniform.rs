//! Uniform tessellation: one grid level for every patch, and the surface's extent.

use crate::eval::{grid_barycentrics, grid_len};
use crate::gpu::eval::{basis_table, Params, Real};
use crate::gpu::Precision;
use crate::patch::PatchKind;
use crate::{Error, Result};

use super::buffers::{groups, grow};
use super::{GpuTessellator, TessCounts, TessUniform, MAX_GRID_TABLE_BYTES, VERTEX_BYTES};

/// The basis of every grid point of `level`, laid out as `eval_table` of
/// `shaders/common.wgsl` reads it.
fn grid_weight_bytes<R: Real>(kind: PatchKind, level: u32) -> Vec<u8> {
    bytemuck::cast_slice(&basis_table::<R>(kind, &grid_barycentrics(level))).to_vec()
}

impl GpuTessellator {
    /// Whether level `level` (≥ 1) fits: 32-bit indices and thread counts, and the vertex
    /// and index buffers within the device's storage binding limit (the error says which).
    pub fn check_level(&self, level: u32) -> Result<()> {
        if level == 0 {
            return Err(Error::Invalid(
                "tessellation level must be at least 1".into(),
            ));
        }
        let topo = &self.topology;
        let records = topo.records(level);
        let index_count = topo.index_count(level);
        let per = grid_len(level) as u64;
        let threads = topo.patches as u64 * per;
        let copy_threads = topo.patches as u64 * 3 * (level as u64 - 1);
        if records >= u32::MAX as u64
            || index_count >= u32::MAX as u64
            || threads >= u32::MAX as u64
            || copy_threads >= u32::MAX as u64
        {
            return Err(Error::Invalid(format!(
                "level {level} on {} patches exceeds 32-bit vertex indices",
                topo.patches
            )));
        }
        let vertex_bytes = records * VERTEX_BYTES;
        let index_bytes = index_count * 4;
        for (what, bytes) in [("vertex", vertex_bytes), ("index", index_bytes)] {
            if bytes > self.max_binding {
                return Err(Error::limit(
                    "max_storage_buffer_binding_size",
                    bytes,
                    self.max_binding,
                    format!(
                        "level {level} on {} patches needs a {} {what} buffer, over the \
                         device's storage binding limit of {}",
                        topo.patches,
                        super::mib(bytes),
                        super::mib(self.max_binding)
                    ),
                ));
            }
        }
        Ok(())
    }

    /// Records the tessellation at grid level `level` (≥ 1) into `encoder`: the vertex,
    /// index and indirect buffers hold the welded surface once the encoder's work has run.
    /// The level's parameters (and its basis table) are written with `queue.write_buffer`,
    /// so submit the encoder before tessellating again. Buffers are reused while large
    /// enough; a finer level allocates larger ones (call [`GpuTessellator::vertices`] and
    /// [`GpuTessellator::indices`] again after this).
    pub fn tessellate(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        level: u32,
    ) -> Result<TessCounts> {
        self.check_level(level)?;
        let topo = &self.topology;
        let records = topo.records(level);
        let index_count = topo.index_count(level);
        let per = grid_len(level) as u64;
        let threads = topo.patches as u64 * per;
        let copy_threads = topo.patches as u64 * 3 * (level as u64 - 1);
        let vertex_bytes = records * VERTEX_BYTES;
        let index_bytes = index_count * 4;
        let rb = self.precision.bytes() as u64;
        let table_bytes = per * self.kind.stride() as u64 * 3 * rb;
        let use_table = table_bytes <= MAX_GRID_TABLE_BYTES.min(self.max_binding);
        use wgpu::BufferUsages as U;
        let mut rebind0 = false;
        if use_table {
            rebind0 = grow(
                device,
                &mut self.grid_w,
                table_bytes,
                "tess grid weights",
                U::STORAGE | U::COPY_DST,
            );
            let w = match self.precision {
                Precision::F32 => grid_weight_bytes::<f32>(self.kind, level),
                Precision::F64 => grid_weight_bytes::<f64>(self.kind, level),
            };
            queue.write_buffer(&self.grid_w, 0, &w);
        }
        if rebind0 {
            self.group0 = Self::bind0(
                device,
                &self.layout0,
                &self.params,
                &self.patch_data,
                &self.grid_w,
            );
        }
        self.grow_outputs(device, vertex_bytes, index_bytes);
        let (mx, my) = groups(threads as u32, self.max_groups)?;
        let (cx, cy) = groups(copy_threads as u32, self.max_groups)?;
        let params = Params {
            count: threads as u32,
            first_local: 0,
            level,
            per: per as u32,
            groups_x: mx,
            _pad: [0; 3],
        };
        queue.write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
        self.uniform = TessUniform {
            main_count: threads as u32,
            main_groups_x: mx,
            copy_count: copy_threads as u32,
            copy_groups_x: cx,
            ..TessUniform::default()
        };
        queue.write_buffer(&self.tess_uniform, 0, bytemuck::bytes_of(&self.uniform));
        let args = wgpu::util::DrawIndexedIndirectArgs {
            index_count: index_count as u32,
            instance_count: 1,
            first_index: 0,
            base_vertex: 0,
            first_instance: 0,
        };
        queue.write_buffer(&self.indirect, 0, args.as_bytes());
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("g1tess tessellate"),
                timestamp_writes: None,
            });
            pass.set_pipeline(if use_table {
                &self.main_table
            } else {
                &self.main_basis
            });
            pass.set_bind_group(0, &self.group0, &[]);
            pass.set_bind_group(1, &self.group1, &[]);
            pass.dispatch_workgroups(mx, my, 1);
        }
        if self.topology.copied_blocks > 0 && copy_threads > 0 {
            // A pass of its own: the owners' positions are written by the one above.
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("g1tess tessellate split normals"),
                timestamp_writes: None,
            });
            pass.set_pipeline(&self.copy);
            pass.set_bind_group(0, &self.group0, &[]);
            pass.set_bind_group(1, &self.group1, &[]);
            pass.dispatch_workgroups(cx, cy, 1);
        }
        let counts = TessCounts {
            level,
            vertices: records as u32,
            indices: index_count as u32,
        };
        self.counts = Some(counts);
        self.level_cap = None;
        Ok(counts)
    }

    /// Records, after [`GpuTessellator::tessellate`] in the same submission, the extent of
    /// the surface along three directions into [`GpuTessellator::bounds`]: the largest
    /// `p · axes[k]` and the largest `−p · axes[k]` over the vertices, as order-preserving
    /// keys (`decode_bounds`). An aggregate for fitting a camera (24 bytes).
    pub fn record_bounds(
        &mut self,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        axes: [[f32; 3]; 3],
    ) -> Result<()> {
        let counts = self.counts.ok_or_else(|| {
            Error::Invalid(
                "bounds need a uniform tessellation (tessellate) recorded before them".into(),
            )
        })?;
        let (bx, by) = groups(counts.vertices, self.max_groups)?;
        self.uniform.bounds_count = counts.vertices;
        self.uniform.bounds_groups_x = bx;
        self.uniform.axes = axes.map(|a| [a[0], a[1], a[2], 0.0]);
        queue.write_buffer(&self.tess_uniform, 0, bytemuck::bytes_of(&self.uniform));
        encoder.clear_buffer(&self.bounds, 0, None);
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("g1tess tessellate bounds"),
            timestamp_writes: None,
        });
        pass.set_pipeline(&self.bounds_pipeline);
        pass.set_bind_group(0, &self.group0, &[]);
        pass.set_bind_group(1, &self.group1, &[]);
        pass.dispatch_workgroups(bx, by, 1);
        Ok(())
    }
}
