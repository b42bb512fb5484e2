//! Timestamp association of two trajectories (evo's `--t_max_diff`).

use super::MetricsError;
use crate::dataset::StampedPose;

/// Associates two timestamp lists one-to-one: returns `(i, j)` index pairs with
/// `|a[i] − b[j]| ≤ max_diff_ns`, sorted by `i`.
///
/// Pairs are accepted greedily in order of increasing time difference (ties broken by `i`, then
/// `j`), each index used at most once: exact nanosecond matches come first, then nearest
/// neighbours. Deterministic. When every timestamp of the sparser list has a unique nearest
/// neighbour in the other (the usual case of regular sampling with a tolerance below half the
/// period), this equals evo's association (`--t_max_diff`), which matches each timestamp of the
/// shorter trajectory to its nearest neighbour in the longer one without enforcing uniqueness.
/// One more difference: evo compares float seconds, so for a timestamp exactly halfway between two
/// others its rounding may pick the later neighbour where we pick the earlier. Inputs need not be
/// sorted.
pub fn associate(a: &[i64], b: &[i64], max_diff_ns: i64) -> Vec<(usize, usize)> {
    let tol = max_diff_ns.max(0) as u64;
    let mut bo: Vec<usize> = (0..b.len()).collect();
    bo.sort_by_key(|&j| (b[j], j));
    let bs: Vec<i64> = bo.iter().map(|&j| b[j]).collect();
    let dist = |t: i64, k: usize| (i128::from(bs[k]) - i128::from(t)).unsigned_abs() as u64;
    let mut used_b = vec![false; b.len()];

    // Lazy greedy matching: the global order of all candidate pairs (|Δt|, i, j) is produced by
    // merging, per i, its candidates in increasing (|Δt|, j) order, so memory stays O(n + m)
    // whatever the tolerance. Per i, two boundaries walk outwards from the insertion point over
    // used entries of b: `left[i]` (one past the nearest unused entry below) and `right[i]`.
    // A candidate is only asked for again once it has been used, so skipping used entries is
    // all the advancing needed.
    let mut left: Vec<usize> = Vec::with_capacity(a.len());
    let mut right: Vec<usize> = Vec::with_capacity(a.len());
    for &t in a {
        let p = bs.partition_point(|&s| s < t);
        left.push(p);
        right.push(p);
    }
    let next = |i: usize, left: &mut [usize], right: &mut [usize], used_b: &[bool]| {
        let t = a[i];
        while left[i] > 0 && used_b[bo[left[i] - 1]] {
            left[i] -= 1;
        }
        while right[i] < bs.len() && used_b[bo[right[i]]] {
            right[i] += 1;
        }
        // Below: among equal timestamps the smallest j comes first, i.e. the lowest unused
        // index of the run of equal stamps that ends at the boundary.
        let l = (left[i] > 0)
            .then(|| {
                let end = left[i] - 1;
                let mut k = end;
                while k > 0 && bs[k - 1] == bs[end] {
                    k -= 1;
                }
                (k..=end).find(|&k| !used_b[bo[k]]).unwrap_or(end)
            })
            .map(|k| (dist(t, k), bo[k]))
            .filter(|c| c.0 <= tol);
        let r = (right[i] < bs.len())
            .then_some(right[i])
            .map(|k| (dist(t, k), bo[k]))
            .filter(|c| c.0 <= tol);
        let (d, j) = match (l, r) {
            (Some(x), Some(y)) => Some(x.min(y)),
            (x, y) => x.or(y),
        }?;
        Some(std::cmp::Reverse((d, i, j)))
    };
    let mut heap = std::collections::BinaryHeap::new();
    for i in 0..a.len() {
        if let Some(c) = next(i, &mut left, &mut right, &used_b) {
            heap.push(c);
        }
    }
    let mut pairs = Vec::new();
    while let Some(std::cmp::Reverse((_, i, j))) = heap.pop() {
        if used_b[j] {
            if let Some(c) = next(i, &mut left, &mut right, &used_b) {
                heap.push(c);
            }
        } else {
            used_b[j] = true;
            pairs.push((i, j));
        }
    }
    pairs.sort_unstable();
    pairs
}

/// Associates two trajectories (see [`associate`]) and returns the matched pose lists
/// `(ground truth, estimate)` in ground-truth order, plus the index pairs.
pub fn associate_trajectories(
    gt: &[StampedPose],
    est: &[StampedPose],
    max_diff_ns: i64,
) -> Result<Matched, MetricsError> {
    let ta: Vec<i64> = gt.iter().map(|s| s.t_ns).collect();
    let tb: Vec<i64> = est.iter().map(|s| s.t_ns).collect();
    let pairs = associate(&ta, &tb, max_diff_ns);
    if pairs.is_empty() {
        return Err(MetricsError::NoMatches {
            gt: gt.len(),
            est: est.len(),
            max_diff_ns,
        });
    }
    Ok(Matched {
        gt: pairs.iter().map(|&(i, _)| gt[i]).collect(),
        est: pairs.iter().map(|&(_, j)| est[j]).collect(),
        pairs,
    })
}

/// Two associated trajectories of equal length.
#[derive(Clone, Debug, PartialEq)]
pub struct Matched {
    /// Matched ground-truth poses.
    pub gt: Vec<StampedPose>,
    /// Matched estimated poses (same length and order as `gt`).
    pub est: Vec<StampedPose>,
    /// `(ground-truth index, estimate index)` into the original lists.
    pub pairs: Vec<(usize, usize)>,
}
