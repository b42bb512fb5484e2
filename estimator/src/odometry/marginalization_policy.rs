//! Marginalization policy: which factors and states go into the prior when a frame leaves the
//! window (VINS-Fusion's two cases). The Schur complement itself is
//! [`crate::problem::marginalization::marginalize`], a pure function of the problem.

use std::sync::Arc;

use super::frame::{BlockRef, Prior};
use super::window::Window;
use super::window_problem::WindowProblem;
use crate::problem::marginalization::{MarginalizationOptions, marginalize};
use crate::problem::{BlockId, ResidualId};

/// The new prior when the oldest frame leaves with the IMU active: its pose and speed-bias, the
/// landmarks anchored in it, and every factor touching them (the IMU factor to the next frame,
/// its zero-velocity, GNSS and wheel factors, the old prior, those landmarks' reprojections) are marginalized. Without the IMU there is no
/// prior (vision only: the oldest remaining pose fixes the gauge). The persistent points
/// `lost` (keys; [`lost_points`]) leave too, with every observation of theirs.
pub(super) fn prior_without_oldest(
    window: &Window,
    built: &WindowProblem,
    imu_active: bool,
    lost: &[u64],
) -> Option<Prior> {
    if !imu_active {
        return None;
    }
    let oldest = window.frames[0].seq;
    let pose = built.block(BlockRef::Pose(oldest)).expect("pose");
    let mut remove = vec![pose];
    remove.extend(built.block(BlockRef::SpeedBias(oldest)));
    let mut residuals: Vec<ResidualId> = built
        .imu
        .iter()
        .filter(|(_, k)| *k == 1)
        .map(|(r, _)| *r)
        .collect();
    residuals.extend(
        built
            .frame_factors
            .iter()
            .filter(|(_, seq)| *seq == oldest)
            .map(|(r, _)| *r),
    );
    // Landmarks anchored in the oldest frame (sorted ids: membership by binary search).
    let mut anchored: Vec<u64> = Vec::new();
    for (id, lm) in &built.landmarks {
        if window.features.tracks[id].obs[0].seq == oldest {
            remove.push(*lm);
            anchored.push(*id);
        }
    }
    anchored.sort_unstable();
    residuals.extend(
        built
            .visual
            .iter()
            .filter(|(_, id)| anchored.binary_search(id).is_ok())
            .map(|(r, _)| *r),
    );
    // Persistent points: their observations in the oldest frame go into the prior.
    remove.extend(points_leaving(
        &built.points,
        &built.point_obs,
        oldest,
        held_by_prior(built),
    ));
    let lost_blocks = built
        .points
        .iter()
        .filter(|(k, _)| lost.binary_search(k).is_ok())
        .map(|(_, b)| *b);
    for b in lost_blocks {
        if !remove.contains(&b) {
            remove.push(b);
        }
    }
    residuals.extend(
        built
            .point_obs
            .iter()
            .filter(|(_, key, seq)| *seq == oldest || lost.binary_search(key).is_ok())
            .map(|(r, _, _)| *r),
    );
    if let Some(r) = built.prior
        && remove
            .iter()
            .any(|b| built.problem.residual_blocks(r).contains(b))
    {
        residuals.push(r);
    }
    residuals.sort();
    prior_from(built, &residuals, &remove)
}

/// The persistent points whose tracks the newest frame lost (keys, sorted): points the solve
/// `built` holds that the newest frame does not observe, provided there is something to
/// marginalize — an observation in the window, or a place in the prior. A track the front end
/// lost does not come back (its feature returns under a new id), so such a point only waits
/// for its last observation to leave the window; marginalized at once, with its observations,
/// it gives its place to a live track.
pub(super) fn lost_points(window: &Window, built: &WindowProblem) -> Vec<u64> {
    let Some(newest) = window.frames.back().map(|f| f.seq) else {
        return Vec::new();
    };
    points_lost(
        &built.points,
        &built.point_obs,
        newest,
        held_by_prior(built),
    )
}

/// Whether the prior of the solve `built` holds a block.
fn held_by_prior(built: &WindowProblem) -> impl Fn(&BlockId) -> bool + '_ {
    |b| {
        built
            .prior
            .is_some_and(|r| built.problem.residual_blocks(r).contains(b))
    }
}

