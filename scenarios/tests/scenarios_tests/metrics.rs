//! Alignment, ATE, RPE, association and NEES on synthetic data with known answers.

use estimator::geometry::{Pose, so3_exp};
use nalgebra::{Matrix3, Matrix6, Rotation3, UnitQuaternion, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use scenarios::dataset::StampedPose;
use scenarios::metrics::{
    Alignment, Covariance, EvalOptions, MetricsError, PairsFrom, RpeOptions, Sim3, Stats,
    associate, ate, estimate_alignment, evaluate, nees, rpe, rpe_pairs,
};

fn gauss3(rng: &mut ChaCha8Rng, sigma: f64) -> Vector3<f64> {
    Vector3::from_fn(|_, _| {
        sigma * <StandardNormal as Distribution<f64>>::sample(&StandardNormal, rng)
    })
}

/// A random 3-D trajectory (not planar, not collinear) with random orientations.
fn random_trajectory(rng: &mut ChaCha8Rng, n: usize) -> Vec<Pose> {
    let mut p = Vector3::zeros();
    let mut q = UnitQuaternion::identity();
    (0..n)
        .map(|_| {
            p += gauss3(rng, 0.3);
            q *= so3_exp(&gauss3(rng, 0.2));
            Pose::new(q, p)
        })
        .collect()
}

fn random_sim3(rng: &mut ChaCha8Rng, with_scale: bool) -> Sim3 {
    Sim3 {
        rotation: Rotation3::from_scaled_axis(gauss3(rng, 1.5)),
        translation: gauss3(rng, 5.0),
        scale: if with_scale {
            0.3 + 2.0 * gauss3(rng, 1.0).x.abs()
        } else {
            1.0
        },
    }
}

fn inverse(s: &Sim3) -> Sim3 {
    let r = s.rotation.inverse();
    Sim3 {
        rotation: r,
        translation: -(r * s.translation) / s.scale,
        scale: 1.0 / s.scale,
    }
}

fn assert_sim3_eq(a: &Sim3, b: &Sim3, tol: f64) {
    let dr = (a.rotation.matrix() - b.rotation.matrix()).abs().max();
    let dt = (a.translation - b.translation).abs().max();
    let ds = (a.scale - b.scale).abs();
    assert!(
        dr < tol && dt < tol && ds < tol,
        "dR {dr:e} dt {dt:e} ds {ds:e}"
    );
}

/// est = S⁻¹ · gt, so aligning est onto gt must give back S.
fn check_recovers(alignment: Alignment, truth: Sim3, gt: &[Pose]) {
    let inv = inverse(&truth);
    let est: Vec<Pose> = gt.iter().map(|p| inv.transform_pose(p)).collect();
    let s = estimate_alignment(gt, &est, alignment).unwrap();
    assert_sim3_eq(&s, &truth, 1e-9);
    let r = ate(gt, &est, alignment).unwrap();
    assert!(r.translation.max < 1e-9, "{alignment}: {:?}", r.translation);
    assert!(
        r.rotation_deg.max < 1e-6,
        "{alignment}: {:?}",
        r.rotation_deg
    );
}

#[test]
fn se3_alignment_recovers_random_transforms_exactly() {
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    for _ in 0..20 {
        let gt = random_trajectory(&mut rng, 50);
        let truth = random_sim3(&mut rng, false);
        check_recovers(Alignment::Se3, truth, &gt);
    }
}

#[test]
fn sim3_alignment_recovers_random_transforms_exactly() {
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    for _ in 0..20 {
        let gt = random_trajectory(&mut rng, 50);
        let truth = random_sim3(&mut rng, true);
        check_recovers(Alignment::Sim3, truth, &gt);
    }
}

#[test]
fn position_yaw_alignment_recovers_random_yaw_and_translation_exactly() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    for k in 0..20 {
        let gt = random_trajectory(&mut rng, 50);
        // Yaws all around the circle, including near ±π.
        let yaw = -std::f64::consts::PI + (k as f64 + 0.5) * std::f64::consts::TAU / 20.0;
        let truth = Sim3 {
            rotation: Rotation3::from_axis_angle(&Vector3::z_axis(), yaw),
            translation: gauss3(&mut rng, 5.0),
            scale: 1.0,
        };
        check_recovers(Alignment::PosYaw, truth, &gt);
    }
}

