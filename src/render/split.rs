//! Splitting a frame into tiles for many machines: horizontal bands of whole rows, balanced by the
//! work a quick estimate expects in each. Every process computes the same split (the estimate is
//! deterministic), so `--tile I/N` on N machines covers the frame exactly once.

use crate::render::job::RenderJob;
use crate::render::sample::{SampleId, image_setup, trace_sample};
use crate::render::share::Rect;
use crate::render::stats::RayStats;
use rayon::prelude::*;

/// Columns and rows between the estimate's probes.
const PROBE_STEP: u32 = 8;

/// The work each row of the frame is expected to cost: rays traced by one centre sample every
/// [`PROBE_STEP`] pixels along every [`PROBE_STEP`]-th row, spread over the rows around it.
pub fn row_costs(job: &RenderJob) -> Vec<f64> {
    let s = &job.settings;
    let probe_rows: Vec<u32> = (0..s.height).step_by(PROBE_STEP as usize).collect();
    let setup = image_setup(job);
    let costs: Vec<f64> = probe_rows
        .par_iter()
        .map(|&y| {
            let mut stats = RayStats::new(job.integrator.counters());
            let mut acc = crate::render::accum::PixelSum::default();
            for x in (PROBE_STEP / 2..s.width).step_by(PROBE_STEP as usize) {
                trace_sample(
                    job,
                    &setup,
                    SampleId::Pixel { x, y: (y + PROBE_STEP / 2).min(s.height - 1), index: 0 },
                    &mut acc,
                    None,
                    &mut stats,
                );
            }
            // At least one ray per pixel, even where every probe missed.
            stats.total_rays() as f64 * f64::from(PROBE_STEP) + f64::from(s.width)
        })
        .collect();
    (0..s.height).map(|y| costs[(y / PROBE_STEP) as usize] / f64::from(PROBE_STEP)).collect()
}

/// Tile `index` of `count` of a frame whose rows cost `costs`: a band of whole rows, the bands
/// in order from the top with about equal total cost (each at least one row).
pub fn tile_bounds(width: u32, costs: &[f64], index: u32, count: u32) -> Result<Rect, String> {
    let height = costs.len() as u32;
    if count == 0 || index >= count {
        return Err(format!("tile {index}/{count}: expected 0 ≤ I < N"));
    }
    if count > height {
        return Err(format!("{count} tiles of a frame {height} rows high: at most one tile per row"));
    }
    let total: f64 = costs.iter().sum();
    // The first row of each band: where the running cost passes k/count of the total, moved so
    // every band keeps at least one row.
    let mut starts = Vec::with_capacity(count as usize + 1);
    let mut run = 0.0;
    let mut row = 0u32;
    for k in 0..count {
        let target = total * f64::from(k) / f64::from(count);
        while row < height && run + costs[row as usize] * 0.5 <= target {
            run += costs[row as usize];
            row += 1;
        }
        starts.push(row);
    }
    starts.push(height);
    // Strictly increasing, every band inside the frame.
    for k in 0..count as usize {
        let lo = if k == 0 { 0 } else { starts[k - 1] + 1 };
        let hi = height - (count - k as u32);
        starts[k] = starts[k].clamp(lo, hi);
    }
    starts[0] = 0;
    let (y0, y1) = (starts[index as usize], starts[index as usize + 1]);
    Ok(Rect { x0: 0, y0, x1: width, y1 })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bands_cover_the_frame_once_and_balance_the_cost() {
        let costs: Vec<f64> = (0..100).map(|y| if y < 20 { 10.0 } else { 1.0 }).collect();
        for n in [1, 2, 3, 7, 16, 100] {
            let bands: Vec<Rect> = (0..n).map(|i| tile_bounds(50, &costs, i, n).unwrap()).collect();
            assert_eq!(bands[0].y0, 0);
            assert_eq!(bands[n as usize - 1].y1, 100);
            for w in bands.windows(2) {
                assert_eq!(w[0].y1, w[1].y0, "{n} tiles");
                assert!(w[0].y1 > w[0].y0);
            }
        }
        // Two tiles: the expensive top 20 rows (200) and the rest (80) are split near 140 each.
        let top = tile_bounds(50, &costs, 0, 2).unwrap();
        assert!((13..=15).contains(&top.y1), "{top:?}");
        assert!(tile_bounds(50, &costs, 2, 2).is_err() && tile_bounds(50, &costs, 0, 101).is_err());
    }
}
