//! Property tests of the camera models: round trips over the whole image and field of view,
//! border and corner pixels, analytic projection Jacobians against the shared central-difference
//! checker, constructor validation and rejection of points outside the model's domain.

use std::f64::consts::PI;

use estimator::camera::{
    Camera, CameraError, CameraModel, DoubleSphere, KannalaBrandt, Mei, PinholeRadtan,
};
use estimator::problem::{CheckOptions, Euclidean, Factor, check_factor_jacobians};
use nalgebra::{Vector2, Vector3};
use proptest::prelude::*;
use proptest::test_runner::RngSeed;

/// Round-trip tolerance in pixels.
const PX_TOL: f64 = 1e-6;
/// Bearing round-trip tolerance in radians.
const BEARING_TOL: f64 = 1e-9;
/// Relative tolerance of the Jacobian check (`CheckOptions::rel_tol`).
const JAC_REL_TOL: f64 = 1e-6;
/// Central-difference step relative to the point's length scale.
const JAC_REL_STEP: f64 = 1e-6;

fn config(seed: u64) -> ProptestConfig {
    ProptestConfig {
        cases: 256,
        rng_seed: RngSeed::Fixed(seed),
        ..ProptestConfig::default()
    }
}

/// EuRoC MAV cam0 (radtan).
fn euroc() -> PinholeRadtan {
    PinholeRadtan::euroc_cam0()
}

/// TUM-VI-like equidistant fisheye (512×512, ~195° diagonal field of view).
fn tumvi_kb() -> KannalaBrandt {
    KannalaBrandt::new(
        512, 512, 190.0, 190.0, 254.93, 256.9, 0.0034, 0.0007, -0.0020, 0.0002,
    )
    .unwrap()
}

/// Mei unified model with ξ = 1 (parabolic) and mild radtan distortion.
fn mei() -> Mei {
    Mei::new(
        512, 512, 1.0, 380.0, 381.0, 255.5, 254.5, -0.03, 0.005, 1e-4, -2e-4,
    )
    .unwrap()
}

/// Double sphere with Usenko et al.'s BF2M2020S23 ξ and α, scaled to 512×512.
fn ds() -> DoubleSphere {
    DoubleSphere::new(512, 512, 156.0, 156.0, 255.5, 255.5, -0.17, 0.59).unwrap()
}

/// Radtan whose radial map has a maximum at r² = 1/1.2 inside the image (corners invalid).
fn strong_radtan() -> PinholeRadtan {
    PinholeRadtan::new(
        752, 480, 458.654, 457.296, 367.215, 248.375, -0.4, 0.0, 1e-4, -1e-4,
    )
    .unwrap()
}

/// Kannala-Brandt whose d(θ) peaks at θ = 1/√0.9 ≈ 60.4° (points behind the camera invalid).
fn strong_kb() -> KannalaBrandt {
    KannalaBrandt::new(512, 512, 190.0, 190.0, 255.5, 255.5, -0.3, 0.0, 0.0, 0.0).unwrap()
}

/// Mei with ξ = 2 (hyperbolic): the domain ends at the fold Xs.z = −1/ξ, inside the image.
fn mei_xi2() -> Mei {
    Mei::new(
        512, 512, 2.0, 500.0, 500.0, 255.5, 255.5, -0.02, 0.003, -1e-4, 1e-4,
    )
    .unwrap()
}

/// Where a model's valid domain ends, as an incidence angle.
#[derive(Clone, Copy)]
enum Edge {
    /// Unbounded (radtan with monotonic distortion), or not tested at its edge: Mei with
    /// ξ ≤ 1 diverges at Xs.z → −ξ, where `Z + ξ‖P‖` cancels so that even a perfect projection
    /// of a Cartesian point carries a relative error ε/(1 + Xs.z/ξ); central differences cannot
    /// resolve it (the fold-type edge of Mei is tested with ξ = 2).
    None,
    /// A smooth boundary (a fold of the projection): the projection stays finite.
    Fold(f64),
    /// The projection is finite but the direction `X/r` is singular there (KB at θ = π):
    /// the length scale of the projection shrinks with the distance to the edge.
    Singular(f64),
}

