//! The renderer's settings (`[camera.render]`, `[camera.photometric]`) and errors.

/// Which wgpu backend renders.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RenderBackend {
    /// OpenGL through EGL (Mesa llvmpipe on machines without a GPU).
    #[default]
    Gl,
    /// Vulkan (lavapipe without a GPU).
    Vulkan,
}

impl RenderBackend {
    pub(super) fn backends(self) -> wgpu::Backends {
        match self {
            RenderBackend::Gl => wgpu::Backends::GL,
            RenderBackend::Vulkan => wgpu::Backends::VULKAN,
        }
    }

    /// The Debian packages that provide a software adapter for this backend.
    pub fn install_hint(self) -> &'static str {
        match self {
            RenderBackend::Gl => "apt-get install libegl1 libegl-mesa0 libgl1-mesa-dri",
            RenderBackend::Vulkan => "apt-get install mesa-vulkan-drivers libvulkan1",
        }
    }
}

/// Motion blur: the image is the average of `samples` renders spread over the exposure.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MotionBlur {
    /// Exposure time (s), centred on the capture time.
    pub exposure_s: f64,
    /// Sub-frame renders per image (≥ 2).
    pub samples: u32,
}

/// Photometric effects (deserialized: missing keys take the defaults, none of the effects).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Photometric {
    /// Mean gain (exposure × analogue gain) applied to albedo · shade.
    pub gain: f64,
    /// Relative amplitude of the gain's slow oscillation (auto-exposure hunting): gain(t) =
    /// gain · (1 + gain_variation · sin(2π t / gain_period_s)).
    pub gain_variation: f64,
    /// Period of that oscillation (s).
    pub gain_period_s: f64,
    /// Vignetting: brightness falls as 1 − vignetting · (r / r_corner)², r from the optical
    /// centre (0 = none; 0.3 = corners 30 % darker).
    pub vignetting: f64,
    /// Read noise σ (grey levels).
    pub read_noise: f64,
    /// Shot noise: electrons per grey level (variance of a level `I` is `I / electrons_per_level`);
    /// 0 turns shot noise off.
    pub electrons_per_level: f64,
    /// A sudden exposure change: from this true time on, the gain is multiplied by a factor.
    pub gain_step: Option<GainStep>,
    /// The lens and sensor's blur: a Gaussian point spread of this σ (px of the camera image),
    /// applied before the noise (0 = a perfectly sharp image).
    pub optical_blur_px: f64,
}

/// A step in the gain (an auto-exposure jump between two frames).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GainStep {
    /// When (s of true time).
    pub at_s: f64,
    /// Gain factor from then on.
    pub factor: f64,
}

impl Default for Photometric {
    /// Unit gain, no vignetting, no noise.
    fn default() -> Self {
        Self {
            gain: 1.0,
            gain_variation: 0.0,
            gain_period_s: 10.0,
            vignetting: 0.0,
            read_noise: 0.0,
            electrons_per_level: 0.0,
            gain_step: None,
            optical_blur_px: 0.0,
        }
    }
}

