//! Counters of the work a render did, and of the work it avoided.

use serde::Serialize;
use std::ops::AddAssign;
use std::time::Duration;

/// Rays traced by kind, and work skipped because it could not change the image. Counted per
/// tile and summed, so counting costs no synchronisation.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct RayStats {
    /// Rays from the camera.
    pub camera_rays: u64,
    /// Shadow rays toward lights.
    pub shadow_rays: u64,
    /// Reflection rays (mirror and glossy).
    pub reflection_rays: u64,
    /// Transmission rays (refracted or passed through thin sheets).
    pub refraction_rays: u64,
    /// Light samples skipped without a shadow ray: the light lies on the other side of the
    /// surface from the viewer.
    pub lights_behind: u64,
    /// Light samples skipped without a shadow ray: no light arrives (outside a spot's cone).
    pub lights_unreachable: u64,
    /// Light samples skipped without a shadow ray: the surface has no response to them (no
    /// diffuse and no specular term).
    pub lights_no_response: u64,
    /// Light samples skipped without a shadow ray: their largest possible contribution to the
    /// pixel is below the pruning threshold (changes the image by less than the threshold).
    pub lights_negligible: u64,
    /// Shadow rays not traced because an area light's probe rays agreed (adaptive soft shadows).
    pub shadow_rays_saved: u64,
    /// Reflection or refraction rays not traced because the coefficient (kr or kt) is zero.
    pub zero_coefficient_rays: u64,
    /// Rays a glossy fan would have added at sharp surfaces (blur = 0): one ray does.
    pub glossy_rays_saved: u64,
    /// Secondary rays not traced because their accumulated weight fell below the pruning threshold.
    pub pruned_rays: u64,
    /// Secondary rays not traced because the maximum recursion depth was reached.
    pub depth_limited: u64,
    /// Samples whose radiance was NaN or infinite; they are dropped from the pixel average.
    pub nonfinite_samples: u64,
}

impl RayStats {
    /// All rays traced.
    pub fn total_rays(&self) -> u64 {
        self.camera_rays + self.shadow_rays + self.reflection_rays + self.refraction_rays
    }
}

impl AddAssign for RayStats {
    fn add_assign(&mut self, o: RayStats) {
        self.camera_rays += o.camera_rays;
        self.shadow_rays += o.shadow_rays;
        self.reflection_rays += o.reflection_rays;
        self.refraction_rays += o.refraction_rays;
        self.lights_behind += o.lights_behind;
        self.lights_unreachable += o.lights_unreachable;
        self.lights_no_response += o.lights_no_response;
        self.lights_negligible += o.lights_negligible;
        self.shadow_rays_saved += o.shadow_rays_saved;
        self.zero_coefficient_rays += o.zero_coefficient_rays;
        self.glossy_rays_saved += o.glossy_rays_saved;
        self.pruned_rays += o.pruned_rays;
        self.depth_limited += o.depth_limited;
        self.nonfinite_samples += o.nonfinite_samples;
    }
}

/// CPU time used so far by all threads of this process; `None` where unavailable.
pub fn process_cpu_time() -> Option<Duration> {
    #[cfg(unix)]
    return clock(libc::CLOCK_PROCESS_CPUTIME_ID);
    #[cfg(not(unix))]
    None
}

/// CPU time used so far by the calling thread; `None` where unavailable.
pub fn thread_cpu_time() -> Option<Duration> {
    #[cfg(unix)]
    return clock(libc::CLOCK_THREAD_CPUTIME_ID);
    #[cfg(not(unix))]
    None
}

#[cfg(unix)]
fn clock(id: libc::clockid_t) -> Option<Duration> {
    let mut ts = libc::timespec { tv_sec: 0, tv_nsec: 0 };
    // SAFETY: `ts` is a valid, writable timespec; clock_gettime only writes to it.
    let r = unsafe { libc::clock_gettime(id, &mut ts) };
    (r == 0).then(|| Duration::new(ts.tv_sec as u64, ts.tv_nsec as u32))
}

/// Peak resident memory of this process so far, bytes (Linux: `VmHWM`); `None` where unavailable.
pub fn peak_memory_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}