#[test]
fn position_yaw_alignment_is_the_least_squares_yaw() {
    // With noise, perturbing the recovered yaw or translation must not reduce the cost.
    let mut rng = ChaCha8Rng::seed_from_u64(4);
    let gt = random_trajectory(&mut rng, 40);
    let est: Vec<Pose> = gt
        .iter()
        .map(|p| Pose::new(p.q, p.p + gauss3(&mut rng, 0.1)))
        .collect();
    let s = estimate_alignment(&gt, &est, Alignment::PosYaw).unwrap();
    let cost = |s: &Sim3| -> f64 {
        gt.iter()
            .zip(&est)
            .map(|(g, e)| (g.p - s.transform_point(&e.p)).norm_squared())
            .sum()
    };
    let c0 = cost(&s);
    for d in [-1e-4, 1e-4] {
        let mut t = s;
        t.rotation = Rotation3::from_axis_angle(&Vector3::z_axis(), d) * s.rotation;
        assert!(cost(&t) > c0);
        for axis in 0..3 {
            let mut t = s;
            t.translation[axis] += d;
            assert!(cost(&t) > c0);
        }
    }
}

#[test]
fn ate_and_rpe_of_identical_trajectories_are_zero() {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let gt = random_trajectory(&mut rng, 100);
    for a in [
        Alignment::None,
        Alignment::Se3,
        Alignment::Sim3,
        Alignment::PosYaw,
    ] {
        let r = ate(&gt, &gt, a).unwrap();
        assert!(r.translation.rmse < 1e-12, "{a}: {}", r.translation.rmse);
        assert!(r.rotation_deg.rmse < 1e-6, "{a}: {}", r.rotation_deg.rmse);
    }
    for o in [
        RpeOptions::meters(1.0),
        RpeOptions::frames(1),
        RpeOptions::frames(7),
    ] {
        let r = rpe(&gt, &gt, &o).unwrap();
        assert!(r.translation.max < 1e-12 && r.rotation_deg.max < 1e-6);
    }
    let stamped: Vec<StampedPose> = gt
        .iter()
        .enumerate()
        .map(|(i, p)| StampedPose::new(i as i64 * 50_000_000, *p))
        .collect();
    let ev = evaluate(&stamped, &stamped, &EvalOptions::default()).unwrap();
    assert_eq!(ev.matched.pairs.len(), 100);
    assert!(ev.ate.translation.rmse < 1e-12);
}

#[test]
fn ate_without_alignment_is_the_plain_position_error() {
    let gt = vec![Pose::identity(); 4];
    let est: Vec<Pose> = [3.0, 4.0, 0.0, 0.0]
        .iter()
        .map(|&x| Pose::new(UnitQuaternion::identity(), Vector3::new(x, 0.0, 0.0)))
        .collect();
    let r = ate(&gt, &est, Alignment::None).unwrap();
    assert!((r.translation.rmse - (25.0f64 / 4.0).sqrt()).abs() < 1e-15);
    assert_eq!(r.translation.median, 1.5);
    assert_eq!(r.translation.max, 4.0);
    assert_eq!(r.translation.mean, 7.0 / 4.0);
}

#[test]
fn stats_follow_numpy() {
    let s = Stats::from_errors(&[3.0, 1.0, 2.0]).unwrap();
    assert_eq!((s.median, s.min, s.max, s.mean), (2.0, 1.0, 3.0, 2.0));
    assert!((s.std - (2.0f64 / 3.0).sqrt()).abs() < 1e-15);
    assert!((s.rmse - (14.0f64 / 3.0).sqrt()).abs() < 1e-15);
    assert_eq!(s.sse, 14.0);
    assert!(Stats::from_errors(&[]).is_none());
}

#[test]
fn degenerate_alignments_are_errors_not_panics() {
    let line: Vec<Pose> = (0..10)
        .map(|i| Pose::new(UnitQuaternion::identity(), Vector3::new(i as f64, 0.0, 0.0)))
        .collect();
    assert!(matches!(
        estimate_alignment(&line, &line, Alignment::Se3),
        Err(MetricsError::Degenerate(_))
    ));
    let same = vec![Pose::identity(); 5];
    assert!(estimate_alignment(&same, &same, Alignment::Sim3).is_err());
    assert!(estimate_alignment(&same, &same, Alignment::PosYaw).is_err());
    assert!(matches!(
        estimate_alignment(&line[..2], &line[..2], Alignment::Se3),
        Err(MetricsError::TooFewPoses { .. })
    ));
    assert!(matches!(
        ate(&line, &line[..3], Alignment::None),
        Err(MetricsError::LengthMismatch { .. })
    ));
    // A straight line is fine for position+yaw (yaw from the horizontal direction).
    assert!(estimate_alignment(&line, &line, Alignment::PosYaw).is_ok());
}

