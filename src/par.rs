//! Vectors made on the thread pool.

use rayon::prelude::*;

/// `n` values made by `make`, each written once on the pool (rayon's indexed collect writes
/// straight into the vector). Besides the speed: on fresh memory the first write to a page
/// is what maps it in (and the kernel zeroes it then), so the pages of a vector made here
/// are mapped by the pool's threads, not by the one-thread loop that writes it next.
pub(crate) fn filled_with<T: Send>(n: usize, make: impl Fn() -> T + Sync + Send) -> Vec<T> {
    (0..n).into_par_iter().map(|_| make()).collect()
}