/// Per persistent point (`points`: key and block, sorted by key), from its observations
/// (`point_obs`: residual, point key, frame seq): whether frame `seq` observes it, and whether
/// another window frame does.
fn sightings(
    points: &[(u64, BlockId)],
    point_obs: &[(ResidualId, u64, u64)],
    seq: u64,
) -> Vec<(bool, bool)> {
    debug_assert!(points.windows(2).all(|w| w[0].0 < w[1].0));
    let mut seen = vec![(false, false); points.len()];
    for (_, key, s) in point_obs {
        if let Ok(i) = points.binary_search_by_key(key, |(k, _)| *k) {
            if *s == seq {
                seen[i].0 = true;
            } else {
                seen[i].1 = true;
            }
        }
    }
    seen
}

/// [`lost_points`] over the solve's persistent points (`points`: key and block, sorted by key)
/// and their observations (`point_obs`: residual, point key, frame seq): the keys of those not
/// observed in frame `newest` that are observed in some other frame or held by the prior
/// (`held`).
fn points_lost(
    points: &[(u64, BlockId)],
    point_obs: &[(ResidualId, u64, u64)],
    newest: u64,
    held: impl Fn(&BlockId) -> bool,
) -> Vec<u64> {
    points
        .iter()
        .zip(sightings(points, point_obs, newest))
        .filter(|((_, b), (in_newest, elsewhere))| !in_newest && (*elsewhere || held(b)))
        .map(|((k, _), _)| *k)
        .collect()
}

/// The persistent points (`points`: key and block, sorted by key) that leave with the oldest
/// frame `oldest`: those observed in no later window frame (`point_obs`: residual, point key,
/// frame seq), provided there is something to marginalize — an observation in the oldest
/// frame, or a place in the prior (`held`). A point that nothing observes and the prior does
/// not hold is left out: `marginalize` rejects a block no residual touches, which would lose
/// the whole prior.
fn points_leaving(
    points: &[(u64, BlockId)],
    point_obs: &[(ResidualId, u64, u64)],
    oldest: u64,
    held: impl Fn(&BlockId) -> bool,
) -> Vec<BlockId> {
    points
        .iter()
        .zip(sightings(points, point_obs, oldest))
        .filter(|((_, b), (here, later))| !later && (*here || held(b)))
        .map(|((_, b), _)| *b)
        .collect()
}

/// The prior when the second-newest frame is dropped (not a keyframe): only the prior itself
/// loses that frame's states, if it involves them; its measurements are discarded (VINS-Fusion)
/// and its IMU interval merges into the newest frame's. `Some(current)` when nothing changes.
pub(super) fn prior_without_second_newest(window: &Window, built: &WindowProblem) -> Option<Prior> {
    let Some(r) = built.prior else {
        return window.prior.clone();
    };
    let drop = window.frames[window.frames.len() - 2].seq;
    let mut remove: Vec<BlockId> = Vec::new();
    remove.extend(built.block(BlockRef::Pose(drop)));
    remove.extend(built.block(BlockRef::SpeedBias(drop)));
    remove.retain(|b| built.problem.residual_blocks(r).contains(b));
    if remove.is_empty() {
        return window.prior.clone();
    }
    prior_alone_without(window, built, r, &remove)
}

/// The prior `r` with the blocks `remove` marginalized out of it alone. Where every block it
/// keeps holds the prior's linearization point (first-estimate Jacobians) and is variable,
/// this is [`PriorFactor::marginalized`] on its information form (nothing to relinearize);
/// otherwise the general marginalization, which re-expresses the prior at the current values.
fn prior_alone_without(
    window: &Window,
    built: &WindowProblem,
    r: ResidualId,
    remove: &[BlockId],
) -> Option<Prior> {
    let (factor, refs) = window.prior.as_ref()?;
    let blocks = built.problem.residual_blocks(r);
    let in_place = blocks.iter().all(|b| {
        remove.contains(b)
            || (!built.problem.is_constant(*b) && built.problem.linearization_point(*b).is_some())
    });
    if !in_place || blocks.len() != refs.len() {
        return prior_from(built, &[r], remove);
    }
    let removed: Vec<usize> = (0..blocks.len())
        .filter(|&k| remove.contains(&blocks[k]))
        .collect();
    let options = MarginalizationOptions::default();
    let marginal = factor
        .marginalized(&removed, options.eigen_threshold)
        .ok()?;
    let kept_refs: Vec<BlockRef> = (0..refs.len())
        .filter(|k| !removed.contains(k))
        .map(|k| refs[k])
        .collect();
    marginal
        .has_information()
        .then(|| (Arc::new(marginal), kept_refs))
}