#[test]
fn association_prefers_exact_then_nearest_and_is_one_to_one() {
    let ms = 1_000_000;
    let a = [0, 100 * ms, 200 * ms, 300 * ms, 400 * ms];
    // 100 ms exact; 203 and 198 both near 200: 198 is nearer; 305 near 300; 700 unmatched.
    let b = [100 * ms, 198 * ms, 203 * ms, 305 * ms, 700 * ms];
    let p = associate(&a, &b, 10 * ms);
    assert_eq!(p, vec![(1, 0), (2, 1), (3, 3)]);
    // One-to-one: 203 ms stays unmatched although it is within 10 ms of 200 ms.
    assert!(!p.iter().any(|&(_, j)| j == 2));
    // Zero tolerance: exact matches only.
    assert_eq!(associate(&a, &b, 0), vec![(1, 0)]);
    // Order of inputs does not matter.
    let b_rev: Vec<i64> = b.iter().rev().copied().collect();
    let p_rev: Vec<(usize, usize)> = associate(&a, &b_rev, 10 * ms);
    let back: Vec<(usize, usize)> = p_rev.iter().map(|&(i, j)| (i, b.len() - 1 - j)).collect();
    assert_eq!(back, p);
    // Ties go to the earlier index: 150 is 5 ms from both 145 and 155.
    assert_eq!(
        associate(&[150 * ms], &[145 * ms, 155 * ms], 10 * ms),
        vec![(0, 0)]
    );
    assert!(associate(&[], &b, ms).is_empty());
}

#[test]
fn evaluate_reports_no_matches() {
    let gt = vec![StampedPose::new(0, Pose::identity())];
    let est = vec![StampedPose::new(1_000_000_000, Pose::identity())];
    assert!(matches!(
        evaluate(&gt, &est, &EvalOptions::default()),
        Err(MetricsError::NoMatches { .. })
    ));
}

#[test]
fn rpe_pairs_follow_evo_definitions() {
    // Unit steps along x: path length k at pose k.
    let poses: Vec<Pose> = (0..10)
        .map(|i| Pose::new(UnitQuaternion::identity(), Vector3::new(i as f64, 0.0, 0.0)))
        .collect();
    let pairs = rpe_pairs(&poses, &RpeOptions::meters(2.5)).unwrap();
    assert_eq!(pairs, vec![(0, 3), (3, 6), (6, 9)]);
    let all = RpeOptions {
        all_pairs: true,
        tol_m: 0.1,
        ..RpeOptions::meters(2.0)
    };
    assert_eq!(rpe_pairs(&poses, &all).unwrap().len(), 8);
    assert_eq!(
        rpe_pairs(&poses, &RpeOptions::frames(4)).unwrap(),
        vec![(0, 4), (4, 8)]
    );
    let all_f = RpeOptions {
        all_pairs: true,
        ..RpeOptions::frames(4)
    };
    assert_eq!(rpe_pairs(&poses, &all_f).unwrap().len(), 6);
    assert!(rpe_pairs(&poses, &RpeOptions::frames(0)).is_err());
    assert!(rpe_pairs(&poses, &RpeOptions::meters(f64::NAN)).is_err());
    // Path shorter than the delta: no pairs, and rpe() says so.
    assert!(rpe(&poses, &poses, &RpeOptions::meters(100.0)).is_err());
}

#[test]
fn rpe_measures_relative_drift_only() {
    // A constant offset does not change the RPE; a scale error of 10 % gives 0.1 m per metre.
    let gt: Vec<Pose> = (0..21)
        .map(|i| {
            Pose::new(
                UnitQuaternion::identity(),
                Vector3::new(0.5 * i as f64, 0.0, 0.0),
            )
        })
        .collect();
    let shifted: Vec<Pose> = gt
        .iter()
        .map(|p| Pose::new(p.q, p.p + Vector3::new(1.0, 2.0, 3.0)))
        .collect();
    let r = rpe(&gt, &shifted, &RpeOptions::meters(1.0)).unwrap();
    assert!(r.translation.max < 1e-12);
    let scaled: Vec<Pose> = gt.iter().map(|p| Pose::new(p.q, p.p * 1.1)).collect();
    let r = rpe(&gt, &scaled, &RpeOptions::meters(1.0)).unwrap();
    assert_eq!(r.pairs.len(), 10);
    assert!((r.translation.rmse - 0.1).abs() < 1e-12);
    // Pairs from the estimate: the scaled path reaches 1 m after 2 steps too (1.1 m).
    let o = RpeOptions {
        pairs_from: PairsFrom::Estimate,
        ..RpeOptions::meters(1.0)
    };
    assert_eq!(rpe(&gt, &scaled, &o).unwrap().pairs.len(), 10);
}

