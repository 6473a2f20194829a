//! Large read-mostly tables on transparent huge pages.
//!
//! A per-vertex kernel that reads a few scattered values from each vertex's
//! own block of a large table (the near-field propagation reads about ten
//! coefficients from each vertex's 4 KB transport) touches a new 4 KB page
//! per vertex: a TLB miss and a page walk each, which software prefetches
//! wait on too. On 2 MB pages the same table needs 512× fewer TLB entries.
//!
//! Linux maps anonymous memory on huge pages only where asked
//! (`/sys/kernel/mm/transparent_hugepage/enabled` is `madvise` on most
//! distributions), so [`vec_on_huge_pages`] asks (`madvise(MADV_HUGEPAGE)`)
//! for its allocation before the first write faults its pages in. The
//! advice is a hint: where it is refused (`never`, another OS, a table
//! smaller than a huge page) the vector is an ordinary one, with the same
//! contents.

/// The huge page size the advice aims at (x86-64 and most AArch64 kernels).
pub const HUGE_PAGE_BYTES: usize = 2 << 20;

/// `len` copies of `value`, in memory advised onto transparent huge pages
/// (module docs) before it is written.
#[must_use]
pub fn vec_on_huge_pages<T: Copy>(len: usize, value: T) -> Vec<T> {
    let mut v: Vec<T> = Vec::with_capacity(len);
    advise_huge_pages(v.as_ptr().cast::<u8>(), len * size_of::<T>());
    v.resize(len, value);
    v
}

/// Advises the whole huge pages inside `[ptr, ptr + bytes)` (memory this
/// process owns and has not written yet).
#[cfg(target_os = "linux")]
fn advise_huge_pages(ptr: *const u8, bytes: usize) {
    let start = (ptr as usize).next_multiple_of(HUGE_PAGE_BYTES);
    let end = (ptr as usize).saturating_add(bytes) / HUGE_PAGE_BYTES * HUGE_PAGE_BYTES;
    if end > start {
        // SAFETY: the range lies inside one live allocation of ours and
        // starts on a page boundary; MADV_HUGEPAGE changes no contents. A
        // failure (THP disabled, an old kernel) leaves ordinary pages.
        unsafe {
            libc::madvise(start as *mut libc::c_void, end - start, libc::MADV_HUGEPAGE);
        }
    }
}

#[cfg(not(target_os = "linux"))]
fn advise_huge_pages(_ptr: *const u8, _bytes: usize) {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn contents_are_those_asked_for_at_every_size() {
        for len in [0, 1, 1000, HUGE_PAGE_BYTES / 4 + 3, 3 * HUGE_PAGE_BYTES / 4] {
            let v = vec_on_huge_pages(len, 1.5f32);
            assert_eq!(v.len(), len);
            assert!(v.iter().all(|&x| x == 1.5));
        }
    }

    /// Where the kernel honours the advice, a table of a few huge pages
    /// gets some (the test reads `/proc/self/smaps`; it checks only what
    /// the machine's THP settings allow: advised memory on huge pages, and
    /// compaction at the fault for it when none is free).
    #[cfg(target_os = "linux")]
    #[test]
    fn a_large_table_lands_on_huge_pages_where_the_kernel_allows() {
        let setting = |name: &str| {
            std::fs::read_to_string(format!("/sys/kernel/mm/transparent_hugepage/{name}"))
                .unwrap_or_default()
        };
        let (mode, defrag) = (setting("enabled"), setting("defrag"));
        let honoured = (mode.contains("[madvise]") || mode.contains("[always]"))
            && ["[always]", "[madvise]", "[defer+madvise]"]
                .iter()
                .any(|d| defrag.contains(d));
        let v = vec_on_huge_pages(HUGE_PAGE_BYTES, 0.0f32);
        let addr = v.as_ptr() as usize;
        let smaps = std::fs::read_to_string("/proc/self/smaps").unwrap_or_default();
        let mut in_table = false;
        let mut huge_kb = 0u64;
        for line in smaps.lines() {
            if let Some((range, _)) = line.split_once(' ')
                && let Some((lo, hi)) = range.split_once('-')
                && let (Ok(lo), Ok(hi)) =
                    (usize::from_str_radix(lo, 16), usize::from_str_radix(hi, 16))
            {
                in_table = lo <= addr + v.len() * 4 && addr < hi;
            } else if in_table && let Some(rest) = line.strip_prefix("AnonHugePages:") {
                huge_kb += rest
                    .trim()
                    .trim_end_matches(" kB")
                    .trim()
                    .parse::<u64>()
                    .unwrap_or(0);
            }
        }
        if honoured {
            assert!(
                huge_kb >= 2048,
                "THP {mode:?}, defrag {defrag:?}: {huge_kb} kB on huge pages"
            );
        }
        assert!(v.iter().all(|&x| x == 0.0));
    }
}