impl Edge {
    fn theta(self) -> Option<f64> {
        match self {
            Edge::None => None,
            Edge::Fold(t) | Edge::Singular(t) => Some(t),
        }
    }
}

/// A model under test with the angular extent of its field of view.
struct Model {
    name: &'static str,
    cam: Camera,
    /// Largest incidence angle sampled as "inside the field of view": the widest image corner,
    /// or slightly inside the domain edge where corners are not valid.
    fov: f64,
    /// Where the model's domain ends.
    edge: Edge,
}

/// Incidence angle of a unit bearing.
fn incidence(b: &Vector3<f64>) -> f64 {
    b.xy().norm().atan2(b.z)
}

fn corners(cam: &dyn CameraModel) -> [Vector2<f64>; 4] {
    let (w, h) = (f64::from(cam.width()) - 0.5, f64::from(cam.height()) - 0.5);
    [
        Vector2::new(-0.5, -0.5),
        Vector2::new(w, -0.5),
        Vector2::new(-0.5, h),
        Vector2::new(w, h),
    ]
}

fn model(name: &'static str, cam: Camera, edge: Edge) -> Model {
    let corner_fov = corners(cam.model())
        .iter()
        .filter_map(|c| cam.unproject(c))
        .map(|b| incidence(&b))
        .fold(0.0, f64::max);
    let fov = match edge.theta() {
        Some(e) if corner_fov == 0.0 || corner_fov > e - 1e-3 => e - 1e-3,
        _ => corner_fov,
    };
    assert!(fov > 0.3, "{name}: field of view {fov}");
    Model {
        name,
        cam,
        fov,
        edge,
    }
}

/// The four reference models (every corner pixel valid).
fn reference_models() -> Vec<Model> {
    let d = ds();
    vec![
        model("euroc-radtan", euroc().into(), Edge::None),
        model(
            "tumvi-kb",
            tumvi_kb().into(),
            Edge::Singular(tumvi_kb().max_theta()),
        ),
        model("mei-xi1", mei().into(), Edge::None),
        model(
            "double-sphere",
            d.clone().into(),
            Edge::Fold((-d.w2()).acos()),
        ),
    ]
}

/// Reference models plus three whose valid domain ends inside the image.
fn all_models() -> Vec<Model> {
    let mut v = reference_models();
    let r = strong_radtan();
    v.push(model(
        "strong-radtan",
        r.clone().into(),
        Edge::Fold(r.max_r2().sqrt().atan()),
    ));
    let k = strong_kb();
    v.push(model(
        "strong-kb",
        k.clone().into(),
        Edge::Fold(k.max_theta()),
    ));
    v.push(model(
        "mei-xi2",
        mei_xi2().into(),
        Edge::Fold((-0.5f64).acos()),
    ));
    v
}

fn direction(theta: f64, phi: f64) -> Vector3<f64> {
    Vector3::new(
        theta.sin() * phi.cos(),
        theta.sin() * phi.sin(),
        theta.cos(),
    )
}

/// Angle between two vectors, accurate for tiny angles.
fn angle(a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    a.cross(b).norm().atan2(a.dot(b))
}

/// Checks `project(unproject(uv)) = uv` and consistency of `is_valid` with `unproject`.
fn check_pixel(m: &Model, uv: &Vector2<f64>) -> Result<bool, String> {
    let cam = &m.cam;
    let b = cam.unproject(uv);
    if cam.is_valid(uv) != b.is_some() {
        return Err(format!(
            "{}: is_valid({uv:?}) disagrees with unproject = {b:?}",
            m.name
        ));
    }
    let Some(b) = b else { return Ok(false) };
    if (b.norm() - 1.0).abs() > 1e-12 {
        return Err(format!("{}: bearing {b:?} of {uv:?} is not unit", m.name));
    }
    for depth in [1.0, 0.1, 25.0] {
        let back = cam
            .project(&(b * depth))
            .ok_or_else(|| format!("{}: bearing of valid pixel {uv:?} not projectable", m.name))?;
        let err = (back - uv).norm();
        if err > PX_TOL {
            return Err(format!(
                "{}: pixel {uv:?} → {b:?} → {back:?} (error {err:.3e} px)",
                m.name
            ));
        }
    }
    Ok(true)
}

