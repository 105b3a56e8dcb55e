//! CPU work that runs on a thread of its own while the caller goes on drawing frames (a PDSM's
//! construction in the viewer): the caller polls it once per frame and reports its progress.
//!
//! Each job counts its progress in a [`BuildControl`] of its own, so a job superseded by other
//! inputs (and cancelled) never moves the progress of the one that replaces it; the caller copies
//! the job's progress to the control it shares with its watchers ([`BackgroundJob::report_to`]).

use std::thread::JoinHandle;

use crate::BuildControl;

/// A job running on its own thread, yielding a `T`.
pub struct BackgroundJob<T> {
    control: BuildControl,
    handle: JoinHandle<T>,
}

/// The job's thread panicked (a bug); its message is in the log.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Panicked;

impl<T: Send + 'static> BackgroundJob<T> {
    /// Starts `work` on a thread called `name`, counting `total` units of `unit` in the control
    /// it is given (`done` moves as the work goes; the work should stop early once
    /// `control.is_cancelled()`).
    pub fn spawn(
        name: &str,
        total: u32,
        unit: &'static str,
        work: impl FnOnce(&BuildControl) -> T + Send + 'static,
    ) -> std::io::Result<Self> {
        let control = BuildControl::default();
        control.start(total, unit);
        let thread_control = control.clone();
        let handle = std::thread::Builder::new()
            .name(name.into())
            .spawn(move || work(&thread_control))?;
        Ok(Self { control, handle })
    }

    /// Asks the job to stop at its next unit; its result, if any, should then be dropped.
    pub fn cancel(&self) {
        self.control.cancel();
    }

    /// `(done, total)` so far.
    pub fn progress(&self) -> (u32, u32) {
        self.control.progress().unwrap_or((0, 0))
    }

    /// Copies the job's progress to `shared` (the control the caller's watchers see).
    pub fn report_to(&self, shared: &BuildControl) {
        let (done, _) = self.progress();
        shared
            .done
            .store(done, std::sync::atomic::Ordering::Relaxed);
    }

    /// Whether the job has ended (its result is ready to take).
    pub fn is_finished(&self) -> bool {
        self.handle.is_finished()
    }

    /// The job's result once it has ended (waits for it otherwise), or [`Panicked`].
    pub fn join(self) -> Result<T, Panicked> {
        self.handle.join().map_err(|_| Panicked)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_job_reports_progress_stops_when_cancelled_and_yields_its_result() {
        let job = BackgroundJob::spawn("test job", 10, "units", |control| {
            for k in 0..10 {
                if control.is_cancelled() {
                    return Err(k);
                }
                control
                    .done
                    .store(k + 1, std::sync::atomic::Ordering::Relaxed);
            }
            Ok(10)
        })
        .unwrap();
        assert_eq!(job.join(), Ok(Ok(10)));

        let (tx, rx) = std::sync::mpsc::channel::<()>();
        let job = BackgroundJob::spawn("test job", 10, "units", move |control| {
            rx.recv().unwrap();
            if control.is_cancelled() {
                return Err(0);
            }
            Ok(1)
        })
        .unwrap();
        let shared = BuildControl::default();
        shared.start(10, "units");
        job.report_to(&shared);
        assert_eq!(shared.progress(), Some((0, 10)));
        job.cancel();
        tx.send(()).unwrap();
        assert_eq!(job.join(), Ok(Err(0)));

        let job = BackgroundJob::spawn("test job", 1, "units", |_| -> u32 { panic!("a bug") });
        assert_eq!(job.unwrap().join(), Err(Panicked));
    }
}