#[test]
fn nees_of_known_errors() {
    let gt = vec![Pose::identity(); 2];
    let est = vec![
        Pose::new(UnitQuaternion::identity(), Vector3::new(0.2, 0.0, 0.0)),
        Pose::new(UnitQuaternion::identity(), Vector3::new(0.0, -0.1, 0.0)),
    ];
    let cov = [
        Covariance::Position(Matrix3::from_diagonal_element(0.04)),
        Covariance::Position(Matrix3::from_diagonal_element(0.01)),
    ];
    let r = nees(&gt, &est, &cov).unwrap();
    assert_eq!(r.dof, 3);
    assert!((r.per_pose[0] - 1.0).abs() < 1e-12 && (r.per_pose[1] - 1.0).abs() < 1e-12);
    assert!((r.mean - 1.0).abs() < 1e-12);

    // 6-DoF: a rotation error of 0.1 rad about z with σ = 0.05 rad gives 4.
    let est6 = vec![Pose::new(
        so3_exp(&Vector3::new(0.0, 0.0, 0.1)),
        Vector3::zeros(),
    )];
    let mut p6 = Matrix6::identity();
    p6[(5, 5)] = 0.0025;
    let r = nees(&gt[..1], &est6, &[Covariance::Pose(p6)]).unwrap();
    assert_eq!(r.dof, 6);
    assert!((r.mean - 4.0).abs() < 1e-9, "{}", r.mean);

    // Monte-Carlo: errors drawn from the covariance give average NEES ≈ dof.
    let mut rng = ChaCha8Rng::seed_from_u64(6);
    let l = Matrix3::new(0.1, 0.0, 0.0, 0.02, 0.05, 0.0, -0.01, 0.03, 0.2);
    let p = l * l.transpose();
    let n = 4000;
    let gt = vec![Pose::identity(); n];
    let est: Vec<Pose> = (0..n)
        .map(|_| Pose::new(UnitQuaternion::identity(), l * gauss3(&mut rng, 1.0)))
        .collect();
    let cov = vec![Covariance::Position(p); n];
    let r = nees(&gt, &est, &cov).unwrap();
    assert!((r.mean - 3.0).abs() < 0.15, "{}", r.mean);

    // Bad inputs are errors.
    let bad = [Covariance::Position(Matrix3::zeros())];
    assert!(matches!(
        nees(&gt[..1], &est[..1], &bad),
        Err(MetricsError::BadCovariance { index: 0 })
    ));
    let mixed = [Covariance::Position(p), Covariance::Pose(p6)];
    assert!(nees(&gt[..2], &est[..2], &mixed).is_err());
}

/// The definition of [`associate`], written the slow way: all candidate pairs sorted by
/// (|Δt|, i, j), accepted greedily one-to-one.
fn associate_brute_force(a: &[i64], b: &[i64], tol: i64) -> Vec<(usize, usize)> {
    let mut c: Vec<(i64, usize, usize)> = Vec::new();
    for (i, &x) in a.iter().enumerate() {
        for (j, &y) in b.iter().enumerate() {
            if (x - y).abs() <= tol {
                c.push(((x - y).abs(), i, j));
            }
        }
    }
    c.sort_unstable();
    let (mut ua, mut ub) = (vec![false; a.len()], vec![false; b.len()]);
    let mut out = Vec::new();
    for (_, i, j) in c {
        if !ua[i] && !ub[j] {
            ua[i] = true;
            ub[j] = true;
            out.push((i, j));
        }
    }
    out.sort_unstable();
    out
}

#[test]
fn association_equals_its_brute_force_definition() {
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    for case in 0..300 {
        let na = (case % 17) + 1;
        let nb = (case * 7 % 23) + 1;
        // Coarse stamps (many ties and duplicates), unsorted.
        let mut draw = |n: usize| -> Vec<i64> {
            (0..n)
                .map(|_| (gauss3(&mut rng, 10.0).x.round() as i64) * 5)
                .collect()
        };
        let a = draw(na);
        let b = draw(nb);
        for tol in [0, 4, 5, 12, 1000] {
            assert_eq!(
                associate(&a, &b, tol),
                associate_brute_force(&a, &b, tol),
                "{a:?} {b:?} {tol}"
            );
        }
    }
}

#[test]
fn association_with_a_huge_tolerance_stays_fast() {
    let a: Vec<i64> = (0..50_000).map(|k| k * 5_000_000).collect();
    let b: Vec<i64> = (0..40_000).map(|k| k * 6_250_000 + 1).collect();
    let t = std::time::Instant::now();
    let p = associate(&a, &b, i64::MAX);
    assert_eq!(p.len(), 40_000);
    assert!(t.elapsed().as_secs_f64() < 5.0, "{:?}", t.elapsed());
}
