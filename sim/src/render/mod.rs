//! Off-screen rendering of the scene into each camera's grey-level image (and depth), with wgpu.
//!
//! # Pipeline (per camera, per frame)
//! 1. **Scene pass (GPU)**: the scene's surfaces (and markers) are drawn into an undistorted
//!    *virtual pinhole* image that shares the camera's frame and covers its field of view with a
//!    margin; grey level = albedo · shade · gain. The albedo comes from a mip-mapped texture
//!    array (texture anti-aliasing: bilinear within the nearest mip level by default, trilinear
//!    and anisotropic on request); `shade` is a fixed directional light per surface. Optional 4×
//!    MSAA anti-aliases geometric edges. Reversed infinite Z (depth = near / z) with a 32-bit
//!    float depth buffer keeps 100 m scenes free of z-fighting.
//! 2. **Readback** of every camera's pinhole image(s) (one copy per image into one buffer, one
//!    map per frame).
//! 3. **Remap (CPU)**: every real pixel has a tap precomputed at start-up through
//!    [`estimator::camera::CameraModel::unproject`]: where its bearing lands in the virtual
//!    pinhole (top-left index and 1/256-px position) and its vignetting factor; integer bilinear
//!    interpolation, one thread per camera. Images carry the model's real
//!    distortion (radtan, Kannala-Brandt, MEI, double sphere). Pixels whose bearing is outside
//!    the model's valid region, or more than `max_half_angle_deg` off-axis, are black. (On the
//!    software adapter this costs ≈0.5 ms per image against ≈5 ms for the same remap as a GPU
//!    pass.)
//! 4. **Motion blur** (optional): the scene pass runs for `samples` poses spread evenly over the
//!    exposure; their remapped sums are averaged. **Rolling shutter** (a camera's
//!    `rolling_shutter`): the scene pass runs for `readout_samples` poses spanning the readout and
//!    each row takes the renders around its own time, weighted as a sequence linear in time
//!    (integrated over its exposure with motion blur): `shutter.rs`.
//! 5. **Sensor noise**: Gaussian read noise and shot noise from the ChaCha8 stream
//!    `<camera name>/pixels` of the seed (ChaCha stream index = frame index, so any frame can be
//!    re-rendered alone with the same noise), then rounding to 8 bits.
//!
//! Depth images (optional) are rendered at exposure sample ⌊samples/2⌋ (the capture time without
//! motion blur; the middle sample of an odd count) as inverse depth, remapped
//! without blending across depth edges, and returned as z along the optical axis (m; 0 where no
//! surface is seen).
//!
//! # Determinism and adapters
//! The adapter is chosen deterministically: adapters of the configured backend sorted by kind
//! (discrete GPU, integrated, virtual, CPU, other) and name; a configured name substring
//! overrides. The same scene, seed and pose give identical bytes within a process and across
//! processes on the same machine (tested by hash). On a machine without a GPU, wgpu's GL backend
//! finds Mesa's llvmpipe through EGL (Debian: `libegl1 libegl-mesa0 libgl1-mesa-dri`); the Vulkan
//! backend finds lavapipe (`mesa-vulkan-drivers libvulkan1`). Different backends or Mesa versions
//! may differ by a grey level in a few pixels.

mod config;
mod formation;
mod images;
mod optics;
mod readback;
mod remap;
mod setup;
mod shutter;
mod texture;

pub use config::{GainStep, MotionBlur, Photometric, RenderBackend, RenderConfig, RenderError};
pub use images::{AdapterSummary, CameraImage, DepthImage, GrayImage, ImageFrame, VirtualPinhole};

use crate::camera::RigConfig;
use crate::rng::sensor_rng;
use crate::scene::{Scene, SurfaceTexture};
use estimator::geometry::Pose;
use formation::CameraFormation;
pub(crate) use formation::{ImageFormation, Readback};
use nalgebra::{Matrix4, Vector2, Vector3};
use rand::RngExt;
use readback::copy_out;
use setup::{choose_adapter, padded_row, projection, scene_vertices, texture_2d, view};
use std::sync::Arc;
use wgpu::util::DeviceExt;

