//! The broad phase: which colliders may touch this step. Each collider is a sphere (its centre
//! and reach, grown by how far its body can move in the step); sort and sweep along the axis
//! where the centres spread most finds the overlapping boxes of those spheres in
//! `O(n log n + pairs)`, and the pairs come out in one order for any thread count.

use nalgebra::Vector3;
use rayon::prelude::*;

/// Fewest colliders for which the sweep runs on the stepping pool (below it the threads'
/// meeting costs more than the sweep).
pub const MIN_COLLIDERS_ON_POOL: usize = 1024;

/// Runs of the sorted colliders per stepping thread (a free thread takes the next run).
const RUNS_PER_THREAD: usize = 8;

/// A collider's bounding sphere for the step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bound {
    pub centre: Vector3<f64>,
    /// Reach plus the motion bound, m.
    pub radius_m: f64,
}

/// Reused buffers.
#[derive(Debug, Default, Clone)]
pub struct Sweep {
    order: Vec<(f64, u32)>,
    /// Per run of the sorted colliders swept on the pool, its pairs.
    runs: Vec<Vec<(u32, u32)>>,
}

impl Sweep {
    /// The pairs `(i, j)`, `i < j`, of `bounds` whose boxes overlap, sorted, into `pairs`
    /// (cleared first). With `pool` and at least [`MIN_COLLIDERS_ON_POOL`] colliders, runs of
    /// the sorted colliders are swept side by side: the same set of pairs, sorted the same.
    pub fn pairs(
        &mut self,
        bounds: &[Bound],
        pairs: &mut Vec<(u32, u32)>,
        pool: Option<&rayon::ThreadPool>,
    ) {
        pairs.clear();
        if bounds.len() < 2 {
            return;
        }
        let axis = spread_axis(bounds);
        self.order.clear();
        self.order.extend(
            bounds
                .iter()
                .enumerate()
                .map(|(i, b)| (b.centre[axis] - b.radius_m, i as u32)),
        );
        self.order
            .sort_unstable_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
        let order = &self.order;
        match pool {
            Some(pool) if order.len() >= MIN_COLLIDERS_ON_POOL => {
                let runs = pool.current_num_threads() * RUNS_PER_THREAD;
                let size = order.len().div_ceil(runs);
                self.runs.resize_with(runs, Vec::new);
                pool.install(|| {
                    self.runs.par_iter_mut().enumerate().for_each(|(r, out)| {
                        out.clear();
                        let end = ((r + 1) * size).min(order.len());
                        sweep_from(bounds, order, axis, (r * size).min(end)..end, out);
                    })
                });
                for run in &self.runs {
                    pairs.extend_from_slice(run);
                }
            }
            _ => sweep_from(bounds, order, axis, 0..order.len(), pairs),
        }
        pairs.sort_unstable();
    }
}

/// The overlapping pairs of the colliders at positions `from` of `order` (sorted by their
/// lower bound along `axis`) with those after them, appended to `out`.
fn sweep_from(
    bounds: &[Bound],
    order: &[(f64, u32)],
    axis: usize,
    from: std::ops::Range<usize>,
    out: &mut Vec<(u32, u32)>,
) {
    for k in from {
        let (lo, i) = order[k];
        let bi = &bounds[i as usize];
        let hi = bi.centre[axis] + bi.radius_m;
        debug_assert!(lo <= hi);
        for &(lo_j, j) in &order[k + 1..] {
            if lo_j > hi {
                break;
            }
            let bj = &bounds[j as usize];
            let reach = bi.radius_m + bj.radius_m;
            let d = bi.centre - bj.centre;
            if d.x.abs() <= reach && d.y.abs() <= reach && d.z.abs() <= reach {
                out.push((i.min(j), i.max(j)));
            }
        }
    }
}

