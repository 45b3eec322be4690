//! Progress reporting from long library operations, without any terminal code: the library
//! calls a [`Progress`]; the command line implements it with a bar.

/// Receives the phases of a long operation and the work done in each. `Sync`, because an
/// operation may report from a worker of the thread pool ([`crate::fair_with_progress`]
/// runs its search on one).
pub trait Progress: Sync {
    /// A new phase named `phase` over `total` units of work (patches, ...), from zero.
    fn start(&self, phase: &str, total: u64);
    /// `n` more units of the current phase are done.
    fn inc(&self, n: u64);
}

/// Reports nothing.
#[derive(Clone, Copy, Debug, Default)]
pub struct NoProgress;

impl Progress for NoProgress {
    fn start(&self, _: &str, _: u64) {}
    fn inc(&self, _: u64) {}
}
