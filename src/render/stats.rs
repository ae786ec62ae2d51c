//! Counters of the work a render did, and of the work it avoided.

use serde::Serialize;
use std::ops::AddAssign;
use std::time::Duration;

/// Most counters one integrator may declare.
pub const MAX_COUNTERS: usize = 24;

/// What a counter counts: its kind decides where `--stats` prints it and whether it adds to the
/// rays traced (rays per second).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum CounterKind {
    /// Rays traced (shadow, reflection, refraction, bounce, …): part of [`RayStats::total_rays`].
    Rays,
    /// Work skipped because it could not change the image (or changes it below a threshold).
    Avoided,
    /// Anything else the integrator wants to report.
    Other,
}

/// A counter an integrator declares ([`crate::Integrator::counters`]): its index in the table is
/// the index it counts with ([`RayStats::add`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct Counter {
    /// Short name, as printed (`shadow_rays`).
    pub name: &'static str,
    /// What it counts, in a few words.
    pub doc: &'static str,
    /// Its kind.
    pub kind: CounterKind,
}

impl Counter {
    /// A counter row.
    pub const fn new(name: &'static str, kind: CounterKind, doc: &'static str) -> Self {
        Counter { name, doc, kind }
    }
}

/// The work of a render: camera rays and non-finite samples (counted by the render loop) and the
/// counters the integrator declared (counted by it). Kept per tile and summed, so counting costs
/// no synchronisation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RayStats {
    /// The integrator's counter table.
    pub table: &'static [Counter],
    /// Rays from the camera.
    pub camera_rays: u64,
    /// Samples whose radiance was NaN or infinite; they are dropped from the pixel average.
    pub nonfinite_samples: u64,
    counts: [u64; MAX_COUNTERS],
    /// Bit `i` set when counter `i` counts rays (kind [`CounterKind::Rays`]).
    rays_mask: u32,
    /// Rays counted by those counters so far: [`RayStats::rays`] without walking the table.
    traced: u64,
    /// The rays this work may trace ([`RayStats::exhausted`]); `u64::MAX` by default.
    allowance: u64,
}

impl Default for RayStats {
    fn default() -> Self {
        RayStats::new(&[])
    }
}

impl RayStats {
    /// Zero counts for an integrator with counters `table` (at most [`MAX_COUNTERS`]; more are
    /// not counted).
    pub fn new(table: &'static [Counter]) -> Self {
        let rays_mask =
            table.iter().take(MAX_COUNTERS).enumerate().filter(|(_, c)| c.kind == CounterKind::Rays).fold(0, |m, (i, _)| m | 1 << i);
        RayStats { table, camera_rays: 0, nonfinite_samples: 0, counts: [0; MAX_COUNTERS], rays_mask, traced: 0, allowance: u64::MAX }
    }

    /// Adds `n` to counter `i` of the table.
    #[inline]
    pub fn add(&mut self, i: usize, n: u64) {
        if let Some(c) = self.counts.get_mut(i) {
            *c += n;
            self.traced += n * u64::from(self.rays_mask >> i & 1);
        }
    }

    /// All rays traced so far (the same as [`RayStats::total_rays`], kept as they are counted).
    #[inline]
    pub fn rays(&self) -> u64 {
        self.camera_rays + self.traced
    }

    /// Lets this work trace at most `rays` rays in all (counted from zero): past them,
    /// [`RayStats::exhausted`] is true. The render loop gives each tile what is left of the work
    /// budget ([`crate::render::budget`]).
    pub fn set_allowance(&mut self, rays: u64) {
        self.allowance = rays;
    }

    /// True once more rays were traced than allowed ([`RayStats::set_allowance`]). An integrator
    /// whose rays branch checks it at each hit and stops recursing: the render then discards
    /// the work and stops (the sample would be wrong), so one camera ray cannot run away.
    #[inline]
    pub fn exhausted(&self) -> bool {
        self.rays() > self.allowance
    }

    /// Whether `n` more rays can be traced without passing the allowance
    /// ([`RayStats::set_allowance`]): then no check of [`RayStats::exhausted`] on the way can
    /// turn true, whatever the order the rays are counted in.
    #[inline]
    pub fn has_room(&self, n: u64) -> bool {
        self.rays().saturating_add(n) <= self.allowance
    }

    /// Counter `i` of the table.
    pub fn count(&self, i: usize) -> u64 {
        self.counts.get(i).copied().unwrap_or(0)
    }

    /// The counter called `name` (0 when the table has none).
    pub fn get(&self, name: &str) -> u64 {
        self.table.iter().position(|c| c.name == name).map_or(0, |i| self.count(i))
    }

    /// Each counter of the table with its count.
    pub fn counters(&self) -> impl Iterator<Item = (&'static Counter, u64)> + '_ {
        self.table.iter().take(MAX_COUNTERS).enumerate().map(|(i, c)| (c, self.counts[i]))
    }

    /// All rays traced: camera rays and every counter of kind [`CounterKind::Rays`].
    pub fn total_rays(&self) -> u64 {
        self.camera_rays + self.counters().filter(|(c, _)| c.kind == CounterKind::Rays).map(|(_, n)| n).sum::<u64>()
    }
}

impl AddAssign for RayStats {
    fn add_assign(&mut self, o: RayStats) {
        if self.table.is_empty() {
            self.table = o.table;
        }
        if self.rays_mask == 0 {
            self.rays_mask = o.rays_mask;
        }
        self.camera_rays += o.camera_rays;
        self.nonfinite_samples += o.nonfinite_samples;
        self.traced += o.traced;
        for (a, b) in self.counts.iter_mut().zip(o.counts) {
            *a += b;
        }
    }
}

impl Serialize for RayStats {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        let mut m = s.serialize_map(None)?;
        m.serialize_entry("camera_rays", &self.camera_rays)?;
        for (c, n) in self.counters() {
            m.serialize_entry(c.name, &n)?;
        }
        m.serialize_entry("nonfinite_samples", &self.nonfinite_samples)?;
        m.serialize_entry("total_rays", &self.total_rays())?;
        m.end()
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
