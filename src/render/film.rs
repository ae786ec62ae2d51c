//! The film: the rendered image as linear HDR RGB.

use glam::Vec3;

/// A vector of `n` copies of `value`, or an error naming `what` if the memory cannot be had
/// (instead of aborting the process): how films, their sums and layers are allocated.
pub fn try_filled<T: Clone>(n: usize, value: T, what: &str) -> Result<Vec<T>, OutOfMemory> {
    let mut v: Vec<T> = Vec::new();
    v.try_reserve_exact(n).map_err(|_| {
        let bytes = n as f64 * std::mem::size_of::<T>() as f64;
        OutOfMemory(format!("out of memory for the {what}: {n} values, {:.3} GB", bytes / 1e9))
    })?;
    advise_huge_pages(v.as_ptr().cast(), n * std::mem::size_of::<T>());
    v.resize(n, value);
    Ok(v)
}

/// Buffers of at least one huge page (bytes) ask for transparent huge pages: a frame's exact sums
/// (96 bytes a pixel) are first touched by the render, and with 4 KiB pages the kernel's page
/// faults took 14–23 % of a 1-spp render (benches/peers/PROFILE.md); one 2 MiB page replaces 512.
const HUGE_PAGE_MIN_BYTES: usize = 2 << 20;

/// Asks the kernel to back the `bytes` at `ptr` (not yet touched) with transparent huge pages
/// where it can. Advice only: contents and results do not change; failures are ignored.
fn advise_huge_pages(ptr: *const u8, bytes: usize) {
    #[cfg(target_os = "linux")]
    if bytes >= HUGE_PAGE_MIN_BYTES {
        const PAGE: usize = 4096;
        let start = (ptr as usize).next_multiple_of(PAGE);
        let end = ptr as usize + bytes;
        if end > start {
            // SAFETY: [start, end) lies inside one live allocation of ours; MADV_HUGEPAGE only
            // changes how the kernel backs those pages, never their contents or the mapping.
            unsafe { libc::madvise(start as *mut libc::c_void, end - start, libc::MADV_HUGEPAGE) };
        }
    }
    #[cfg(not(target_os = "linux"))]
    let _ = (ptr, bytes);
}

/// An image buffer whose memory could not be had; the message names it and its size.
#[derive(Debug)]
pub struct OutOfMemory(pub String);

impl std::fmt::Display for OutOfMemory {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for OutOfMemory {}

/// A `width × height` image of linear RGB, row-major from the top-left pixel.
///
/// Stored as `f32`: 24 bits of mantissa are far beyond what 8-bit or half-float output needs, and
/// it halves the memory of `f64`. All shading arithmetic happens in `f64` before a pixel is stored.
#[derive(Clone, Debug, PartialEq)]
pub struct Film {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// `width × height` pixels, row by row.
    pub pixels: Vec<Vec3>,
}

impl Film {
    /// A black film, or an error naming its size if its memory cannot be had (never an abort:
    /// a size within the limits can still be more than the machine has).
    pub fn new(width: u32, height: u32) -> Result<Self, OutOfMemory> {
        let n = (width as usize).saturating_mul(height as usize);
        let pixels =
            try_filled(n, Vec3::ZERO, "film").map_err(|e| OutOfMemory(e.0.replacen("film:", &format!("{width}×{height} film:"), 1)))?;
        Ok(Film { width, height, pixels })
    }

    /// The pixel at column `x`, row `y`.
    pub fn get(&self, x: u32, y: u32) -> Vec3 {
        self.pixels[y as usize * self.width as usize + x as usize]
    }

    /// Sets the pixel at column `x`, row `y`.
    pub fn set(&mut self, x: u32, y: u32, c: Vec3) {
        self.pixels[y as usize * self.width as usize + x as usize] = c;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A film larger than the address space is an error naming its size, not an abort; one that
    /// fits is black.
    #[test]
    fn a_film_that_cannot_be_had_is_an_error_with_its_size() {
        // 2⁴⁶ pixels of 12 bytes: 844 TB, beyond any 64-bit machine's user address space.
        let e = Film::new(1 << 24, 1 << 22).unwrap_err();
        assert_eq!(e.0, "out of memory for the 16777216×4194304 film: 70368744177664 values, 844424.930 GB");
        let e = Film::new(u32::MAX, u32::MAX).unwrap_err();
        assert!(e.0.starts_with("out of memory for the 4294967295×4294967295 film: "), "{e}");
        let f = Film::new(3, 2).unwrap();
        assert_eq!((f.width, f.height, f.pixels.len()), (3, 2, 6));
        assert!(f.pixels.iter().all(|p| *p == Vec3::ZERO));
    }
}