/// Renderer settings (deserialized: missing keys take [`RenderConfig::default`]'s values).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RenderConfig {
    /// Backend (pinned: backends differ by a grey level here and there).
    pub backend: RenderBackend,
    /// Use the adapter whose name contains this (case-insensitive); `None`: the first in the
    /// deterministic order (GPUs before CPUs).
    pub adapter: Option<String>,
    /// 4× multisampling of geometric edges (textures are always mip-mapped).
    pub msaa: bool,
    /// Blend between mip levels (trilinear filtering) instead of taking the nearest level.
    pub trilinear: bool,
    /// Anisotropic filtering clamp (1, 2, 4, 8 or 16; > 1 implies trilinear).
    pub anisotropy: u16,
    /// Virtual pinhole focal length relative to the camera's on-axis magnification (1 keeps the
    /// image centre's resolution; smaller renders fewer pixels and blurs the centre slightly).
    /// Default 0.85: on the EuRoC radtan pair it renders 28 % fewer pixels than 1.0 for 4.3 %
    /// less mean gradient magnitude in the final images (3.5 % in the image centre; measured
    /// over 10 room poses), which keeps a stereo pair within 8 ms on a 2-core software adapter.
    pub pinhole_scale: f64,
    /// Texture tile size (texels, a power of two).
    pub texture_size: u32,
    /// Texel size on the surfaces (m).
    pub texel_m: f64,
    /// Contrast of the textured materials about mid-grey (1 as generated; 0.5 halves every
    /// grey level's distance from 0.5).
    pub texture_contrast: f64,
    /// How many shapes (posters, stones, clutter) the textured materials carry, relative to the
    /// generator's own (1; 0.25 leaves three quarters of the surfaces to the smooth fBm shading).
    pub texture_density: f64,
    /// Bearings further off-axis than this are not rendered (black); the virtual pinhole covers
    /// the rest. Below 90°.
    pub max_half_angle_deg: f64,
    /// Largest virtual pinhole image side (px); wider fields of view get a smaller virtual focal
    /// length instead.
    pub max_pinhole_size: u32,
    /// Also render depth images.
    pub depth: bool,
    /// Motion blur, if any.
    pub motion_blur: Option<MotionBlur>,
    /// Renders spanning a rolling-shutter readout (2–64; used only when a camera of the rig has
    /// a rolling shutter): each row interpolates the two around its time, so their spacing
    /// bounds the blur it adds (default 9: 2.5 ms over a 20 ms readout).
    pub readout_samples: u32,
    /// Exposure, vignetting and noise.
    pub photometric: Photometric,
}

impl Default for RenderConfig {
    /// GL backend, mip-mapped textures (nearest level, no MSAA), pinhole scale 0.85, 2048²
    /// textures at 4 mm per texel, 75° half-angle, no depth, no blur, no photometric effects.
    fn default() -> Self {
        Self {
            backend: RenderBackend::Gl,
            adapter: None,
            msaa: false,
            trilinear: false,
            anisotropy: 1,
            pinhole_scale: 0.85,
            texture_size: 2048,
            texel_m: 0.004,
            texture_contrast: 1.0,
            texture_density: 1.0,
            max_half_angle_deg: 75.0,
            max_pinhole_size: 2048,
            depth: false,
            motion_blur: None,
            readout_samples: 9,
            photometric: Photometric::default(),
        }
    }
}

/// Renderer errors.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// No adapter of the backend was found.
    #[error(
        "no {backend:?} graphics adapter found{wanted}; on Debian/Ubuntu without a GPU install the software renderer: `{hint}`"
    )]
    NoAdapter {
        /// The backend asked for.
        backend: RenderBackend,
        /// `" matching …"` when an adapter name was configured.
        wanted: String,
        /// The install command.
        hint: &'static str,
    },
    /// The device could not be created or lacks a capability.
    #[error("graphics device: {0}")]
    Device(String),
    /// A configuration value is out of range.
    #[error("render config: {field} = {value} is out of range: {expected}")]
    Field {
        /// The field (`texture_size`, `photometric.vignetting`, …).
        field: &'static str,
        /// The rejected value.
        value: String,
        /// The accepted range.
        expected: &'static str,
    },
    /// A call does not fit the renderer's configuration.
    #[error("render: {0}")]
    Config(String),
    /// wgpu reported an error while rendering or reading back.
    #[error("rendering failed: {0}")]
    Gpu(String),
}

