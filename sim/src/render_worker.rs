//! Rendering on its own thread, one capture ahead of the consumer.
//!
//! The stream submits a capture's render job as soon as the capture is known (one frame before
//! it is emitted), so rendering overlaps with whatever the consumer does with the previous frame
//! (tracking, estimation). Jobs are answered in submission order; the images are exactly those a
//! synchronous render would produce (same inputs, same renderer), so the stream stays
//! deterministic.

use std::sync::mpsc::{Receiver, Sender, channel};
use std::thread::JoinHandle;
use std::time::Instant;

use estimator::geometry::Pose;

use crate::render::{ImageFrame, RenderError, Renderer};

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

/// A render result and the wall time it took (s; for timing reports only).
pub(crate) type RenderResult = (Result<ImageFrame, RenderError>, f64);

/// The renderer on a worker thread.
#[derive(Debug)]
pub(crate) struct RenderWorker {
    jobs: Option<Sender<RenderJob>>,
    results: Receiver<RenderResult>,
    thread: Option<JoinHandle<()>>,
    /// Settings the stream needs without the renderer: exposure offsets, black-frame sizes and
    /// whether depth is rendered.
    pub exposure_offsets_ns: Vec<i64>,
    /// Image size per camera.
    pub image_sizes: Vec<(u32, u32)>,
    /// Depth images rendered too.
    pub depth: bool,
}

impl RenderWorker {
    /// Moves `renderer` onto a new thread.
    pub(crate) fn spawn(mut renderer: Renderer, cameras: usize) -> Self {
        let exposure_offsets_ns = renderer.exposure_offsets_ns();
        let image_sizes = (0..cameras).map(|c| renderer.image_size(c)).collect();
        let depth = renderer.config().depth;
        let (job_tx, job_rx) = channel::<RenderJob>();
        let (res_tx, res_rx) = channel::<RenderResult>();
        let thread = std::thread::Builder::new()
            .name("vio-render".into())
            .spawn(move || {
                for job in job_rx {
                    let start = Instant::now();
                    let out = renderer.render(
                        job.t_capture_ns,
                        job.stamp_ns,
                        job.frame_index,
                        &job.poses_w_b,
                        &job.live,
                    );
                    if res_tx.send((out, start.elapsed().as_secs_f64())).is_err() {
                        break;
                    }
                }
            })
            .expect("spawning the render thread");
        Self {
            jobs: Some(job_tx),
            results: res_rx,
            thread: Some(thread),
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
        self.jobs = None;
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}