/// Test-only factor: residual = projection of the single Euclidean(3) block.
struct ProjectionFactor<'a> {
    cam: &'a dyn CameraModel,
}

impl Factor for ProjectionFactor<'_> {
    fn residual_dim(&self) -> usize {
        2
    }
    fn parameter_block_sizes(&self) -> &[usize] {
        &[3]
    }
    fn parameter_tangent_sizes(&self) -> &[usize] {
        &[3]
    }
    fn evaluate(
        &self,
        params: &[&[f64]],
        residuals: &mut [f64],
        jacobians: Option<&mut [Option<&mut [f64]>]>,
    ) -> bool {
        let p = Vector3::new(params[0][0], params[0][1], params[0][2]);
        let jac_out = jacobians.and_then(|j| j[0].as_deref_mut());
        let uv = match jac_out {
            Some(out) => {
                let Some((uv, j)) = self.cam.project_with_jacobian(&p) else {
                    return false;
                };
                estimator::problem::write_row_major(&j, out);
                uv
            }
            None => match self.cam.project(&p) {
                Some(uv) => uv,
                None => return false,
            },
        };
        residuals[0] = uv.x;
        residuals[1] = uv.y;
        true
    }
}

/// Runs the shared Jacobian checker at `p` with step `JAC_REL_STEP · scale` (`scale`: the
/// length over which the projection varies, `‖p‖` away from singularities), and checks that
/// `project_with_jacobian` returns exactly `project`'s pixel.
fn check_jacobian(m: &Model, p: &Vector3<f64>, scale: f64) -> Result<f64, String> {
    let cam = m.cam.model();
    let uv = cam
        .project(p)
        .ok_or_else(|| format!("{}: {p:?} not projectable", m.name))?;
    let (uv_j, _) = cam
        .project_with_jacobian(p)
        .ok_or_else(|| format!("{}: {p:?} project_with_jacobian failed", m.name))?;
    if uv.x.to_bits() != uv_j.x.to_bits() || uv.y.to_bits() != uv_j.y.to_bits() {
        return Err(format!(
            "{}: project {uv:?} ≠ with-Jacobian {uv_j:?}",
            m.name
        ));
    }
    let factor = ProjectionFactor { cam };
    let options = CheckOptions {
        step: JAC_REL_STEP * scale,
        rel_tol: JAC_REL_TOL,
    };
    check_factor_jacobians(
        &factor,
        &[p.as_slice().to_vec()],
        &[&Euclidean::new(3)],
        options,
    )
    .map_err(|e| format!("{}: Jacobian at {p:?}: {e}", m.name))
}

proptest! {
    #![proptest_config(config(0xCA3E_0001))]

    /// Uniform pixels anywhere in the image: valid ones round-trip to 1e-6 px, and
    /// `is_valid` agrees with `unproject`.
    #[test]
    fn project_unproject_round_trip_over_image(fu in 0.0..=1.0f64, fv in 0.0..=1.0f64) {
        for m in all_models() {
            let uv = Vector2::new(
                -0.5 + fu * f64::from(m.cam.width()),
                -0.5 + fv * f64::from(m.cam.height()),
            );
            check_pixel(&m, &uv).map_err(TestCaseError::fail)?;
        }
    }
}

