//! Construction of the tessellator (its pipelines, uploads and bind groups) and the
//! buffers it keeps: made padded, grown when a level needs more, rebound when grown.

use crate::gpu::eval::{push_patch_data, Params, Real};
use crate::gpu::{shaders, Precision};
use crate::mesh::Mesh;
use crate::patch::PatchTable;
use crate::{Error, Result};

use super::shader::{
    checked_module, compute_pipeline, entry, storage_ty, tess_module_source, uniform_ty,
    TESS_WORKGROUP,
};
use super::{GpuTessellator, TessUniform, Topology};

/// Bytes rounded up to a multiple of 16, at least 16.
fn padded(bytes: u64) -> u64 {
    bytes.max(16).div_ceil(16) * 16
}

/// A buffer of at least `size` bytes ([`padded`]).
pub(super) fn new_buffer(
    device: &wgpu::Device,
    label: &str,
    size: u64,
    usage: wgpu::BufferUsages,
) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: padded(size),
        usage,
        mapped_at_creation: false,
    })
}

/// Replaces `buf` with a new buffer of `bytes` when it is smaller; true when it did (its
/// bind group must then be made again).
pub(super) fn grow(
    device: &wgpu::Device,
    buf: &mut wgpu::Buffer,
    bytes: u64,
    label: &str,
    usage: wgpu::BufferUsages,
) -> bool {
    if buf.size() >= bytes {
        return false;
    }
    *buf = new_buffer(device, label, bytes, usage);
    true
}

fn patch_bytes<R: Real>(table: &PatchTable) -> Vec<u8> {
    let mut out: Vec<R> = Vec::with_capacity(table.len() * 3 * shaders::patch_vecs(table.kind));
    for i in 0..table.len() {
        push_patch_data(table, i, &mut out);
    }
    bytemuck::cast_slice(&out).to_vec()
}

/// Workgroups (x, y) for `count` threads, at most `max` per dimension.
pub(super) fn groups(count: u32, max: u32) -> Result<(u32, u32)> {
    let g = count.div_ceil(TESS_WORKGROUP).max(1);
    let x = g.min(max.max(1));
    let y = g.div_ceil(x);
    if y > max {
        return Err(Error::limit(
            "max_compute_workgroups_per_dimension",
            u64::from(y),
            u64::from(max),
            format!("{count} tessellation threads need more than {max} × {max} workgroups"),
        ));
    }
    Ok((x, y))
}