/// The prior without the GNSS alignment (it is forgotten; see
/// `super::aiding_fusion::Aiding::forget_alignment`): the block is marginalized out of the prior alone.
/// `Some(current)` when the prior does not involve it.
pub(super) fn prior_without_alignment(window: &Window, built: &WindowProblem) -> Option<Prior> {
    let (Some(r), Some(b)) = (built.prior, built.block(BlockRef::GnssAlignment)) else {
        return window.prior.clone();
    };
    if !built.problem.residual_blocks(r).contains(&b) {
        return window.prior.clone();
    }
    prior_alone_without(window, built, r, &[b])
}

/// Marginalizes `remove` out of `residuals`; `None` when that fails or leaves no information.
fn prior_from(
    built: &WindowProblem,
    residuals: &[ResidualId],
    remove: &[BlockId],
) -> Option<Prior> {
    let mp = marginalize(
        &built.problem,
        residuals,
        remove,
        &MarginalizationOptions::default(),
    )
    .ok()?;
    let refs: Vec<BlockRef> = mp
        .blocks
        .iter()
        .map(|b| built.refs.iter().find(|(_, x)| x == b).map(|(r, _)| *r))
        .collect::<Option<Vec<_>>>()
        .unwrap_or_default();
    (refs.len() == mp.blocks.len() && mp.factor.has_information())
        .then(|| (Arc::new(mp.factor), refs))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Points 1–4 against oldest frame 7: 1 is seen only there (leaves), 2 also later
    /// (stays), 3 nowhere but in the prior (leaves: the prior holds it), 4 nowhere and not
    /// in the prior (left out: nothing to marginalize).
    #[test]
    fn points_leaving_are_those_with_something_to_marginalize() {
        let points = [
            (1, BlockId(10)),
            (2, BlockId(11)),
            (3, BlockId(12)),
            (4, BlockId(13)),
        ];
        let obs = [
            (ResidualId(0), 1, 7),
            (ResidualId(1), 2, 7),
            (ResidualId(2), 2, 8),
            (ResidualId(3), 9, 8),
        ];
        let held = |b: &BlockId| *b == BlockId(12);
        assert_eq!(
            points_leaving(&points, &obs, 7, held),
            vec![BlockId(10), BlockId(12)]
        );
        // Without a prior, point 3 has nothing to marginalize either.
        assert_eq!(
            points_leaving(&points, &obs, 7, |_| false),
            vec![BlockId(10)]
        );
    }

    /// Points 1–5 against newest frame 9: 1 is seen there (live), 2 only earlier (lost), 3
    /// nowhere but in the prior (lost: the prior holds it), 4 nowhere and not in the prior
    /// (left out: nothing to marginalize), 5 earlier and in the newest frame (live).
    #[test]
    fn lost_points_are_those_the_newest_frame_does_not_see() {
        let points = [
            (1, BlockId(10)),
            (2, BlockId(11)),
            (3, BlockId(12)),
            (4, BlockId(13)),
            (5, BlockId(14)),
        ];
        let obs = [
            (ResidualId(0), 1, 9),
            (ResidualId(1), 2, 7),
            (ResidualId(2), 2, 8),
            (ResidualId(3), 5, 8),
            (ResidualId(4), 5, 9),
            (ResidualId(5), 6, 8),
        ];
        let held = |b: &BlockId| *b == BlockId(12);
        assert_eq!(points_lost(&points, &obs, 9, held), vec![2, 3]);
        assert_eq!(points_lost(&points, &obs, 9, |_| false), vec![2]);
        // Point 1 alone: nothing is lost.
        assert!(points_lost(&points[..1], &obs, 9, held).is_empty());
    }
}