proptest! {
    #![proptest_config(config(0xCA3E_0002))]

    /// Random 3-D points inside the field of view: `unproject(project(P))` is P's bearing to
    /// 1e-9 rad.
    #[test]
    fn unproject_project_round_trip_over_fov(
        t in 0.0..=1.0f64,
        phi in 0.0..(2.0 * PI),
        depth in 0.05..100.0f64,
    ) {
        for m in all_models() {
            let b = direction(t * m.fov, phi);
            let p = b * depth;
            let uv = m.cam.project(&p).ok_or_else(|| {
                TestCaseError::fail(format!("{}: {p:?} in the FOV not projectable", m.name))
            })?;
            let back = m.cam.unproject(&uv).ok_or_else(|| {
                TestCaseError::fail(format!("{}: {uv:?} (from {p:?}) not unprojectable", m.name))
            })?;
            let err = angle(&back, &b);
            prop_assert!(err < BEARING_TOL, "{}: {p:?} → {uv:?} → {back:?}: {err:.3e} rad", m.name);
        }
    }

    /// Analytic `∂uv/∂P` against central differences (shared checker) for points in the FOV.
    #[test]
    fn project_jacobian_matches_central_differences(
        t in 0.0..=1.0f64,
        phi in 0.0..(2.0 * PI),
        depth in 0.05..100.0f64,
    ) {
        for m in all_models() {
            let p = direction(t * m.fov, phi) * depth;
            check_jacobian(&m, &p, depth).map_err(TestCaseError::fail)?;
        }
    }

    /// Jacobians and bearing round trips near the edge of each model's valid domain
    /// (0.5 mrad to 50 mrad inside it). At a singular edge the central-difference step shrinks
    /// with the distance to the edge.
    #[test]
    fn jacobian_and_round_trip_near_fov_edge(
        margin in 5e-4..5e-2f64,
        phi in 0.0..(2.0 * PI),
        depth in 0.05..100.0f64,
    ) {
        for m in all_models() {
            let (edge, scale) = match m.edge {
                Edge::None => continue,
                Edge::Fold(t) => (t, depth),
                Edge::Singular(t) => (t, depth * margin),
            };
            let theta = edge - margin;
            let b = direction(theta, phi);
            let p = b * depth;
            check_jacobian(&m, &p, scale).map_err(TestCaseError::fail)?;
            let uv = m.cam.project(&p).unwrap();
            let back = m.cam.unproject(&uv).ok_or_else(|| {
                TestCaseError::fail(format!("{}: edge pixel {uv:?} not unprojectable", m.name))
            })?;
            let err = angle(&back, &b);
            prop_assert!(err < BEARING_TOL, "{}: θ = {theta}: {err:.3e} rad", m.name);
        }
    }
}

/// Jacobians on and next to the optical axis (r = 0, 1e-13, 1e-9 relative to z), where KB's
/// `d(θ)/r` must take its limit and the other models have removable singular-looking terms.
#[test]
fn jacobians_on_optical_axis() {
    for m in all_models() {
        for z in [0.05, 1.0, 40.0] {
            for (x, y) in [
                (0.0, 0.0),
                (1e-13, -2e-13),
                (1e-9, 0.0),
                (-7e-10, 3e-10),
                (0.0, 1e-9),
            ] {
                let p = Vector3::new(x * z, y * z, z);
                let worst = check_jacobian(&m, &p, z).unwrap_or_else(|e| panic!("{e}"));
                assert!(worst < JAC_REL_TOL);
                // On the axis every model images the principal point with Jacobian ≈ f/z.
                let (uv, j) = m.cam.project_with_jacobian(&p).unwrap();
                let pp = m.cam.project(&Vector3::new(0.0, 0.0, 1.0)).unwrap();
                assert!((uv - pp).norm() < 1e-5, "{}: {uv:?} vs {pp:?}", m.name);
                assert!(
                    j[(0, 0)] * z > 100.0 && j[(1, 1)] * z > 100.0,
                    "{}: {j}",
                    m.name
                );
            }
        }
    }
}

