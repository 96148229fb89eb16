//! Data parallelism behind the `parallel` feature.
//!
//! With the feature (the default) this is `rayon::prelude`. Without it, the same iterator
//! chains (`par_iter`, `into_par_iter`, `par_chunks`, `par_chunks_mut`, `par_sort_unstable`,
//! `with_min_len`, `flat_map_iter`, `map_init`, `for_each_init`) run sequentially on the
//! standard library's iterators. Every call site collects in order, sorts values whose equal
//! elements are indistinguishable, or writes disjoint chunks, so both builds give the same
//! results.

#[cfg(feature = "parallel")]
pub(crate) use rayon::prelude::*;

#[cfg(not(feature = "parallel"))]
pub(crate) use sequential::*;

#[cfg(not(feature = "parallel"))]
#[allow(
    dead_code,
    reason = "each crate uses a different part of rayon's surface"
)]
mod sequential {
    /// `into_par_iter` for anything iterable: its ordinary iterator.
    pub(crate) trait IntoParallelIterator: IntoIterator + Sized {
        fn into_par_iter(self) -> Self::IntoIter {
            self.into_iter()
        }
    }

    impl<I: IntoIterator> IntoParallelIterator for I {}

    /// `par_iter` and `par_chunks` on slices (and, by deref, vectors).
    pub(crate) trait ParallelSlice<T> {
        fn par_iter(&self) -> std::slice::Iter<'_, T>;
        fn par_chunks(&self, size: usize) -> std::slice::Chunks<'_, T>;
    }

    impl<T> ParallelSlice<T> for [T] {
        fn par_iter(&self) -> std::slice::Iter<'_, T> {
            self.iter()
        }
        fn par_chunks(&self, size: usize) -> std::slice::Chunks<'_, T> {
            self.chunks(size)
        }
    }

    /// `par_chunks_mut` and `par_sort_unstable` on mutable slices.
    pub(crate) trait ParallelSliceMut<T> {
        fn par_chunks_mut(&mut self, size: usize) -> std::slice::ChunksMut<'_, T>;
        fn par_sort_unstable(&mut self)
        where
            T: Ord;
    }

    impl<T> ParallelSliceMut<T> for [T] {
        fn par_chunks_mut(&mut self, size: usize) -> std::slice::ChunksMut<'_, T> {
            self.chunks_mut(size)
        }
        fn par_sort_unstable(&mut self)
        where
            T: Ord,
        {
            self.sort_unstable();
        }
    }

    /// rayon's adapters that the standard iterators lack, with their sequential meaning.
    pub(crate) trait ParallelIterator: Iterator + Sized {
        /// A splitting hint: no effect on one thread.
        fn with_min_len(self, _min: usize) -> Self {
            self
        }

        /// `flat_map` with a sequential inner iterator.
        fn flat_map_iter<U, F>(self, f: F) -> std::iter::FlatMap<Self, U, F>
        where
            U: IntoIterator,
            F: FnMut(Self::Item) -> U,
        {
            self.flat_map(f)
        }

        /// `map` with one scratch value made by `init` (rayon makes one per split).
        fn map_init<T, R>(
            self,
            init: impl FnOnce() -> T,
            mut f: impl FnMut(&mut T, Self::Item) -> R,
        ) -> impl Iterator<Item = R> {
            let mut scratch = init();
            self.map(move |item| f(&mut scratch, item))
        }

        /// `for_each` with one scratch value made by `init` (rayon makes one per split).
        fn for_each_init<T>(self, init: impl FnOnce() -> T, mut f: impl FnMut(&mut T, Self::Item)) {
            let mut scratch = init();
            self.for_each(|item| f(&mut scratch, item));
        }
    }

    impl<I: Iterator> ParallelIterator for I {}
}
