//! Work in steps through two buffers: the thread pool produces step k + 1 into one while
//! the calling thread consumes step k from the other. The f32 grid kernel
//! (`eval::cpu::grid_f32`: chunks of samples) and the stitcher (`tess::stitch`: batches of
//! patch outputs) run their consumers, the user's sink, this way.

/// Steps of at most `step` items over `0..total`: `produce(start, len, buf)` fills `buf`
/// with items `start..start + len` (on the thread pool, but for the first step), and
/// `consume(start, len, buf)` reads them, in order, on the calling thread, while the next
/// step is produced into the other buffer (steps are produced one at a time, in order, so
/// `produce` may keep state of its own). `next` must hold a step wherever there is more
/// than one. The first error of `consume` stops the steps (after the step being produced
/// meanwhile) and is returned.
pub(crate) fn double_buffered<'a, B, E>(
    mut cur: &'a mut B,
    mut next: &'a mut B,
    total: usize,
    step: usize,
    mut produce: impl FnMut(usize, usize, &mut B) + Send,
    mut consume: impl FnMut(usize, usize, &B) -> Result<(), E>,
) -> Result<(), E>
where
    B: Send + ?Sized,
{
    let step = step.max(1);
    let (mut start, mut len) = (0, step.min(total));
    if len > 0 {
        produce(0, len, cur);
    }
    while len > 0 {
        let after = start + len;
        let more = step.min(total - after);
        let (ready, building, produce) = (&*cur, &mut *next, &mut produce);
        rayon::in_place_scope(|s| {
            if more > 0 {
                s.spawn(move |_| produce(after, more, building));
            }
            consume(start, len, ready)
        })?;
        std::mem::swap(&mut cur, &mut next);
        (start, len) = (after, more);
    }
    Ok(())
}
