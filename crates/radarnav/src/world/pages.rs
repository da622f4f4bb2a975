//! Huge pages under the ray search's arrays.
//!
//! A ray through a large mesh world touches a few cache lines in each of many arrays spread
//! over hundreds of megabytes: with 4 KiB pages nearly every such read also misses the TLB
//! and waits for a page walk. Backed by 2 MiB pages the same arrays need 512 times fewer
//! translations. Linux 6.1 and later (`MADV_COLLAPSE`) collapse the pages already holding
//! the arrays in place, whatever the system's `transparent_hugepage` setting short of
//! `never`; elsewhere, and where the kernel declines, nothing changes. Only the page size
//! changes, never what the memory holds, so results stay bit-identical.

/// Where a slice lies: its address and length in bytes.
pub(crate) fn span<T>(items: &[T]) -> (usize, usize) {
    (items.as_ptr().expose_provenance(), size_of_val(items))
}

/// The size of a huge page on x86-64 and most aarch64 kernels.
const HUGE_PAGE: usize = 2 << 20;

/// Below this many bytes the arrays fit the TLB's reach anyway, and a collapse (a copy of
/// each 2 MiB region) would cost more than it saves.
const MIN_BYTES: usize = 8 << 20;

/// Asks the kernel to back the 2 MiB pages holding `spans` (address, bytes) with huge pages,
/// when they add up to at least [`MIN_BYTES`]. One request per page, so that a page the
/// kernel declines (one shared with memory of another kind, or none free) does not stop the
/// rest. Best effort: errors are ignored, since the memory holds the same either way.
pub(crate) fn collapse(spans: impl IntoIterator<Item = (usize, usize)>) {
    for page in huge_pages(spans, MIN_BYTES) {
        advise(page, HUGE_PAGE);
    }
}

/// The starts of the huge pages covering `spans`, each once, in increasing order; none when
/// the spans hold fewer than `min_bytes`.
fn huge_pages(spans: impl IntoIterator<Item = (usize, usize)>, min_bytes: usize) -> Vec<usize> {
    let mut pages = Vec::new();
    let mut total = 0;
    for (addr, len) in spans {
        if len == 0 {
            continue;
        }
        total += len;
        let first = addr / HUGE_PAGE;
        let last = (addr + len - 1) / HUGE_PAGE;
        pages.extend((first..=last).map(|p| p * HUGE_PAGE));
    }
    if total < min_bytes {
        return Vec::new();
    }
    pages.sort_unstable();
    pages.dedup();
    pages
}

#[cfg(target_os = "linux")]
fn advise(addr: usize, len: usize) {
    // SAFETY: MADV_COLLAPSE only changes how the range is mapped (huge pages in place of
    // small ones, contents copied), never what it holds; on unmapped or ineligible memory the
    // kernel returns an error and leaves it alone.
    let _ = unsafe {
        libc::madvise(
            std::ptr::with_exposed_provenance_mut(addr),
            len,
            libc::MADV_COLLAPSE,
        )
    };
}

#[cfg(not(target_os = "linux"))]
fn advise(_addr: usize, _len: usize) {}

#[cfg(test)]
mod tests {
    use super::*;

    const M: usize = HUGE_PAGE;

    #[test]
    fn every_huge_page_a_span_touches_once_in_order() {
        let spans = [
            (5 * M + 100, 10),    // inside page 5
            (2 * M - 8, 16),      // straddles pages 1 and 2
            (3 * M, M),           // exactly page 3
            (9 * M + 1, 0),       // empty: no page
            (5 * M + 4000, 3000), // page 5 again
        ];
        assert_eq!(huge_pages(spans, 0), vec![M, 2 * M, 3 * M, 5 * M]);
    }

    #[test]
    fn small_arrays_are_left_alone() {
        let spans = [(M, 1000), (7 * M, 2000)];
        assert!(huge_pages(spans, 3001).is_empty());
        assert_eq!(huge_pages(spans, 3000), vec![M, 7 * M]);
    }

    #[test]
    fn collapsing_a_live_array_keeps_its_contents() {
        // Whether the kernel grants the huge pages depends on the machine; what must hold
        // everywhere is that the memory reads the same after the call.
        let data: Vec<u64> = (0..(3 * M / 8) as u64)
            .map(|i| i.wrapping_mul(0x9e37_79b9))
            .collect();
        let before: u64 = data.iter().fold(0, |h, &x| h.rotate_left(5) ^ x);
        let (addr, len) = span(&data);
        for page in huge_pages([(addr, len)], 0) {
            advise(page, HUGE_PAGE);
        }
        let after: u64 = data.iter().fold(0, |h, &x| h.rotate_left(5) ^ x);
        assert_eq!(before, after);
    }
}
