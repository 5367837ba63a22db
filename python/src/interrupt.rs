//! Long work (render, fit, synth, eval) on a worker thread while the calling Python thread waits
//! with the GIL released and checks for Ctrl-C every 50 ms: on a KeyboardInterrupt the work's
//! stop flag is set, the worker finishes at its next safe point, and the KeyboardInterrupt is
//! raised. Also draws a one-line progress display on stderr when asked.

use pyo3::prelude::*;
use std::io::Write;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

/// Progress of the work: `done` of `total` units, named by `unit`.
pub struct Progress {
    pub done: AtomicU64,
    pub total: AtomicU64,
    pub label: String,
    pub unit: &'static str,
    pub show: bool,
}

impl Progress {
    /// A progress counter of `total` units.
    pub fn new(label: impl Into<String>, unit: &'static str, total: u64, show: bool) -> Self {
        Progress {
            done: AtomicU64::new(0),
            total: AtomicU64::new(total),
            label: label.into(),
            unit,
            show,
        }
    }

    fn draw(&self, start: Instant, last: bool) {
        if !self.show {
            return;
        }
        let (d, t) = (
            self.done.load(Ordering::Relaxed),
            self.total.load(Ordering::Relaxed),
        );
        let pct = if t > 0 {
            100.0 * d as f64 / t as f64
        } else {
            0.0
        };
        let mut e = std::io::stderr().lock();
        let _ = write!(
            e,
            "\r{}: {pct:5.1}% ({d}/{t} {}), {:.1} s{}",
            self.label,
            self.unit,
            start.elapsed().as_secs_f64(),
            if last { "\n" } else { "" }
        );
        let _ = e.flush();
    }
}

/// Runs `work(stop)` on a worker thread; see the module doc.
pub fn run<T: Send>(
    py: Python<'_>,
    progress: &Progress,
    work: impl FnOnce(&AtomicBool) -> T + Send,
) -> PyResult<T> {
    let stop = AtomicBool::new(false);
    let start = Instant::now();
    std::thread::scope(|s| {
        let worker = s.spawn(|| work(&stop));
        let mut last_draw = Instant::now();
        loop {
            let finished = py.detach(|| {
                let t0 = Instant::now();
                while !worker.is_finished() && t0.elapsed() < Duration::from_millis(50) {
                    std::thread::sleep(Duration::from_millis(2));
                }
                worker.is_finished()
            });
            if finished {
                break;
            }
            if let Err(e) = py.check_signals() {
                stop.store(true, Ordering::SeqCst);
                let _ = py.detach(|| worker.join());
                if progress.show {
                    eprintln!();
                }
                return Err(e);
            }
            if last_draw.elapsed() >= Duration::from_millis(250) {
                progress.draw(start, false);
                last_draw = Instant::now();
            }
        }
        let out = py.detach(|| worker.join());
        match out {
            Ok(v) => {
                progress.draw(start, true);
                Ok(v)
            }
            Err(_) => Err(pyo3::exceptions::PyRuntimeError::new_err(
                "btfpt: the worker thread panicked (a bug: please report it with the input)",
            )),
        }
    })
}