impl GpuTessellator {
    /// Builds the pipelines of `table`'s patch kind in `precision` on the host's device and
    /// uploads the patch data and the topology of `mesh` (the table's mesh). Errors when the
    /// device lacks what the shaders need (`SHADER_F64` for f64, storage buffers in compute
    /// shaders) or a buffer exceeds its limits.
    ///
    /// The device is checked against [`GpuTessellator::required_limits`] and
    /// [`GpuTessellator::required_features`] for every pass, the per-edge ones included
    /// ([`GpuTessellator::check_device`]): a device that allows too few storage buffers
    /// per stage gets an [`Error::LimitExceeded`] here, never a panic in a later pass.
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        mesh: &Mesh,
        table: &PatchTable,
        precision: Precision,
    ) -> Result<GpuTessellator> {
        if table.len() != mesh.triangles.len() {
            return Err(Error::Invalid(format!(
                "{}: a patch table of {} patches for {} triangles",
                mesh.name,
                table.len(),
                mesh.triangles.len()
            )));
        }
        Self::check_device(device, precision)?;
        let limits = device.limits();
        let max_binding = (limits.max_storage_buffer_binding_size).min(limits.max_buffer_size);
        let max_groups = limits.max_compute_workgroups_per_dimension;
        let topology = Topology::new(mesh, &mesh.adjacency())?;
        let module = checked_module(
            device,
            "tessellate.wgsl",
            table.kind,
            precision,
            tess_module_source(table.kind, precision)?,
        )?;
        let layout0 = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("g1tess tessellate eval"),
            entries: &[
                entry(0, uniform_ty()),
                entry(1, storage_ty(true)),
                entry(4, storage_ty(true)),
            ],
        });
        let layout1 = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("g1tess tessellate"),
            entries: &[
                entry(0, uniform_ty()),
                entry(1, storage_ty(true)),
                entry(2, storage_ty(false)),
                entry(3, storage_ty(false)),
                entry(4, storage_ty(false)),
            ],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("g1tess tessellate"),
            bind_group_layouts: &[Some(&layout0), Some(&layout1)],
            immediate_size: 0,
        });
        let make = |entry: &str| compute_pipeline(device, &pipeline_layout, &module, entry);
        let data = match precision {
            Precision::F32 => patch_bytes::<f32>(table),
            Precision::F64 => patch_bytes::<f64>(table),
        };
        let topo_bytes: &[u8] = bytemuck::cast_slice(&topology.table);
        for (what, bytes) in [("patch data", data.len()), ("topology", topo_bytes.len())] {
            if bytes as u64 > max_binding {
                return Err(Error::limit(
                    "max_storage_buffer_binding_size",
                    bytes as u64,
                    max_binding,
                    format!(
                        "{}: the {what} of {} patches takes {bytes} bytes, over the device's \
                         storage binding limit of {max_binding}",
                        mesh.name,
                        table.len()
                    ),
                ));
            }
        }
        use wgpu::BufferUsages as U;
        let buffer = |label, size: u64, usage| new_buffer(device, label, size, usage);
        let params = buffer(
            "tess params",
            std::mem::size_of::<Params>() as u64,
            U::UNIFORM | U::COPY_DST,
        );
        let patch_data = buffer(
            "tess patch data",
            data.len() as u64,
            U::STORAGE | U::COPY_DST,
        );
        queue.write_buffer(&patch_data, 0, &data);
        let topo_buffer = buffer(
            "tess topology",
            topo_bytes.len() as u64,
            U::STORAGE | U::COPY_DST,
        );
        queue.write_buffer(&topo_buffer, 0, topo_bytes);
        let grid_w = buffer("tess grid weights", 16, U::STORAGE | U::COPY_DST);
        let tess_uniform = buffer(
            "tess uniform",
            std::mem::size_of::<TessUniform>() as u64,
            U::UNIFORM | U::COPY_DST,
        );
        let vertices = buffer("tess vertices", 16, Self::VERTEX_USAGE);
        let indices = buffer("tess indices", 16, Self::INDEX_USAGE);
        let indirect = buffer(
            "tess indirect",
            std::mem::size_of::<wgpu::util::DrawIndexedIndirectArgs>() as u64,
            U::INDIRECT | U::COPY_DST | U::COPY_SRC,
        );
        let bounds = buffer("tess bounds", 24, U::STORAGE | U::COPY_SRC | U::COPY_DST);
        let group0 = Self::bind0(device, &layout0, &params, &patch_data, &grid_w);
        let group1 = Self::bind1(
            device,
            &layout1,
            &tess_uniform,
            &topo_buffer,
            &vertices,
            &indices,
            &bounds,
        );
        Ok(GpuTessellator {
            kind: table.kind,
            precision,
            topology,
            max_binding,
            max_groups,
            main_table: make("tess_main"),
            main_basis: make("tess_basis_main"),
            copy: make("tess_copy_main"),
            bounds_pipeline: make("tess_bounds_main"),
            layout0,
            layout1,
            params,
            patch_data,
            grid_w,
            tess_uniform,
            topo_buffer,
            vertices,
            indices,
            indirect,
            bounds,
            group0,
            group1,
            uniform: TessUniform::default(),
            counts: None,
            levels: None,
            level_cap: None,
            level_group: None,
        })
    }

    /// Usage of the vertex buffer.
    pub const VERTEX_USAGE: wgpu::BufferUsages = wgpu::BufferUsages::VERTEX
        .union(wgpu::BufferUsages::STORAGE)
        .union(wgpu::BufferUsages::COPY_SRC)
        .union(wgpu::BufferUsages::COPY_DST);
    /// Usage of the index buffer.
    pub const INDEX_USAGE: wgpu::BufferUsages = wgpu::BufferUsages::INDEX
        .union(wgpu::BufferUsages::STORAGE)
        .union(wgpu::BufferUsages::COPY_SRC)
        .union(wgpu::BufferUsages::COPY_DST);

    pub(super) fn bind0(
        device: &wgpu::Device,
        layout: &wgpu::BindGroupLayout,
        params: &wgpu::Buffer,
        patch_data: &wgpu::Buffer,
        grid_w: &wgpu::Buffer,
    ) -> wgpu::BindGroup {
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("g1tess tessellate eval"),
            layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: params.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: patch_data.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 4,
                    resource: grid_w.as_entire_binding(),
                },
            ],
        })
    }

    pub(super) fn bind1(
        device: &wgpu::Device,
        layout: &wgpu::BindGroupLayout,
        uniform: &wgpu::Buffer,
        topology: &wgpu::Buffer,
        vertices: &wgpu::Buffer,
        indices: &wgpu::Buffer,
        bounds: &wgpu::Buffer,
    ) -> wgpu::BindGroup {
        crate::gpu::bind_buffers(
            device,
            "g1tess tessellate",
            layout,
            &[uniform, topology, vertices, indices, bounds],
        )
    }

    /// Grows the vertex and index buffers to at least `vertex_bytes` and `index_bytes`,
    /// making the tessellation bind group again when either was replaced.
    pub(super) fn grow_outputs(
        &mut self,
        device: &wgpu::Device,
        vertex_bytes: u64,
        index_bytes: u64,
    ) {
        let grew_vertices = grow(
            device,
            &mut self.vertices,
            vertex_bytes,
            "tess vertices",
            Self::VERTEX_USAGE,
        );
        let grew_indices = grow(
            device,
            &mut self.indices,
            index_bytes,
            "tess indices",
            Self::INDEX_USAGE,
        );
        if grew_vertices || grew_indices {
            self.level_group = None;
            self.group1 = Self::bind1(
                device,
                &self.layout1,
                &self.tess_uniform,
                &self.topo_buffer,
                &self.vertices,
                &self.indices,
                &self.bounds,
            );
        }
    }
}