/// Near clipping distance (m).
const NEAR_M: f64 = 0.02;
/// Uniform slots are 256 bytes apart (wgpu's minimum dynamic offset alignment).
const UNIFORM_STRIDE: u64 = 256;
/// Marker disks are drawn as regular polygons with this many sides.
const MARKER_SIDES: usize = 48;
const PINHOLE_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R8Unorm;
/// Inverse depth travels as the bits of an f32 in a 32-bit integer target: R32Float is not
/// renderable on downlevel (GL) adapters, R32Uint is.
const INV_DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Uint;
const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Vertex {
    pos: [f32; 3],
    uv: [f32; 2],
    layer: u32,
    shade: f32,
    plain: f32,
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct SceneCameraUniform {
    view_proj: [[f32; 4]; 4],
    gain: f32,
    inv_near: f32,
    pad: [f32; 2],
}

/// GPU targets of one camera (its virtual pinhole's size and place in the readback are its
/// [`CameraFormation`]'s).
struct CameraTargets {
    t_b_c: Pose,
    /// Projection of the virtual pinhole (camera frame → clip).
    proj: Matrix4<f64>,
    msaa_view: Option<wgpu::TextureView>,
    pinhole: wgpu::Texture,
    pinhole_view: wgpu::TextureView,
    zbuf_view: wgpu::TextureView,
    /// Inverse-depth target and its single-sample depth buffer (depth images only).
    inv_depth: Option<(wgpu::Texture, wgpu::TextureView, wgpu::TextureView)>,
}

/// The renderer: a wgpu device with the scene, its textures and per-camera targets uploaded.
pub struct Renderer {
    config: RenderConfig,
    /// From read-back renders to camera images (shared with the render worker's forming
    /// thread).
    formation: Arc<ImageFormation>,
    adapter: AdapterSummary,
    device: wgpu::Device,
    queue: wgpu::Queue,
    scene_pipeline: wgpu::RenderPipeline,
    inv_depth_pipeline: Option<wgpu::RenderPipeline>,
    scene_group: wgpu::BindGroup,
    uniforms: wgpu::Buffer,
    vertices: wgpu::Buffer,
    vertex_count: u32,
    cameras: Vec<CameraTargets>,
    readback: wgpu::Buffer,
    samples: u32,
    /// Render times relative to the capture time (ns).
    offsets_ns: Vec<i64>,
    /// The scene's background grey level.
    background: f64,
}

impl std::fmt::Debug for Renderer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Renderer")
            .field("adapter", &self.adapter)
            .field("config", &self.config)
            .field("cameras", &self.cameras.len())
            .finish_non_exhaustive()
    }
}

