//! Transparent huge pages for the planner's node array.
//!
//! A whole-map search reads its nodes in wavefront order, a few rows at a time across
//! the whole array: with 4 KiB pages a 1000² map spans 4 000 pages, more than the TLB
//! holds, and a fresh array takes one page fault per page. Asking the kernel for 2 MiB
//! pages (as NumPy does for large arrays) removes most of both. It is advice only: where
//! the kernel declines, nothing changes but the speed.

/// Size of a transparent huge page on x86-64 and most aarch64 kernels.
#[cfg(target_os = "linux")]
const HUGE_PAGE: usize = 2 << 20;

/// Advises the kernel to back the spare capacity of `buffer` with huge pages. Call it
/// before the elements are written, so that the first touch faults in huge pages.
pub fn advise<T>(buffer: &mut Vec<T>) {
    #[cfg(target_os = "linux")]
    {
        let bytes = buffer.capacity() * size_of::<T>();
        if bytes < 2 * HUGE_PAGE {
            return;
        }
        let start = buffer.as_mut_ptr() as usize;
        // madvise takes page-aligned ranges: the huge pages wholly inside the buffer.
        let first = start.next_multiple_of(HUGE_PAGE);
        let end = (start + bytes) / HUGE_PAGE * HUGE_PAGE;
        if end > first {
            // SAFETY: the range lies inside the buffer's allocation, and MADV_HUGEPAGE
            // changes how the pages are backed, never their contents.
            unsafe {
                libc::madvise(first as *mut libc::c_void, end - first, libc::MADV_HUGEPAGE);
            }
        }
    }
    #[cfg(not(target_os = "linux"))]
    let _ = buffer;
}
