//! Reading a buffer back from the GPU: map, wait, hand out the bytes, unmap, with every
//! failure an [`Error::Gpu`] instead of a panic.

use crate::{Error, Result};

/// Maps the first `bytes` bytes of `buffer` (which needs [`wgpu::BufferUsages::MAP_READ`],
/// and whose copies into it have been submitted), waits for the device, hands the bytes to
/// `f` and unmaps the buffer again, also when `f` fails.
///
/// `bytes` must be a multiple of [`wgpu::COPY_BUFFER_ALIGNMENT`] (4); the mapped bytes
/// start at offset 0, [`wgpu::MAP_ALIGNMENT`]-aligned, so `f` may cast them to `f32`,
/// `f64` or `u32` with `bytemuck`. Errors when mapping fails (a lost device, a buffer in use) or the
/// map callback never runs.
///
/// ```no_run
/// # fn demo(device: &wgpu::Device, staging: &wgpu::Buffer) -> g1tess::Result<()> {
/// let floats: Vec<f32> = g1tess::read_buffer(device, staging, 64, |b| {
///     bytemuck::cast_slice(b).to_vec()
/// })?;
/// # let _ = floats;
/// # Ok(())
/// # }
/// ```
pub fn read_buffer<T>(
    device: &wgpu::Device,
    buffer: &wgpu::Buffer,
    bytes: u64,
    f: impl FnOnce(&[u8]) -> T,
) -> Result<T> {
    read_buffer_after(device, buffer, bytes, None, f)
}

/// [`read_buffer`] waiting only for submission `after` (the one that wrote `buffer`), not
/// for every submission: work submitted later keeps running while `f` reads (double
/// buffering). `None` waits for everything submitted.
pub fn read_buffer_after<T>(
    device: &wgpu::Device,
    buffer: &wgpu::Buffer,
    bytes: u64,
    after: Option<wgpu::SubmissionIndex>,
    f: impl FnOnce(&[u8]) -> T,
) -> Result<T> {
    if bytes == 0 {
        return Ok(f(&[]));
    }
    if bytes > buffer.size() {
        return Err(Error::Gpu(format!(
            "reading {bytes} bytes back from a buffer of {} bytes",
            buffer.size()
        )));
    }
    let slice = buffer.slice(..bytes);
    let (tx, rx) = std::sync::mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |r| {
        let _ = tx.send(r);
    });
    device
        .poll(wgpu::PollType::Wait {
            submission_index: after,
            timeout: None,
        })
        .map_err(|e| Error::Gpu(format!("device poll: {e}")))?;
    rx.recv()
        .map_err(|_| Error::Gpu("reading a buffer back: the map callback never ran".into()))?
        .map_err(|e| Error::Gpu(format!("reading a buffer back: mapping failed: {e}")))?;
    let out = slice
        .get_mapped_range()
        .map_err(|e| Error::Gpu(format!("reading a buffer back: {e}")))
        .map(|view| f(&view));
    buffer.unmap();
    out
}
