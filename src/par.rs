//! Vectors made, and searches run, on the thread pool.

use rayon::prelude::*;

/// `n` values made by `make`, each written once on the pool (rayon's indexed collect writes
/// straight into the vector). Besides the speed: on fresh memory the first write to a page
/// is what maps it in (and the kernel zeroes it then), so the pages of a vector made here
/// are mapped by the pool's threads, not by the one-thread loop that writes it next.
pub(crate) fn filled_with<T: Send>(n: usize, make: impl Fn() -> T + Sync + Send) -> Vec<T> {
    (0..n).into_par_iter().map(|_| make()).collect()
}

/// The values of `cells` (atomics, typically made by [`filled_with`] and written on the
/// pool), each through `take`, in one task and in place: the standard library's collect
/// reuses the allocation where the sizes match (an optimisation it does not promise),
/// where a collect on the pool would fault in a new vector's pages.
pub(crate) fn into_values<A, T>(cells: Vec<A>, take: impl FnMut(A) -> T) -> Vec<T> {
    cells.into_iter().map(take).collect()
}

/// Indices searched by one task of [`first_index`]: enough that a task's cost is its loop,
/// not rayon's bookkeeping.
const STRETCH: usize = 1 << 14;

/// The first `i` in `0..n` for which `holds(i)`, as `(0..n).find(holds)` gives it, searched
/// on the pool a stretch of [`STRETCH`] indices per task. Rayon's `position_first` over the
/// items does the same search with its bookkeeping per item: on the 2 M-triangle ogre of
/// BENCHMARKS.md the mesh's and the numbering's checks took 68 ms of CPU that way.
pub(crate) fn first_index(n: usize, holds: impl Fn(usize) -> bool + Sync) -> Option<usize> {
    (0..n.div_ceil(STRETCH))
        .into_par_iter()
        .find_map_first(|k| (k * STRETCH..n.min((k + 1) * STRETCH)).find(|&i| holds(i)))
}

/// Whether `holds(i)` for every `i` in `0..n`: [`first_index`] of the first that does not.
pub(crate) fn all_indices(n: usize, holds: impl Fn(usize) -> bool + Sync) -> bool {
    first_index(n, |i| !holds(i)).is_none()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The first index found is the serial search's, wherever the matches are: none, one at
    /// either end, several in one stretch and in many, across stretch boundaries.
    #[test]
    fn first_index_is_the_serial_search() {
        let n = 5 * STRETCH + 17;
        let cases: Vec<Vec<usize>> = vec![
            vec![],
            vec![0],
            vec![n - 1],
            vec![STRETCH - 1, STRETCH],
            vec![STRETCH, STRETCH - 1],
            vec![3 * STRETCH + 5, 3 * STRETCH + 4, 4 * STRETCH],
            (0..n).step_by(7).rev().collect(),
        ];
        for hits in cases {
            let mut marked = vec![false; n];
            for &h in &hits {
                marked[h] = true;
            }
            let want = marked.iter().position(|&m| m);
            assert_eq!(first_index(n, |i| marked[i]), want, "hits {hits:?}");
            assert_eq!(
                all_indices(n, |i| !marked[i]),
                want.is_none(),
                "hits {hits:?}"
            );
        }
        assert_eq!(first_index(0, |_| true), None);
        assert_eq!(first_index(1, |_| true), Some(0));
    }
}
