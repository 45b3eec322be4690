//! Reading a buffer back from the GPU: map, wait, hand out the bytes, unmap, with every
//! failure an [`Error::Gpu`] instead of a panic. [`read_buffer`] blocks (native only: on the
//! web it returns an error); [`read_buffer_async`] awaits, on the web and natively.

use std::future::Future;
use std::pin::Pin;
use std::sync::{Arc, Mutex};
use std::task::{Context, Poll, Waker};

use crate::{Error, Result};

/// Maps the first `bytes` bytes of `buffer` (which needs [`wgpu::BufferUsages::MAP_READ`],
/// and whose copies into it have been submitted), waits for the device, hands the bytes to
/// `f` and unmaps the buffer again, also when `f` fails.
///
/// `bytes` must be a multiple of [`wgpu::COPY_BUFFER_ALIGNMENT`] (4); the mapped bytes
/// start at offset 0, [`wgpu::MAP_ALIGNMENT`]-aligned, so `f` may cast them to `f32`,
/// `f64` or `u32` with `bytemuck`. Errors when mapping fails (a lost device, a buffer in use) or the
/// map callback never runs. On the web (wasm32), which cannot block, it returns an error
/// at once: await [`read_buffer_async`] there.
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
    check_size(buffer, bytes)?;
    if cfg!(target_arch = "wasm32") {
        return Err(Error::Gpu(
            "reading a buffer back: the web cannot block; use read_buffer_async".into(),
        ));
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

/// [`read_buffer`] as a future, for the web (wasm32), where the browser maps the buffer
/// while the page's event loop runs and nothing may block: the same checks, bytes and
/// errors. Natively the device is polled until the mapping is done (wgpu's native backends
/// make progress only when polled), so the future is ready when first polled, under any
/// executor.
///
/// ```no_run
/// # async fn demo(device: &wgpu::Device, staging: &wgpu::Buffer) -> g1tess::Result<()> {
/// let counts: Vec<u32> = g1tess::read_buffer_async(device, staging, 16, |b| {
///     bytemuck::cast_slice(b).to_vec()
/// })
/// .await?;
/// # let _ = counts;
/// # Ok(())
/// # }
/// ```
pub async fn read_buffer_async<T>(
    device: &wgpu::Device,
    buffer: &wgpu::Buffer,
    bytes: u64,
    f: impl FnOnce(&[u8]) -> T,
) -> Result<T> {
    if bytes == 0 {
        return Ok(f(&[]));
    }
    check_size(buffer, bytes)?;
    let slice = buffer.slice(..bytes);
    let slot = Arc::new(Mutex::new(Slot::default()));
    let sender = Sender(slot.clone());
    slice.map_async(wgpu::MapMode::Read, move |r| sender.send(r));
    if !cfg!(target_arch = "wasm32") {
        device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| Error::Gpu(format!("device poll: {e}")))?;
    }
    Mapped(slot)
        .await
        .map_err(|e| Error::Gpu(format!("reading a buffer back: {e}")))?;
    let out = slice
        .get_mapped_range()
        .map_err(|e| Error::Gpu(format!("reading a buffer back: {e}")))
        .map(|view| f(&view));
    buffer.unmap();
    out
}

/// The error for reading more bytes than `buffer` holds.
fn check_size(buffer: &wgpu::Buffer, bytes: u64) -> Result<()> {
    if bytes > buffer.size() {
        return Err(Error::Gpu(format!(
            "reading {bytes} bytes back from a buffer of {} bytes",
            buffer.size()
        )));
    }
    Ok(())
}

/// The outcome of one `map_async` (`None` until its callback runs) and the task waiting for it.
#[derive(Default)]
struct Slot {
    done: Option<std::result::Result<(), String>>,
    waker: Option<Waker>,
}

/// The map callback's half: stores the outcome and wakes the waiting task; dropped without
/// sending (wgpu dropped the callback unrun) it stores an error, so the future never hangs.
struct Sender(Arc<Mutex<Slot>>);

impl Sender {
    fn send(self, r: std::result::Result<(), wgpu::BufferAsyncError>) {
        self.finish(r.map_err(|e| format!("mapping failed: {e}")));
    }

    fn finish(&self, r: std::result::Result<(), String>) {
        let waker = self.0.lock().ok().and_then(|mut slot| {
            slot.done.get_or_insert(r);
            slot.waker.take()
        });
        if let Some(w) = waker {
            w.wake();
        }
    }
}

impl Drop for Sender {
    fn drop(&mut self) {
        self.finish(Err("the map callback never ran".into()));
    }
}

/// The waiting half: ready once the callback has run (or was dropped).
struct Mapped(Arc<Mutex<Slot>>);

impl Future for Mapped {
    type Output = std::result::Result<(), String>;

    fn poll(self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<Self::Output> {
        let Ok(mut slot) = self.0.lock() else {
            return Poll::Ready(Err("the map state is poisoned".into()));
        };
        match slot.done.take() {
            Some(r) => Poll::Ready(r),
            None => {
                slot.waker = Some(cx.waker().clone());
                Poll::Pending
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use wgpu::util::DeviceExt;

    #[test]
    fn the_async_readback_gives_the_blocking_ones_bytes() {
        let ctx = match crate::tests::common::shared_gpu() {
            Ok(ctx) => ctx,
            Err(e) => {
                let ci = std::env::var("CI").is_ok_and(|v| v == "true" || v == "1");
                assert!(!ci, "CI=true and no GPU adapter: {e}");
                eprintln!("SKIP: no GPU adapter ({e}); GPU test not run");
                return;
            }
        };
        let want: Vec<u32> = (0..64u32).map(|i| i.wrapping_mul(2_654_435_761)).collect();
        let buffer = ctx
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("readback test"),
                contents: bytemuck::cast_slice(&want),
                usage: wgpu::BufferUsages::MAP_READ,
            });
        let copy = |b: &[u8]| bytemuck::cast_slice::<u8, u32>(b).to_vec();
        let sync = read_buffer(&ctx.device, &buffer, 256, copy).unwrap();
        // Natively the future is ready when first polled: any executor drives it.
        let fut = read_buffer_async(&ctx.device, &buffer, 256, copy);
        let got = pollster::block_on(fut).unwrap();
        assert_eq!(got, want);
        assert_eq!(sync, want);
        // The first 16 bytes only; more than the buffer holds is an error, not a panic.
        let head = pollster::block_on(read_buffer_async(&ctx.device, &buffer, 16, copy));
        assert_eq!(head.unwrap(), want[..4]);
        let err = pollster::block_on(read_buffer_async(&ctx.device, &buffer, 260, copy));
        assert_eq!(
            err.unwrap_err().to_string(),
            "gpu: reading 260 bytes back from a buffer of 256 bytes"
        );
    }
}