/// Every pixel of a 4-px grid plus the whole border of each reference model is valid and
/// round-trips; the strong-distortion models are valid at the centre but not at the corners.
#[test]
fn whole_image_and_borders_are_valid() {
    for m in reference_models() {
        let (w, h) = (m.cam.width(), m.cam.height());
        let (wf, hf) = (f64::from(w) - 0.5, f64::from(h) - 0.5);
        let mut pixels = Vec::new();
        for v in (0..h).step_by(4) {
            for u in (0..w).step_by(4) {
                pixels.push(Vector2::new(f64::from(u), f64::from(v)));
            }
        }
        for u in 0..w {
            for v in [-0.5, 0.0, hf - 0.5, hf] {
                pixels.push(Vector2::new(f64::from(u), v));
            }
        }
        for v in 0..h {
            for u in [-0.5, 0.0, wf - 0.5, wf] {
                pixels.push(Vector2::new(u, f64::from(v)));
            }
        }
        pixels.extend(corners(m.cam.model()));
        for uv in &pixels {
            assert!(m.cam.is_valid(uv), "{}: pixel {uv:?} not valid", m.name);
            assert!(check_pixel(&m, uv).unwrap_or_else(|e| panic!("{e}")));
        }
        // Just outside the image area.
        for uv in [
            Vector2::new(-0.51, 10.0),
            Vector2::new(wf + 0.01, 10.0),
            Vector2::new(10.0, -0.51),
            Vector2::new(10.0, hf + 0.01),
        ] {
            assert!(!m.cam.is_valid(&uv), "{}: {uv:?} outside the image", m.name);
        }
    }
    for cam in [
        Camera::from(strong_radtan()),
        Camera::from(strong_kb()),
        Camera::from(mei_xi2()),
    ] {
        let c = Vector2::new(f64::from(cam.width()) / 2.0, f64::from(cam.height()) / 2.0);
        assert!(cam.is_valid(&c));
        for uv in corners(cam.model()) {
            assert!(
                !cam.is_valid(&uv) && cam.unproject(&uv).is_none(),
                "{cam:?} {uv:?}"
            );
        }
    }
}

/// The four EuRoC cam0 corners (pixel-area corners and corner pixel centres) unproject,
/// reproject to 1e-9 px (undistortion converges to machine precision, not a fixed count), and
/// lie at the expected wide angles.
#[test]
fn euroc_corners_round_trip() {
    let cam = euroc();
    for uv in [
        Vector2::new(-0.5, -0.5),
        Vector2::new(751.5, -0.5),
        Vector2::new(-0.5, 479.5),
        Vector2::new(751.5, 479.5),
        Vector2::new(0.0, 0.0),
        Vector2::new(751.0, 0.0),
        Vector2::new(0.0, 479.0),
        Vector2::new(751.0, 479.0),
    ] {
        assert!(cam.is_valid(&uv), "{uv:?}");
        let b = cam.unproject(&uv).unwrap();
        let back = cam.project(&b).unwrap();
        assert!((back - uv).norm() < 1e-9, "{uv:?} → {back:?}");
        // Barrel distortion: the corner rays are wider than the undistorted pinhole's.
        let pinhole = Vector3::new((uv.x - cam.cx) / cam.fx, (uv.y - cam.cy) / cam.fy, 1.0);
        assert!(incidence(&b) > incidence(&pinhole) + 0.05, "{uv:?}");
    }
    // The top-left corner ray is about 53° off axis (undistorted radius ≈ 1.32).
    let b = cam.unproject(&Vector2::new(-0.5, -0.5)).unwrap();
    assert!((incidence(&b).to_degrees() - 53.0).abs() < 1.5, "{b:?}");
}