impl Renderer {
    /// Uploads `scene` (textures drawn from `seed`) and prepares targets and remap tables for
    /// every camera of `rig`. Fails with an install hint when no adapter exists.
    pub fn new(
        scene: &Scene,
        rig: &RigConfig,
        config: &RenderConfig,
        seed: u64,
    ) -> Result<Self, RenderError> {
        config.validate()?;
        if let Some((i, c)) = rig
            .cameras
            .iter()
            .enumerate()
            .find(|(_, c)| c.model.width().max(c.model.height()) > 8192)
        {
            return Err(RenderError::Config(format!(
                "camera {i} ({}) is {}×{}: rendered cameras are at most 8192 pixels a side",
                c.name,
                c.model.width(),
                c.model.height()
            )));
        }
        if rig.cameras.is_empty() {
            return Err(RenderError::Config("the rig has no camera".into()));
        }
        let adapter = choose_adapter(config)?;
        let info = adapter.get_info();
        let summary = AdapterSummary {
            name: info.name.clone(),
            backend: format!("{:?}", info.backend),
            driver: [info.driver.as_str(), info.driver_info.as_str()]
                .iter()
                .filter(|s| !s.is_empty())
                .cloned()
                .collect::<Vec<_>>()
                .join(" "),
            device_type: format!("{:?}", info.device_type),
        };
        let msaa = if config.msaa { 4 } else { 1 };
        for (fmt, what) in [(PINHOLE_FORMAT, "R8Unorm"), (DEPTH_FORMAT, "Depth32Float")] {
            let flags = adapter.get_texture_format_features(fmt).flags;
            if msaa > 1 && !flags.sample_count_supported(msaa) {
                return Err(RenderError::Device(format!(
                    "adapter {summary} cannot multisample {what} 4×: set msaa = false"
                )));
            }
        }
        let anisotropy = if adapter
            .get_downlevel_capabilities()
            .flags
            .contains(wgpu::DownlevelFlags::ANISOTROPIC_FILTERING)
        {
            config.anisotropy
        } else {
            1
        };
        let limits = wgpu::Limits::downlevel_defaults().using_resolution(adapter.limits());
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("sim::render"),
            required_features: wgpu::Features::empty(),
            required_limits: limits,
            ..Default::default()
        }))
        .map_err(|e| RenderError::Device(format!("{summary}: {e}")))?;
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);

        // Textures: one layer per material, full mip chain.
        let n = config.texture_size;
        let albedo = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("albedo"),
            size: wgpu::Extent3d {
                width: n,
                height: n,
                depth_or_array_layers: texture::MATERIALS.len() as u32,
            },
            mip_level_count: n.ilog2() + 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::R8Unorm,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        let mut tex_rng = sensor_rng(seed, "render/textures");
        for (layer, m) in texture::MATERIALS.iter().enumerate() {
            let style = texture::TextureStyle {
                contrast: config.texture_contrast as f32,
                density: config.texture_density as f32,
            };
            let levels = texture::generate(*m, n as usize, config.texel_m, style, &mut tex_rng);
            for (level, data) in levels.iter().enumerate() {
                let s = (n >> level).max(1);
                queue.write_texture(
                    wgpu::TexelCopyTextureInfo {
                        texture: &albedo,
                        mip_level: level as u32,
                        origin: wgpu::Origin3d {
                            x: 0,
                            y: 0,
                            z: layer as u32,
                        },
                        aspect: wgpu::TextureAspect::All,
                    },
                    data,
                    wgpu::TexelCopyBufferLayout {
                        offset: 0,
                        bytes_per_row: Some(s),
                        rows_per_image: Some(s),
                    },
                    wgpu::Extent3d {
                        width: s,
                        height: s,
                        depth_or_array_layers: 1,
                    },
                );
            }
        }
        let albedo_view = albedo.create_view(&wgpu::TextureViewDescriptor {
            dimension: Some(wgpu::TextureViewDimension::D2Array),
            ..Default::default()
        });
        let albedo_sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("albedo"),
            address_mode_u: wgpu::AddressMode::Repeat,
            address_mode_v: wgpu::AddressMode::Repeat,
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            mipmap_filter: if config.trilinear || anisotropy > 1 {
                wgpu::MipmapFilterMode::Linear
            } else {
                wgpu::MipmapFilterMode::Nearest
            },
            anisotropy_clamp: anisotropy,
            ..Default::default()
        });
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("render.wgsl"),
            source: wgpu::ShaderSource::Wgsl(include_str!("render.wgsl").into()),
        });
        let scene_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("scene"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: true,
                        min_binding_size: wgpu::BufferSize::new(std::mem::size_of::<
                            SceneCameraUniform,
                        >() as u64),
                    },
                    count: None,
                },
                wgpu::BindGroupLayoutEntry {
                    binding: 1,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Float { filterable: true },
                        view_dimension: wgpu::TextureViewDimension::D2Array,
                        multisampled: false,
                    },
                    count: None,
                },
                wgpu::BindGroupLayoutEntry {
                    binding: 2,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                    count: None,
                },
            ],
        });
        let vertex_layout = wgpu::VertexBufferLayout {
            array_stride: std::mem::size_of::<Vertex>() as u64,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &wgpu::vertex_attr_array![
                0 => Float32x3, 1 => Float32x2, 2 => Uint32, 3 => Float32, 4 => Float32
            ],
        };
        let scene_pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("scene"),
            bind_group_layouts: &[Some(&scene_layout)],
            immediate_size: 0,
        });
        let pipeline_for = |entry: &str, format, samples| {
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(entry),
                layout: Some(&scene_pl),
                vertex: wgpu::VertexState {
                    module: &module,
                    entry_point: Some("vs_scene"),
                    compilation_options: Default::default(),
                    buffers: &[Some(vertex_layout.clone())],
                },
                primitive: wgpu::PrimitiveState {
                    topology: wgpu::PrimitiveTopology::TriangleList,
                    front_face: wgpu::FrontFace::Ccw,
                    cull_mode: Some(wgpu::Face::Back),
                    ..Default::default()
                },
                depth_stencil: Some(wgpu::DepthStencilState {
                    format: DEPTH_FORMAT,
                    depth_write_enabled: Some(true),
                    depth_compare: Some(wgpu::CompareFunction::Greater),
                    stencil: Default::default(),
                    bias: Default::default(),
                }),
                multisample: wgpu::MultisampleState {
                    count: samples,
                    ..Default::default()
                },
                fragment: Some(wgpu::FragmentState {
                    module: &module,
                    entry_point: Some(entry),
                    compilation_options: Default::default(),
                    targets: &[Some(wgpu::ColorTargetState {
                        format,
                        blend: None,
                        write_mask: wgpu::ColorWrites::RED,
                    })],
                }),
                multiview_mask: None,
                cache: None,
            })
        };
        let scene_pipeline = pipeline_for("fs_scene", PINHOLE_FORMAT, msaa);
        let inv_depth_pipeline = config
            .depth
            .then(|| pipeline_for("fs_inv_depth", INV_DEPTH_FORMAT, 1));

        let shutters: Vec<_> = rig
            .cameras
            .iter()
            .map(|c| (c.rolling_shutter, c.model.height()))
            .collect();
        let mut plan = shutter::plan(&shutters, config.motion_blur, config.readout_samples);
        let samples = plan.offsets_ns.len() as u32;
        let n_cams = rig.cameras.len() as u64;
        let uniforms = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("scene cameras"),
            size: UNIFORM_STRIDE * n_cams * u64::from(samples),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let scene_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("scene"),
            layout: &scene_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                        buffer: &uniforms,
                        offset: 0,
                        size: wgpu::BufferSize::new(
                            std::mem::size_of::<SceneCameraUniform>() as u64
                        ),
                    }),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(&albedo_view),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::Sampler(&albedo_sampler),
                },
            ],
        });
        let verts = scene_vertices(scene, config, seed);
        let vertices = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("scene"),
            contents: bytemuck::cast_slice(&verts),
            usage: wgpu::BufferUsages::VERTEX,
        });

        // Per-camera targets and remap tables.
        let attach = wgpu::TextureUsages::RENDER_ATTACHMENT;
        let copy = wgpu::TextureUsages::COPY_SRC;
        let mut cameras = Vec::new();
        let mut formations = Vec::new();
        let mut readback_size = 0u64;
        for (cam, row_weights) in rig.cameras.iter().zip(plan.row_weights.drain(..)) {
            let table = remap::build(
                cam.model.as_ref(),
                padded_row,
                config.max_half_angle_deg,
                config.max_pinhole_size,
                config.pinhole_scale,
                config.photometric.vignetting,
            );
            let pin = table.pinhole;
            let size = (pin.width, pin.height);
            let msaa_view = (msaa > 1).then(|| {
                view(&texture_2d(
                    &device,
                    "pinhole msaa",
                    size,
                    PINHOLE_FORMAT,
                    msaa,
                    attach,
                ))
            });
            let pinhole = texture_2d(&device, &cam.name, size, PINHOLE_FORMAT, 1, attach | copy);
            let inv_depth = config.depth.then(|| {
                let t = texture_2d(
                    &device,
                    "inverse depth",
                    size,
                    INV_DEPTH_FORMAT,
                    1,
                    attach | copy,
                );
                let v = view(&t);
                let z = view(&texture_2d(
                    &device,
                    "zbuf 1x",
                    size,
                    DEPTH_FORMAT,
                    1,
                    attach,
                ));
                (t, v, z)
            });
            let readback_offset = readback_size;
            readback_size +=
                u64::from(samples) * u64::from(padded_row(pin.width)) * u64::from(pin.height);
            if config.depth {
                readback_size += u64::from(padded_row(4 * pin.width)) * u64::from(pin.height);
            }
            cameras.push(CameraTargets {
                t_b_c: cam.t_b_c,
                proj: projection(&pin),
                pinhole_view: view(&pinhole),
                pinhole,
                zbuf_view: view(&texture_2d(
                    &device,
                    "zbuf",
                    size,
                    DEPTH_FORMAT,
                    msaa,
                    attach,
                )),
                msaa_view,
                inv_depth,
            });
            formations.push(CameraFormation {
                name: cam.name.clone(),
                width: cam.model.width(),
                height: cam.model.height(),
                table,
                readback_offset: readback_offset as usize,
                row_weights,
            });
        }
        if readback_size > device.limits().max_buffer_size {
            return Err(RenderError::Config(format!(
                "the readback of one frame needs {readback_size} bytes, more than the device allows ({}): lower motion_blur.samples or pinhole_scale, or turn depth off",
                device.limits().max_buffer_size
            )));
        }
        let readback = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("readback"),
            size: readback_size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(RenderError::Gpu(e.to_string()));
        }
        Ok(Self {
            config: config.clone(),
            formation: Arc::new(ImageFormation {
                cameras: formations,
                photometric: config.photometric,
                samples: samples as usize,
                depth: config.depth,
                seed,
            }),
            adapter: summary,
            device,
            queue,
            scene_pipeline,
            inv_depth_pipeline,
            scene_group,
            uniforms,
            vertices,
            vertex_count: verts.len() as u32,
            cameras,
            readback,
            samples,
            offsets_ns: plan.offsets_ns,
            background: scene.background,
        })
    }

    /// The image formation of this renderer's rig (for forming read-back frames on another
    /// thread).
    pub(crate) fn formation(&self) -> Arc<ImageFormation> {
        Arc::clone(&self.formation)
    }

    /// The adapter in use.
    pub fn adapter(&self) -> &AdapterSummary {
        &self.adapter
    }

    /// The configuration.
    pub fn config(&self) -> &RenderConfig {
        &self.config
    }

    /// Image size `(width, height)` of camera `cam`.
    pub fn image_size(&self, cam: usize) -> (u32, u32) {
        let c = &self.formation.cameras[cam];
        (c.width, c.height)
    }

    /// The virtual pinhole camera `cam` is rendered through before distortion.
    pub fn pinhole(&self, cam: usize) -> VirtualPinhole {
        self.formation.cameras[cam].table.pinhole
    }

    /// Times (ns, relative to the capture time) of the poses [`Renderer::render`] needs: one
    /// without motion blur, else `samples` spread evenly over the exposure (centres of equal
    /// sub-intervals); with a rolling-shutter camera, `readout_samples` spanning the readouts
    /// (see `shutter.rs`).
    pub fn exposure_offsets_ns(&self) -> Vec<i64> {
        self.offsets_ns.clone()
    }

    /// Gain at true time `t_ns`.
    pub fn gain_at(&self, t_ns: i64) -> f64 {
        let p = &self.config.photometric;
        let t = t_ns as f64 * 1e-9;
        let step = p
            .gain_step
            .filter(|g| t >= g.at_s)
            .map_or(1.0, |g| g.factor);
        step * p.gain
            * (1.0 + p.gain_variation * (std::f64::consts::TAU * t / p.gain_period_s).sin())
    }

    /// Renders the cameras `live` (rig indices, increasing). `poses_w_b` are the body poses at
    /// [`Renderer::exposure_offsets_ns`] around the true capture time `t_capture_ns` (which sets
    /// the gain); `stamp_ns` is written into the frame; `frame_index` selects the noise.
    pub fn render(
        &mut self,
        t_capture_ns: i64,
        stamp_ns: i64,
        frame_index: u64,
        poses_w_b: &[Pose],
        live: &[usize],
    ) -> Result<ImageFrame, RenderError> {
        let frame = self.read_back(t_capture_ns, stamp_ns, frame_index, poses_w_b, live)?;
        Ok(self.formation.form(&frame))
    }

    /// The first half of [`Renderer::render`]: the scene passes drawn and read back, not yet
    /// formed into camera images (see [`Renderer::formation`]).
    pub(crate) fn read_back(
        &mut self,
        t_capture_ns: i64,
        stamp_ns: i64,
        frame_index: u64,
        poses_w_b: &[Pose],
        live: &[usize],
    ) -> Result<Readback, RenderError> {
        let k_n = self.samples as usize;
        if poses_w_b.len() != k_n {
            return Err(RenderError::Config(format!(
                "render needs {k_n} poses (one per exposure sample), got {}",
                poses_w_b.len()
            )));
        }
        if let Some(&c) = live.iter().find(|&&c| c >= self.cameras.len()) {
            return Err(RenderError::Config(format!("no camera {c} in the rig")));
        }
        let gain = self.gain_at(t_capture_ns) as f32;
        let mut bytes = vec![0u8; self.uniforms.size() as usize];
        for (c, cam) in self.cameras.iter().enumerate() {
            for (k, pose) in poses_w_b.iter().enumerate() {
                let t_c_w = pose.compose(&cam.t_b_c).inverse();
                let mut view = Matrix4::identity();
                view.fixed_view_mut::<3, 3>(0, 0)
                    .copy_from(t_c_w.q.to_rotation_matrix().matrix());
                view.fixed_view_mut::<3, 1>(0, 3).copy_from(&t_c_w.p);
                let vp = cam.proj * view;
                let mut m = [[0f32; 4]; 4];
                for (col, mc) in m.iter_mut().enumerate() {
                    for (row, v) in mc.iter_mut().enumerate() {
                        *v = vp[(row, col)] as f32;
                    }
                }
                let u = SceneCameraUniform {
                    view_proj: m,
                    gain,
                    inv_near: (1.0 / NEAR_M) as f32,
                    pad: [0.0; 2],
                };
                let off = (c * k_n + k) * UNIFORM_STRIDE as usize;
                bytes[off..off + std::mem::size_of::<SceneCameraUniform>()]
                    .copy_from_slice(bytemuck::bytes_of(&u));
            }
        }
        let scope = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        self.queue.write_buffer(&self.uniforms, 0, &bytes);
        let mut enc = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("frame"),
            });
        for &c in live {
            let cam = &self.cameras[c];
            let formed = &self.formation.cameras[c];
            let (pw, ph) = (formed.table.pinhole.width, formed.table.pinhole.height);
            let readback_offset = formed.readback_offset as u64;
            let image_bytes = u64::from(padded_row(pw)) * u64::from(ph);
            for k in 0..k_n {
                let offset = ((c * k_n + k) as u64 * UNIFORM_STRIDE) as u32;
                self.scene_pass(&mut enc, cam, offset, Some(f64::from(gain)));
                copy_out(
                    &mut enc,
                    &cam.pinhole,
                    &self.readback,
                    readback_offset + k as u64 * image_bytes,
                    (pw, ph),
                    1,
                );
            }
            if let Some((tex, _, _)) = &cam.inv_depth {
                let offset = ((c * k_n + k_n / 2) as u64 * UNIFORM_STRIDE) as u32;
                self.scene_pass(&mut enc, cam, offset, None);
                let at = readback_offset + k_n as u64 * image_bytes;
                copy_out(&mut enc, tex, &self.readback, at, (pw, ph), 4);
            }
        }
        self.queue.submit([enc.finish()]);
        let slice = self.readback.slice(..);
        let (tx, rx) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| RenderError::Gpu(format!("poll: {e}")))?;
        match rx.recv() {
            Ok(Ok(())) => {}
            Ok(Err(e)) => return Err(RenderError::Gpu(format!("readback: {e}"))),
            Err(_) => return Err(RenderError::Gpu("readback callback dropped".into())),
        }
        let bytes = slice
            .get_mapped_range()
            .map_err(|e| RenderError::Gpu(format!("readback: {e:?}")))?
            .to_vec();
        let frame = Readback {
            t_ns: stamp_ns,
            t_capture_ns,
            frame_index,
            live: live.to_vec(),
            bytes,
        };
        self.readback.unmap();
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(RenderError::Gpu(e.to_string()));
        }
        Ok(frame)
    }

    fn scene_pass(
        &self,
        enc: &mut wgpu::CommandEncoder,
        cam: &CameraTargets,
        offset: u32,
        gain: Option<f64>,
    ) {
        // `None`: the inverse-depth pass (cleared to 0 = nothing seen).
        let depth = gain.is_none();
        let clear = (self.background * gain.unwrap_or(0.0)).clamp(0.0, 1.0);
        let (target, resolve, zbuf, pipeline) = match (&cam.inv_depth, &self.inv_depth_pipeline) {
            (Some((_, inv, z)), Some(p)) if depth => (inv, None, z, p),
            _ => match &cam.msaa_view {
                Some(ms) => (
                    ms,
                    Some(&cam.pinhole_view),
                    &cam.zbuf_view,
                    &self.scene_pipeline,
                ),
                None => (
                    &cam.pinhole_view,
                    None,
                    &cam.zbuf_view,
                    &self.scene_pipeline,
                ),
            },
        };
        let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("scene"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: target,
                depth_slice: None,
                resolve_target: resolve,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color {
                        r: clear,
                        g: 0.0,
                        b: 0.0,
                        a: 1.0,
                    }),
                    store: if resolve.is_some() {
                        wgpu::StoreOp::Discard
                    } else {
                        wgpu::StoreOp::Store
                    },
                },
            })],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: zbuf,
                depth_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Clear(0.0),
                    store: wgpu::StoreOp::Discard,
                }),
                stencil_ops: None,
            }),
            ..Default::default()
        });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, &self.scene_group, &[offset]);
        pass.set_vertex_buffer(0, self.vertices.slice(..));
        pass.draw(0..self.vertex_count, 0..1);
    }
}
