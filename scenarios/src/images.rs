//! Rendered images on disk: 8-bit grey PNGs and 16-bit depth PNGs (millimetres, 0 = no
//! surface; the TUM RGB-D convention uses 5000 per metre, we use 1000 so values read as mm).

use std::path::Path;

use sim::render::{DepthImage, GrayImage};

/// Writes `img` as an 8-bit grey PNG; the error names the file.
pub fn write_gray_png(path: &Path, img: &GrayImage) -> Result<(), String> {
    image::save_buffer_with_format(
        path,
        &img.data,
        img.width,
        img.height,
        image::ExtendedColorType::L8,
        image::ImageFormat::Png,
    )
    .map_err(|e| format!("{}: cannot write the image: {e}", path.display()))
}

/// Depth in millimetres as u16 (0 where no surface is seen; saturates at 65.535 m).
pub fn depth_to_mm(depth: &DepthImage) -> Vec<u16> {
    depth
        .data
        .iter()
        .map(|&z| (f64::from(z) * 1000.0).round().clamp(0.0, 65535.0) as u16)
        .collect()
}

/// Writes `depth` as a 16-bit grey PNG in millimetres; the error names the file.
pub fn write_depth_png(path: &Path, depth: &DepthImage) -> Result<(), String> {
    let buf = image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_raw(
        depth.width,
        depth.height,
        depth_to_mm(depth),
    )
    .ok_or_else(|| format!("{}: depth buffer of the wrong size", path.display()))?;
    buf.save_with_format(path, image::ImageFormat::Png)
        .map_err(|e| format!("{}: cannot write the depth image: {e}", path.display()))
}

/// What `vio render` produced.
#[derive(Clone, Debug)]
pub struct RenderedAt {
    /// The images (with depth).
    pub frame: sim::render::ImageFrame,
    /// The adapter that rendered them.
    pub adapter: String,
    /// Wall time of the render call (s).
    pub render_s: f64,
}

/// Renders every camera of `scenario` (with depth) at `at_s` seconds into the run, with the
/// scenario's rendering settings (also for feature-level scenarios).
pub fn render_at(
    scenario: &crate::spec::Scenario,
    at_s: f64,
    seed: Option<u64>,
) -> Result<RenderedAt, crate::run::RunError> {
    use crate::run::RunError;
    let (world, mut renderer, rig) = renderer_at(scenario, at_s, seed, true)?;
    let t_ns = (at_s * 1e9).round() as i64;
    let mut stream = world.stream();
    let poses = renderer
        .exposure_offsets_ns()
        .iter()
        .map(|o| {
            stream
                .truth((t_ns + o).clamp(0, world.end_ns()))
                .map(|g| g.pose)
                .ok_or(RunError::NoTruth { t_ns: t_ns + o })
        })
        .collect::<Result<Vec<_>, _>>()?;
    let live: Vec<usize> = (0..rig.cameras.len()).collect();
    let start = std::time::Instant::now();
    let frame = renderer
        .render(t_ns, t_ns, rig.frame_at_or_before(t_ns), &poses, &live)
        .map_err(|e| RunError::sim(scenario, e))?;
    Ok(RenderedAt {
        frame,
        adapter: renderer.adapter().to_string(),
        render_s: start.elapsed().as_secs_f64(),
    })
}

/// The scenario's world at `at_s` ([`world_at`]) with a renderer of the scenario's settings
/// (depth images when `depth`) and its camera rig.
pub(crate) fn renderer_at(
    scenario: &crate::spec::Scenario,
    at_s: f64,
    seed: Option<u64>,
    depth: bool,
) -> Result<(sim::World, sim::render::Renderer, sim::camera::RigConfig), crate::run::RunError> {
    let world = world_at(scenario, at_s, seed)?;
    let mut cfg = scenario.render_settings()?;
    cfg.depth = depth;
    let renderer = world
        .renderer(&cfg)
        .map_err(|e| crate::run::RunError::sim(scenario, e))?;
    let rig = world
        .config()
        .rig
        .clone()
        .expect("a renderer implies a rig");
    Ok((world, renderer, rig))
}

/// The scenario's world (`seed` instead of the scenario's), checking that `at_s` lies in the run.
fn world_at(
    scenario: &crate::spec::Scenario,
    at_s: f64,
    seed: Option<u64>,
) -> Result<sim::World, crate::run::RunError> {
    use crate::run::RunError;
    let world_cfg = scenario.world_config(seed, None)?;
    let world = sim::World::new(world_cfg).map_err(|e| RunError::sim(scenario, e))?;
    let end_s = world.end_ns() as f64 * 1e-9;
    if !(at_s.is_finite() && (0.0..=end_s).contains(&at_s)) {
        return Err(RunError::sim(
            scenario,
            format!("--at {at_s} s is outside the scenario's [0, {end_s}] s"),
        ));
    }
    Ok(world)
}

/// The cameras' images side by side (a white 8-pixel gap between them), for a quick look.
pub fn side_by_side(frame: &sim::render::ImageFrame) -> GrayImage {
    let gap = 8;
    let width = frame.cameras.iter().map(|c| c.image.width).sum::<u32>()
        + gap * (frame.cameras.len().max(1) as u32 - 1);
    let height = frame
        .cameras
        .iter()
        .map(|c| c.image.height)
        .max()
        .unwrap_or(0);
    let mut out = GrayImage {
        width,
        height,
        data: vec![255; (width * height) as usize],
    };
    let mut x0 = 0;
    for c in &frame.cameras {
        for y in 0..c.image.height {
            let src =
                &c.image.data[(y * c.image.width) as usize..((y + 1) * c.image.width) as usize];
            let at = (y * width + x0) as usize;
            out.data[at..at + src.len()].copy_from_slice(src);
        }
        x0 += c.image.width + gap;
    }
    out
}