#[test]
fn constructors_reject_bad_input() {
    use CameraError::*;
    let field = |e: CameraError| match e {
        NonFinite { field, .. } | OutOfRange { field, .. } | ZeroSize { field } => field,
    };
    let p = |w, h, fx, fy, cx, k1| PinholeRadtan::new(w, h, fx, fy, cx, 240.0, k1, 0.0, 0.0, 0.0);
    assert!(matches!(
        p(752, 480, f64::NAN, 1.0, 1.0, 0.0),
        Err(NonFinite { field: "fx", .. })
    ));
    assert!(matches!(
        p(752, 480, 0.0, 1.0, 1.0, 0.0),
        Err(OutOfRange { field: "fx", .. })
    ));
    assert!(matches!(
        p(752, 480, -3.0, 1.0, 1.0, 0.0),
        Err(OutOfRange { field: "fx", .. })
    ));
    assert!(matches!(
        p(752, 480, 1.0, 0.0, 1.0, 0.0),
        Err(OutOfRange { field: "fy", .. })
    ));
    assert_eq!(
        field(p(752, 480, 1.0, 1.0, f64::INFINITY, 0.0).unwrap_err()),
        "cx"
    );
    assert_eq!(
        field(p(752, 480, 1.0, 1.0, 1.0, f64::NAN).unwrap_err()),
        "k1"
    );
    assert_eq!(
        p(0, 480, 1.0, 1.0, 1.0, 0.0),
        Err(ZeroSize { field: "width" })
    );
    assert_eq!(
        p(752, 0, 1.0, 1.0, 1.0, 0.0),
        Err(ZeroSize { field: "height" })
    );
    assert!(p(752, 480, 1.0, 1.0, 1.0, 0.0).is_ok());

    let kb = |fy, k4| KannalaBrandt::new(512, 512, 190.0, fy, 256.0, 256.0, 0.0, 0.0, 0.0, k4);
    assert_eq!(field(kb(f64::NAN, 0.0).unwrap_err()), "fy");
    assert_eq!(field(kb(190.0, f64::NEG_INFINITY).unwrap_err()), "k4");
    assert!(kb(190.0, 0.0).is_ok());

    let mei = |xi, p2| Mei::new(512, 512, xi, 380.0, 380.0, 256.0, 256.0, 0.0, 0.0, 0.0, p2);
    assert!(matches!(
        mei(-0.1, 0.0),
        Err(OutOfRange { field: "xi", .. })
    ));
    assert!(matches!(
        mei(f64::NAN, 0.0),
        Err(NonFinite { field: "xi", .. })
    ));
    assert_eq!(field(mei(1.0, f64::NAN).unwrap_err()), "p2");
    assert!(mei(0.0, 0.0).is_ok() && mei(2.5, 0.0).is_ok());

    let ds = |xi, alpha| DoubleSphere::new(512, 512, 156.0, 156.0, 256.0, 256.0, xi, alpha);
    for alpha in [-0.01, 1.01, 2.0] {
        assert!(
            matches!(ds(0.0, alpha), Err(OutOfRange { field: "alpha", .. })),
            "{alpha}"
        );
    }
    assert!(matches!(
        ds(0.0, f64::NAN),
        Err(NonFinite { field: "alpha", .. })
    ));
    for xi in [-1.0, 1.0, 1.5] {
        assert!(
            matches!(ds(xi, 0.5), Err(OutOfRange { field: "xi", .. })),
            "{xi}"
        );
    }
    assert!(ds(-0.17, 0.0).is_ok() && ds(0.5, 1.0).is_ok());
    assert!(DoubleSphere::new(512, 512, 156.0, -1.0, 256.0, 256.0, 0.0, 0.5).is_err());
    // The error message names the field.
    assert!(ds(0.0, 1.5).unwrap_err().to_string().contains("alpha"));
}