impl RenderConfig {
    /// Checks every field; the error names the offending one.
    pub fn validate(&self) -> Result<(), RenderError> {
        let c = self;
        let p = &c.photometric;
        let blur_ok = c.motion_blur.is_none_or(|b| {
            b.exposure_s.is_finite()
                && b.exposure_s > 0.0
                && b.exposure_s <= 0.5
                && (2..=32).contains(&b.samples)
        });
        let fin = |v: f64, ok: bool| v.is_finite() && ok;
        let step_ok = p.gain_step.is_none_or(|g| {
            g.at_s.is_finite()
                && g.at_s >= 0.0
                && g.factor.is_finite()
                && g.factor > 0.0
                && g.factor <= 100.0
        });
        let checks: [(&'static str, String, bool, &'static str); 18] = [
            (
                "texture_size",
                c.texture_size.to_string(),
                c.texture_size.is_power_of_two() && (16..=8192).contains(&c.texture_size),
                "a power of two in [16, 8192]",
            ),
            (
                "texel_m",
                c.texel_m.to_string(),
                (1e-4..=0.1).contains(&c.texel_m),
                "in [1e-4, 0.1] m",
            ),
            (
                "texture_contrast",
                c.texture_contrast.to_string(),
                c.texture_contrast > 0.0 && c.texture_contrast <= 2.0,
                "in (0, 2]",
            ),
            (
                "texture_density",
                c.texture_density.to_string(),
                c.texture_density > 0.0 && c.texture_density <= 4.0,
                "in (0, 4]",
            ),
            (
                "max_half_angle_deg",
                c.max_half_angle_deg.to_string(),
                c.max_half_angle_deg > 1.0 && c.max_half_angle_deg < 89.0,
                "in (1, 89)",
            ),
            (
                "max_pinhole_size",
                c.max_pinhole_size.to_string(),
                (64..=8192).contains(&c.max_pinhole_size),
                "in [64, 8192]",
            ),
            (
                "anisotropy",
                c.anisotropy.to_string(),
                [1, 2, 4, 8, 16].contains(&c.anisotropy),
                "1, 2, 4, 8 or 16",
            ),
            (
                "pinhole_scale",
                c.pinhole_scale.to_string(),
                c.pinhole_scale > 0.1 && c.pinhole_scale <= 4.0,
                "in (0.1, 4]",
            ),
            (
                "motion_blur",
                format!("{:?}", c.motion_blur),
                blur_ok,
                "exposure_s in (0, 0.5] and samples in 2..=32",
            ),
            (
                "readout_samples",
                c.readout_samples.to_string(),
                (2..=64).contains(&c.readout_samples),
                "in 2..=64",
            ),
            (
                "photometric.gain",
                p.gain.to_string(),
                fin(p.gain, p.gain >= 0.0),
                ">= 0",
            ),
            (
                "photometric.gain_variation",
                p.gain_variation.to_string(),
                (0.0..1.0).contains(&p.gain_variation),
                "in [0, 1)",
            ),
            (
                "photometric.gain_period_s",
                p.gain_period_s.to_string(),
                fin(p.gain_period_s, p.gain_period_s > 0.0),
                "> 0",
            ),
            (
                "photometric.vignetting",
                p.vignetting.to_string(),
                (0.0..=1.0).contains(&p.vignetting),
                "in [0, 1]",
            ),
            (
                "photometric.read_noise",
                p.read_noise.to_string(),
                fin(p.read_noise, p.read_noise >= 0.0),
                ">= 0",
            ),
            (
                "photometric.electrons_per_level",
                p.electrons_per_level.to_string(),
                fin(p.electrons_per_level, p.electrons_per_level >= 0.0),
                ">= 0",
            ),
            (
                "photometric.gain_step",
                format!("{:?}", p.gain_step),
                step_ok,
                "at_s >= 0 and factor in (0, 100]",
            ),
            (
                "photometric.optical_blur_px",
                p.optical_blur_px.to_string(),
                (0.0..=5.0).contains(&p.optical_blur_px),
                "in [0, 5] px",
            ),
        ];
        for (field, value, ok, expected) in checks {
            if !ok {
                return Err(RenderError::Field {
                    field,
                    value,
                    expected,
                });
            }
        }
        Ok(())
    }
}
