//! A pipeline stage on its own thread: jobs go in, results come out in the order of the jobs,
//! and the stage's state comes back at the end. What the stage computes depends on the jobs and
//! their order alone, never on when they arrive, so a run that hands work to a stage gives the
//! same bytes as one that does the work in line; the caller decides how far ahead it submits.
//! The thread is scoped, so jobs may borrow what the caller's scope holds (a recording's
//! messages).

use std::sync::mpsc::{Receiver, Sender, channel};
use std::thread::{Scope, ScopedJoinHandle};

/// A worker thread owning a state `S`, turning jobs `J` into results `R` (`None`: the job
/// only updates the state, no result is sent).
pub(crate) struct Stage<'scope, S, J, R> {
    jobs: Option<Sender<J>>,
    results: Receiver<R>,
    thread: Option<ScopedJoinHandle<'scope, S>>,
}

impl<'scope, S, J, R> Stage<'scope, S, J, R>
where
    S: Send + 'scope,
    J: Send + 'scope,
    R: Send + 'scope,
{
    /// Starts the thread `name` in `scope` with `state`; each job runs `work` on the state.
    pub(crate) fn spawn<'env>(
        scope: &'scope Scope<'scope, 'env>,
        name: &str,
        mut state: S,
        mut work: impl FnMut(&mut S, J) -> Option<R> + Send + 'scope,
    ) -> Self {
        let (jobs, job_rx) = channel::<J>();
        let (result_tx, results) = channel();
        let thread = std::thread::Builder::new()
            .name(name.to_string())
            .spawn_scoped(scope, move || {
                for job in job_rx {
                    if let Some(r) = work(&mut state, job)
                        && result_tx.send(r).is_err()
                    {
                        break;
                    }
                }
                state
            })
            .expect("spawning a pipeline stage's thread");
        Self {
            jobs: Some(jobs),
            results,
            thread: Some(thread),
        }
    }
}

impl<S, J, R> Stage<'_, S, J, R> {
    /// Queues a job (never blocks).
    pub(crate) fn submit(&self, job: J) {
        // A send fails only when the thread has ended, which it does early only by panicking;
        // the next result or `finish` passes that panic on.
        if let Some(jobs) = &self.jobs {
            let _ = jobs.send(job);
        }
    }

    /// The next result, in job order; waits for it. Panics if no job left a result to wait for
    /// (a caller's bug) and passes on the stage's panic.
    pub(crate) fn next_result(&mut self) -> R {
        match self.results.recv() {
            Ok(r) => r,
            Err(_) => {
                self.jobs = None;
                match self.thread.take().map(ScopedJoinHandle::join) {
                    Some(Err(panic)) => std::panic::resume_unwind(panic),
                    _ => panic!("a pipeline stage was asked for a result no job makes"),
                }
            }
        }
    }

    /// Lets the stage run the jobs it holds, stops it and returns its state.
    pub(crate) fn finish(mut self) -> S {
        self.jobs = None;
        let thread = self.thread.take().expect("a stage finishes once");
        match thread.join() {
            Ok(state) => state,
            Err(panic) => std::panic::resume_unwind(panic),
        }
    }
}

impl<S, J, R> Drop for Stage<'_, S, J, R> {
    /// A stage dropped unfinished (a run that failed) stops after the jobs it holds.
    fn drop(&mut self) {
        self.jobs = None;
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn results_come_in_job_order_and_the_state_comes_back() {
        // The state counts the jobs; odd jobs only update it; jobs borrow the caller's data.
        let data: Vec<u64> = (100..110).collect();
        std::thread::scope(|scope| {
            let mut stage = Stage::spawn(scope, "test-stage", 0u64, |n: &mut u64, job: &u64| {
                *n += 1;
                job.is_multiple_of(2).then_some((*job, *n))
            });
            for job in &data {
                stage.submit(job);
            }
            let got: Vec<_> = (0..5).map(|_| stage.next_result()).collect();
            assert_eq!(got, vec![(100, 1), (102, 3), (104, 5), (106, 7), (108, 9)]);
            assert_eq!(stage.finish(), 10);
        });
    }

    #[test]
    #[should_panic(expected = "job 3 failed")]
    fn a_panic_in_the_stage_reaches_the_caller() {
        std::thread::scope(|scope| {
            let mut stage = Stage::spawn(scope, "test-stage", (), |_: &mut (), job: u32| {
                assert!(job != 3, "job {job} failed");
                Some(job)
            });
            for job in 0..5 {
                stage.submit(job);
            }
            for _ in 0..5 {
                stage.next_result();
            }
        });
    }
}
