//! Rendering on its own threads, [`RenderWorker::STAGES`] captures ahead of the consumer.
//!
//! Two stages, each on its own thread: the scene passes drawn and read back (`vio-render`), and
//! the camera images formed from what was read back (`vio-form`: remap, blur, noise). The stream
//! submits a capture's job as soon as the capture is known, so the rasterizer draws frame k + 2
//! while frame k + 1 is formed and the consumer tracks and estimates frame k. Jobs are answered in
//! submission order; the images are exactly those a synchronous [`Renderer::render`] produces
//! (same inputs, same renderer), so the stream stays deterministic.

use std::sync::mpsc::{Receiver, Sender, channel};
use std::thread::JoinHandle;
use std::time::Instant;

use estimator::geometry::Pose;

use crate::render::{ImageFrame, Readback, RenderError, Renderer};

/// One capture to render.
#[derive(Debug)]
pub(crate) struct RenderJob {
    /// True capture time (ns).
    pub t_capture_ns: i64,
    /// Stamp written into the frame (ns).
    pub stamp_ns: i64,
    /// Frame index (selects the noise).
    pub frame_index: u64,
    /// Body poses at the exposure offsets.
    pub poses_w_b: Vec<Pose>,
    /// Cameras to render.
    pub live: Vec<usize>,
}

/// A render result and the wall time it took, both stages (s; for timing reports only).
pub(crate) type RenderResult = (Result<ImageFrame, RenderError>, f64);

/// A read-back frame on its way to the forming thread, and the time drawing it took (s).
type ReadbackResult = (Result<Readback, RenderError>, f64);

/// The renderer on a worker thread.
#[derive(Debug)]
pub(crate) struct RenderWorker {
    jobs: Option<Sender<RenderJob>>,
    results: Receiver<RenderResult>,
    threads: Vec<JoinHandle<()>>,
    /// Settings the stream needs without the renderer: exposure offsets, black-frame sizes and
    /// whether depth is rendered.
    pub exposure_offsets_ns: Vec<i64>,
    /// Image size per camera.
    pub image_sizes: Vec<(u32, u32)>,
    /// Depth images rendered too.
    pub depth: bool,
}

impl RenderWorker {
    /// Captures in flight at once for the stages to overlap: one drawn, one formed.
    pub(crate) const STAGES: usize = 2;

    /// Moves `renderer` onto a new thread, its image formation onto another.
    pub(crate) fn spawn(mut renderer: Renderer, cameras: usize) -> Self {
        let exposure_offsets_ns = renderer.exposure_offsets_ns();
        let image_sizes = (0..cameras).map(|c| renderer.image_size(c)).collect();
        let depth = renderer.config().depth;
        let formation = renderer.formation();
        let (job_tx, job_rx) = channel::<RenderJob>();
        let (drawn_tx, drawn_rx) = channel::<ReadbackResult>();
        let (res_tx, res_rx) = channel::<RenderResult>();
        let draw = std::thread::Builder::new()
            .name("vio-render".into())
            .spawn(move || {
                for job in job_rx {
                    let start = Instant::now();
                    let out = renderer.read_back(
                        job.t_capture_ns,
                        job.stamp_ns,
                        job.frame_index,
                        &job.poses_w_b,
                        &job.live,
                    );
                    if drawn_tx.send((out, start.elapsed().as_secs_f64())).is_err() {
                        break;
                    }
                }
            })
            .expect("spawning the render thread");
        let form = std::thread::Builder::new()
            .name("vio-form".into())
            .spawn(move || {
                for (drawn, draw_s) in drawn_rx {
                    let start = Instant::now();
                    let out = drawn.map(|frame| formation.form(&frame));
                    let seconds = draw_s + start.elapsed().as_secs_f64();
                    if res_tx.send((out, seconds)).is_err() {
                        break;
                    }
                }
            })
            .expect("spawning the image formation thread");
        Self {
            jobs: Some(job_tx),
            results: res_rx,
            threads: vec![draw, form],
            exposure_offsets_ns,
            image_sizes,
            depth,
        }
    }

    /// Queues a job.
    pub(crate) fn submit(&self, job: RenderJob) {
        if let Some(tx) = &self.jobs {
            // A closed channel means the thread is gone; `receive` then reports it.
            let _ = tx.send(job);
        }
    }

    /// The result of the oldest job not yet received (blocks until it is rendered).
    pub(crate) fn receive(&self) -> RenderResult {
        self.results.recv().unwrap_or_else(|_| {
            (
                Err(RenderError::Gpu("the render thread stopped".into())),
                0.0,
            )
        })
    }
}

impl Drop for RenderWorker {
    fn drop(&mut self) {
        // Closing the job channel ends the drawing thread, whose end closes the forming
        // thread's input.
        self.jobs = None;
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
    }
}
