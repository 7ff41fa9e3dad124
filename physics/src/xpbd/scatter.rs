//! Writes to distinct elements of one slice from several threads.
//!
//! The coloured solvers move the particles of many constraints at once; a
//! colour never holds two constraints that move the same particle, so no
//! two threads ever touch one element. `Scatter` is the raw view that lets
//! them do so without a lock.

use std::marker::PhantomData;

/// A shared, unchecked view of a mutable slice.
pub(crate) struct Scatter<'a, T> {
    ptr: *mut T,
    len: usize,
    _borrow: PhantomData<&'a mut [T]>,
}

impl<T> Clone for Scatter<'_, T> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<T> Copy for Scatter<'_, T> {}

// SAFETY: a `Scatter` is only used where the callers guarantee that no two
// threads read and write the same element (the colouring's invariant).
unsafe impl<T: Send> Send for Scatter<'_, T> {}
// SAFETY: as above.
unsafe impl<T: Send> Sync for Scatter<'_, T> {}

impl<'a, T: Copy> Scatter<'a, T> {
    /// A view of `slice` for the lifetime of the borrow.
    pub(crate) fn new(slice: &'a mut [T]) -> Self {
        Self {
            ptr: slice.as_mut_ptr(),
            len: slice.len(),
            _borrow: PhantomData,
        }
    }

    /// The element at `i`.
    ///
    /// # Safety
    /// No other thread writes element `i` while this runs.
    #[inline(always)]
    pub(crate) unsafe fn get(self, i: usize) -> T {
        assert!(i < self.len);
        // SAFETY: in bounds (checked); no concurrent write (the caller's promise).
        unsafe { *self.ptr.add(i) }
    }

    /// Sets the element at `i`.
    ///
    /// # Safety
    /// No other thread reads or writes element `i` while this runs.
    #[inline(always)]
    pub(crate) unsafe fn set(self, i: usize, v: T) {
        assert!(i < self.len);
        // SAFETY: in bounds (checked); exclusive (the caller's promise).
        unsafe { *self.ptr.add(i) = v }
    }
}
