use sim::render::{RenderConfig, Renderer};
use sim::{World, WorldConfig};
use std::time::Instant;
fn main() {
    let world = World::new(WorldConfig::default()).unwrap();
    let rig = world.config().rig.clone().unwrap();
    let mut cfg = RenderConfig::default();
    cfg.depth = std::env::args().any(|a| a == "depth");
    if std::env::args().any(|a| a == "blur") { cfg.motion_blur = Some(sim::render::MotionBlur{exposure_s: 0.01, samples: 4}); }
    if std::env::args().any(|a| a == "msaa") { cfg.msaa = true; }
    if std::env::args().any(|a| a == "tri") { cfg.trilinear = true; }
    if let Ok(v) = std::env::var("PINMAX") { cfg.max_pinhole_size = v.parse().unwrap(); }
    let t0 = Instant::now();
    let mut r = Renderer::new(world.scene(), &rig, &cfg, 1).unwrap();
    eprintln!("setup {:?} adapter {} pinhole {:?}", t0.elapsed(), r.adapter(), r.pinhole(0));
    let mut stream = world.stream();
    let offs = r.exposure_offsets_ns();
    fn cpu() -> f64 { let s = std::fs::read_to_string("/proc/self/stat").unwrap(); let f: Vec<&str> = s.rsplit(')').next().unwrap().split_whitespace().collect(); (f[11].parse::<f64>().unwrap() + f[12].parse::<f64>().unwrap()) / 100.0 }
    let c0 = cpu(); let w0 = Instant::now();
    for i in 0..40 {
        let t = 2_000_000_000 + i * 50_000_000i64;
        let poses: Vec<_> = offs.iter().map(|o| stream.truth(t + o).unwrap().pose).collect();
        let t1 = Instant::now();
        let f = r.render(t, t, i as u64, &poses, &[0, 1]).unwrap();
        let _ = t1;
        if i == 0 {
            for c in &f.cameras {
                let mut out = format!("P5\n{} {}\n255\n", c.image.width, c.image.height).into_bytes();
                out.extend(&c.image.data);
                std::fs::write(format!("/tmp/cam{}.pgm", c.cam_id), out).unwrap();
            }
        }
    }
    eprintln!("per frame: wall {:.2} ms, cpu {:.2} ms", w0.elapsed().as_secs_f64()*1e3/40.0, (cpu()-c0)*1e3/40.0);
}
