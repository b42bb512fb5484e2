//! Start-up helpers of the renderer: the adapter choice, the scene's vertices and
//! projection, texture creation.

use super::*;

/// Bytes per row of a copy to a buffer: rows padded to 256 bytes.
pub(super) fn padded_row(bytes: u32) -> u32 {
    bytes.div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT) * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT
}

/// Rank of an adapter kind in the deterministic choice (lower first).
pub(super) fn device_rank(t: wgpu::DeviceType) -> u8 {
    match t {
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Cpu => 3,
        wgpu::DeviceType::Other => 4,
    }
}

/// Picks the adapter deterministically (see the module docs).
pub(super) fn choose_adapter(config: &RenderConfig) -> Result<wgpu::Adapter, RenderError> {
    let instance = wgpu::Instance::new(wgpu::InstanceDescriptor {
        backends: config.backend.backends(),
        flags: wgpu::InstanceFlags::empty(),
        ..wgpu::InstanceDescriptor::new_without_display_handle()
    });
    let mut adapters = pollster::block_on(instance.enumerate_adapters(config.backend.backends()));
    adapters.sort_by_cached_key(|a| {
        let i = a.get_info();
        (device_rank(i.device_type), i.name, i.device)
    });
    let wanted = config.adapter.as_ref().map(|s| s.to_lowercase());
    adapters
        .into_iter()
        .find(|a| {
            wanted
                .as_ref()
                .is_none_or(|w| a.get_info().name.to_lowercase().contains(w))
        })
        .ok_or_else(|| RenderError::NoAdapter {
            backend: config.backend,
            wanted: config
                .adapter
                .as_ref()
                .map_or(String::new(), |w| format!(" matching {w:?}")),
            hint: config.backend.install_hint(),
        })
}

/// OpenCV pinhole → wgpu clip space (y down in pixels, y up in clip), reversed infinite Z:
/// clip depth = near / z.
pub(super) fn projection(p: &VirtualPinhole) -> Matrix4<f64> {
    let (w, h) = (f64::from(p.width), f64::from(p.height));
    #[rustfmt::skip]
    let m = Matrix4::new(
        2.0 * p.f / w, 0.0, 2.0 * (p.cx + 0.5) / w - 1.0, 0.0,
        0.0, -2.0 * p.f / h, 1.0 - 2.0 * (p.cy + 0.5) / h, 0.0,
        0.0, 0.0, 0.0, NEAR_M,
        0.0, 0.0, 1.0, 0.0,
    );
    m
}

/// Fixed directional light: shade of a surface with unit normal `n`.
pub(super) fn shade(n: &Vector3<f64>) -> f32 {
    let l = Vector3::new(0.35, 0.45, 0.82).normalize();
    (0.6 + 0.4 * n.dot(&l).abs()) as f32
}

/// Triangles of the scene: two per surface (counter-clockwise seen from the normal side), a
/// polygon per marker.
pub(super) fn scene_vertices(scene: &Scene, config: &RenderConfig, seed: u64) -> Vec<Vertex> {
    let mut rng = sensor_rng(seed, "render/layout");
    let tile_m = f64::from(config.texture_size) * config.texel_m;
    let mut out = Vec::new();
    let f32x3 = |p: Vector3<f64>| [p.x as f32, p.y as f32, p.z as f32];
    for s in &scene.surfaces {
        // Every surface draws (deterministically) a rich layer and an offset into the tile;
        // very large surfaces (outdoor ground) use a coarser texel so the tile repeats less.
        let layer_draw = rng.random_range(0..texture::RICH_LAYERS);
        let offset = Vector2::new(rng.random::<f64>(), rng.random::<f64>());
        let (lu, lv) = (s.u.norm(), s.v.norm());
        let scale = if lu.max(lv) > 50.0 { 2.5 } else { 1.0 };
        let (layer, plain) = match s.texture {
            SurfaceTexture::Rich => (layer_draw, -1.0),
            SurfaceTexture::Poor => (texture::POOR_LAYER, -1.0),
            SurfaceTexture::Plain(a) => (0, a.clamp(0.0, 1.0) as f32),
        };
        let sh = shade(&s.normal);
        let corner = |a: f64, b: f64| Vertex {
            pos: f32x3(s.origin + s.u * a + s.v * b),
            uv: [
                (offset.x + a * lu / (tile_m * scale)) as f32,
                (offset.y + b * lv / (tile_m * scale)) as f32,
            ],
            layer,
            shade: sh,
            plain,
        };
        let q = [
            corner(0.0, 0.0),
            corner(1.0, 0.0),
            corner(1.0, 1.0),
            corner(0.0, 1.0),
        ];
        let ccw = s.u.cross(&s.v).dot(&s.normal) > 0.0;
        let order: [usize; 6] = if ccw {
            [0, 1, 2, 0, 2, 3]
        } else {
            [0, 2, 1, 0, 3, 2]
        };
        out.extend(order.iter().map(|&i| q[i]));
    }
    for m in &scene.markers {
        let n = m.normal.normalize();
        let a = if n.x.abs() < 0.9 {
            Vector3::x()
        } else {
            Vector3::y()
        };
        let e1 = n.cross(&a).normalize();
        let e2 = n.cross(&e1); // (e1, e2, n) right-handed: counter-clockwise seen from n
        let c = m.drawn_center();
        let vert = |p: Vector3<f64>| Vertex {
            pos: f32x3(p),
            uv: [0.0, 0.0],
            layer: 0,
            shade: 1.0,
            plain: m.albedo.clamp(0.0, 1.0) as f32,
        };
        let rim = |k: usize| {
            let ang = std::f64::consts::TAU * k as f64 / MARKER_SIDES as f64;
            c + (e1 * ang.cos() + e2 * ang.sin()) * m.radius
        };
        for k in 0..MARKER_SIDES {
            out.extend([vert(c), vert(rim(k)), vert(rim(k + 1))]);
        }
    }
    out
}

pub(super) fn texture_2d(
    device: &wgpu::Device,
    label: &str,
    (width, height): (u32, u32),
    format: wgpu::TextureFormat,
    samples: u32,
    usage: wgpu::TextureUsages,
) -> wgpu::Texture {
    device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: samples,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage,
        view_formats: &[],
    })
}

pub(super) fn view(t: &wgpu::Texture) -> wgpu::TextureView {
    t.create_view(&wgpu::TextureViewDescriptor::default())
}