#[test]
fn points_outside_the_domain_are_rejected() {
    let nan = Vector3::new(f64::NAN, 0.0, 1.0);
    let origin = Vector3::zeros();

    // Pinhole-radtan: behind, in the image plane, or too close to it.
    let cam = euroc();
    for p in [
        Vector3::new(0.0, 0.0, -1.0),
        Vector3::new(0.1, 0.2, -3.0),
        Vector3::new(1.0, 0.0, 0.0),
        Vector3::new(1.0, 2.0, 1e-7),
        nan,
        origin,
    ] {
        assert!(
            cam.project(&p).is_none() && cam.project_with_jacobian(&p).is_none(),
            "{p:?}"
        );
    }
    // Beyond the monotonic radius of the strong radtan model.
    let strong = strong_radtan();
    let r = strong.max_r2().sqrt();
    assert!(strong.project(&Vector3::new(r * 0.999, 0.0, 1.0)).is_some());
    assert!(strong.project(&Vector3::new(r * 1.001, 0.0, 1.0)).is_none());
    assert!(strong.project(&Vector3::new(0.3, 0.2, -1.0)).is_none());

    // KB: straight behind is never valid; the strong model rejects everything past θ_max ≈ 60°,
    // so every point behind the camera.
    let kb = tumvi_kb();
    assert_eq!(kb.max_theta(), PI);
    for p in [Vector3::new(0.0, 0.0, -1.0), origin, nan] {
        assert!(kb.project(&p).is_none(), "{p:?}");
    }
    let kb = strong_kb();
    let tmax = kb.max_theta();
    assert!((tmax - (1.0f64 / 0.9).sqrt()).abs() < 1e-12, "{tmax}");
    assert!(kb.project(&direction(tmax - 1e-3, 0.3)).is_some());
    for p in [
        direction(tmax + 1e-3, 0.3),
        direction(PI / 2.0, 1.0),
        Vector3::new(0.1, -0.2, -1.0),
        Vector3::new(0.0, 0.0, -1.0),
    ] {
        assert!(
            kb.project(&p).is_none() && kb.project_with_jacobian(&p).is_none(),
            "{p:?}"
        );
    }
    // Pixels beyond d(θ_max) do not unproject.
    let rd_max = kb.project(&direction(tmax - 1e-9, 0.0)).unwrap().x - kb.cx;
    assert!(
        kb.unproject(&Vector2::new(kb.cx + rd_max * 1.001, kb.cy))
            .is_none()
    );

    // Mei: ξ = 0.5 sees down to Xs.z > −0.5; ξ = 2 (hyperbolic beyond parabolic) to −1/ξ.
    for (xi, limit) in [(0.5, -0.5f64), (2.0, -0.5), (1.0, -1.0)] {
        let m = Mei::new(512, 512, xi, 300.0, 300.0, 256.0, 256.0, 0.0, 0.0, 0.0, 0.0).unwrap();
        let th = limit.acos();
        assert!(m.project(&direction(th - 1e-3, 0.2)).is_some(), "ξ = {xi}");
        if xi != 1.0 {
            assert!(m.project(&direction(th + 1e-3, 0.2)).is_none(), "ξ = {xi}");
        }
        assert!(m.project(&origin).is_none() && m.project(&nan).is_none());
    }

    // Double sphere: z > −w2·d1.
    let d = ds();
    let th = (-d.w2()).acos();
    assert!(d.project(&direction(th - 1e-3, 1.0)).is_some());
    assert!(d.project(&direction(th + 1e-3, 1.0)).is_none());
    assert!(d.project(&Vector3::new(0.0, 0.0, -1.0)).is_none());
    assert!(d.project(&origin).is_none());
    // α > 0.5 limits unprojection to r² ≤ 1/(2α − 1).
    let r_max = (1.0 / (2.0 * d.alpha - 1.0)).sqrt() * d.fx;
    assert!(
        d.unproject(&Vector2::new(d.cx + r_max * 1.001, d.cy))
            .is_none()
    );
}

/// `Camera` forwards every call to the wrapped model unchanged.
#[test]
fn camera_enum_delegates() {
    let p = Vector3::new(0.3, -0.2, 1.5);
    let uv = Vector2::new(100.25, 200.75);
    let models: [&dyn CameraModel; 4] = [&euroc(), &tumvi_kb(), &mei(), &ds()];
    let wrapped = [
        Camera::from(euroc()),
        Camera::from(tumvi_kb()),
        Camera::from(mei()),
        Camera::from(ds()),
    ];
    for (m, c) in models.iter().zip(&wrapped) {
        assert_eq!(m.width(), c.width());
        assert_eq!(m.height(), c.height());
        assert_eq!(m.project(&p), c.project(&p));
        assert_eq!(m.project_with_jacobian(&p), c.project_with_jacobian(&p));
        assert_eq!(m.unproject(&uv), c.unproject(&uv));
        assert_eq!(m.is_valid(&uv), c.is_valid(&uv));
        assert_eq!(m.unproject_normalized(&uv), c.unproject_normalized(&uv));
    }
    assert_eq!(wrapped[0], Camera::PinholeRadtan(euroc()));
    assert_ne!(wrapped[0], wrapped[1]);
}
