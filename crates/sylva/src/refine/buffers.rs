//! The buffers refinement writes: parallel fills in fixed chunks (the same bytes for any
//! thread count), allocations that fail with [`RefineError::OutOfMemory`] instead of
//! aborting, and views of fully written uninitialised slots.

use super::*;
/// Elements per parallel task.
const CHUNK: usize = 2048;

/// `dst[i] = f(i)` for every element, on the rayon pool when `par`.
pub(crate) fn fill<T: Send>(par: bool, dst: &mut [T], f: impl Fn(usize, &mut T) + Sync) {
    if par && dst.len() > CHUNK {
        dst.par_chunks_mut(CHUNK).enumerate().for_each(|(ci, chunk)| {
            let base = ci * CHUNK;
            for (k, x) in chunk.iter_mut().enumerate() {
                f(base + k, x);
            }
        });
    } else {
        for (i, x) in dst.iter_mut().enumerate() {
            f(i, x);
        }
    }
}

/// Fills `dst` in chunks of `n` elements: `f(i, &mut dst[i*n..(i+1)*n])`.
pub(crate) fn fill_chunks<T: Send>(par: bool, dst: &mut [T], n: usize, f: impl Fn(usize, &mut [T]) + Sync) {
    if par && dst.len() > CHUNK * n {
        dst.par_chunks_mut(CHUNK * n).enumerate().for_each(|(ci, chunk)| {
            for (k, x) in chunk.chunks_mut(n).enumerate() {
                f(ci * CHUNK + k, x);
            }
        });
    } else {
        for (i, x) in dst.chunks_mut(n).enumerate() {
            f(i, x);
        }
    }
}

/// The error of a failed allocation of `n` values of `T` for `what`.
fn out_of_memory<T>(n: usize, what: &'static str) -> RefineError {
    RefineError::OutOfMemory { what, bytes: n as u128 * std::mem::size_of::<T>() as u128 }
}

/// `n` uninitialised slots, for outputs that a kernel writes completely (saves zeroing
/// large arrays and lets the first touch of each page happen in the parallel writers),
/// or [`RefineError::OutOfMemory`] naming `what` when the allocation fails.
pub(crate) fn try_uninit_vec<T>(n: usize, what: &'static str) -> Result<Vec<MaybeUninit<T>>, RefineError> {
    let mut v = Vec::new();
    v.try_reserve_exact(n).map_err(|_| out_of_memory::<T>(n, what))?;
    // SAFETY: `MaybeUninit` needs no initialisation, and the capacity is at least `n`.
    unsafe { v.set_len(n) };
    Ok(v)
}

/// An empty vector with room for `n` values, or [`RefineError::OutOfMemory`].
pub(crate) fn try_with_capacity<T>(n: usize, what: &'static str) -> Result<Vec<T>, RefineError> {
    let mut v = Vec::new();
    v.try_reserve_exact(n).map_err(|_| out_of_memory::<T>(n, what))?;
    Ok(v)
}

/// Types whose all-zero bit pattern is a valid value (index arrays).
///
/// # Safety
/// Implement only for types valid when zeroed.
pub(crate) unsafe trait Zeroable: Copy {}
// SAFETY: integers and arrays of them are valid when zeroed.
unsafe impl Zeroable for u32 {}
// SAFETY: as above.
unsafe impl Zeroable for [u32; 2] {}

/// `n` zeros (as `vec![0; n]`, whose pages the system zeroes lazily), or
/// [`RefineError::OutOfMemory`] naming `what` when the allocation fails.
pub(crate) fn try_zeroed<T: Zeroable>(n: usize, what: &'static str) -> Result<Vec<T>, RefineError> {
    let layout = std::alloc::Layout::array::<T>(n).map_err(|_| out_of_memory::<T>(n, what))?;
    if layout.size() == 0 {
        return Ok(Vec::new());
    }
    // SAFETY: the layout has a non-zero size.
    let ptr = unsafe { std::alloc::alloc_zeroed(layout) }.cast::<T>();
    if ptr.is_null() {
        return Err(out_of_memory::<T>(n, what));
    }
    // SAFETY: allocated by the global allocator with `T`'s layout for `n` values, all
    // valid because `T: Zeroable`.
    Ok(unsafe { Vec::from_raw_parts(ptr, n, n) })
}

/// A copy of `src`, or [`RefineError::OutOfMemory`] naming `what`.
pub(crate) fn try_to_vec<T: Copy>(src: &[T], what: &'static str) -> Result<Vec<T>, RefineError> {
    let mut v = try_with_capacity(src.len(), what)?;
    v.extend_from_slice(src);
    Ok(v)
}

/// Views fully written slots as values.
///
/// # Safety
/// Every element of `s` must have been written.
pub(crate) unsafe fn assume_init<T>(s: &[MaybeUninit<T>]) -> &[T] {
    // SAFETY: same layout; initialised by the caller's contract.
    unsafe { std::slice::from_raw_parts(s.as_ptr().cast::<T>(), s.len()) }
}

/// Mutable view of fully written slots as values.
///
/// # Safety
/// Every element of `s` must have been written.
pub(crate) unsafe fn assume_init_mut<T>(s: &mut [MaybeUninit<T>]) -> &mut [T] {
    // SAFETY: same layout; initialised by the caller's contract.
    unsafe { std::slice::from_raw_parts_mut(s.as_mut_ptr().cast::<T>(), s.len()) }
}

/// Turns a fully written vector into a vector of values.
///
/// # Safety
/// Every element of `v` must have been written.
pub(crate) unsafe fn into_init<T>(v: Vec<MaybeUninit<T>>) -> Vec<T> {
    let mut v = std::mem::ManuallyDrop::new(v);
    // SAFETY: same layout, length and capacity; initialised by the caller's contract.
    unsafe { Vec::from_raw_parts(v.as_mut_ptr().cast::<T>(), v.len(), v.capacity()) }
}