/// The axis along which the centres' variance is largest (the first of equals).
fn spread_axis(bounds: &[Bound]) -> usize {
    let n = bounds.len() as f64;
    let mean = bounds.iter().fold(Vector3::zeros(), |a, b| a + b.centre) / n;
    let var = bounds.iter().fold(Vector3::zeros(), |a, b| {
        a + (b.centre - mean).map(|x| x * x)
    });
    let mut axis = 0;
    for k in 1..3 {
        if var[k] > var[axis] {
            axis = k;
        }
    }
    axis
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Brute force over every pair: the boxes of the spheres overlap on all three axes.
    fn brute(bounds: &[Bound]) -> Vec<(u32, u32)> {
        let mut out = Vec::new();
        for i in 0..bounds.len() {
            for j in i + 1..bounds.len() {
                let d = bounds[i].centre - bounds[j].centre;
                let r = bounds[i].radius_m + bounds[j].radius_m;
                if d.iter().all(|x| x.abs() <= r) {
                    out.push((i as u32, j as u32));
                }
            }
        }
        out
    }

    #[test]
    fn the_sweep_finds_exactly_the_pairs_brute_force_finds() {
        // A deterministic scatter of 400 spheres of mixed sizes in a 4 m cube.
        let mut s = 12345u64;
        let mut next = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        let bounds: Vec<Bound> = (0..400)
            .map(|_| Bound {
                centre: Vector3::new(4.0 * next(), 4.0 * next(), 1.0 * next()),
                radius_m: 0.02 + 0.2 * next(),
            })
            .collect();
        let mut pairs = Vec::new();
        Sweep::default().pairs(&bounds, &mut pairs, None);
        let expected = brute(&bounds);
        // 400 spheres: a few hundred overlapping pairs, so the comparison means something.
        assert!(expected.len() > 100, "{}", expected.len());
        assert_eq!(pairs, expected);
    }

    /// The smallest batches: none or one collider has no pair; two have theirs exactly when
    /// their boxes overlap, touching included.
    #[test]
    fn two_colliders_pair_when_their_boxes_overlap() {
        let b = |x: f64| Bound {
            centre: Vector3::new(x, 0.0, 0.0),
            radius_m: 0.5,
        };
        let mut sweep = Sweep::default();
        let mut pairs = vec![(7, 7)];
        sweep.pairs(&[], &mut pairs, None);
        assert!(pairs.is_empty());
        sweep.pairs(&[b(0.0)], &mut pairs, None);
        assert!(pairs.is_empty());
        sweep.pairs(&[b(0.0), b(0.9)], &mut pairs, None);
        assert_eq!(pairs, vec![(0, 1)]);
        sweep.pairs(&[b(1.1), b(0.0)], &mut pairs, None);
        assert!(pairs.is_empty());
        // Boxes that just touch (one's upper bound is the other's lower, exactly) overlap.
        sweep.pairs(&[b(1.0), b(0.0)], &mut pairs, None);
        assert_eq!(pairs, vec![(0, 1)]);
    }

    /// Past [`MIN_COLLIDERS_ON_POOL`] colliders, on a pool of 1, 2 and 3 threads (runs of the
    /// sorted colliders side by side): exactly the pairs brute force finds.
    #[test]
    fn the_sweep_on_a_pool_finds_the_same_pairs() {
        let mut s = 99u64;
        let mut next = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        let bounds: Vec<Bound> = (0..2 * MIN_COLLIDERS_ON_POOL)
            .map(|_| Bound {
                centre: Vector3::new(12.0 * next(), 12.0 * next(), 1.0 * next()),
                radius_m: 0.02 + 0.2 * next(),
            })
            .collect();
        let expected = brute(&bounds);
        // Measured 1812 pairs.
        assert!(expected.len() > 1000, "{}", expected.len());
        let mut sweep = Sweep::default();
        for threads in [1, 2, 3] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let mut pairs = Vec::new();
            sweep.pairs(&bounds, &mut pairs, Some(&pool));
            assert_eq!(pairs, expected, "{threads} threads");
        }
    }

    #[test]
    fn the_sweep_axis_is_the_widest_spread() {
        let b = |x: f64, y: f64, z: f64| Bound {
            centre: Vector3::new(x, y, z),
            radius_m: 0.1,
        };
        assert_eq!(spread_axis(&[b(0.0, 0.0, 0.0), b(0.0, 5.0, 1.0)]), 1);
        assert_eq!(spread_axis(&[b(0.0, 0.0, 0.0), b(0.5, 0.2, 1.0)]), 2);
        assert_eq!(spread_axis(&[b(3.0, 0.0, 0.0), b(0.5, 0.2, 1.0)]), 0);
    }
}
