//! The stop request of long commands (render, fit): Ctrl-C (SIGINT), SIGTERM (what schedulers such
//! as Slurm send at a time limit or on preemption, before SIGKILL) and SIGHUP (a closed terminal or
//! session) all set one flag; the command then saves what it can resume from and exits non-zero.
//! Uses the `ctrlc` crate's `termination` feature, which catches the three signals on one thread.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

/// Installs the handler and returns the flag it sets. A SIGHUP that the process inherited as
/// ignored (`nohup`) stays ignored. If the handler cannot be installed the flag never fires and a
/// warning says so: the command still runs, without a checkpoint on a signal. Installed once per
/// process: later calls (one per case of `btfpt check`) return the same flag.
pub fn stop_flag() -> Arc<AtomicBool> {
    static FLAG: std::sync::OnceLock<Arc<AtomicBool>> = std::sync::OnceLock::new();
    FLAG.get_or_init(install).clone()
}

fn install() -> Arc<AtomicBool> {
    let flag = Arc::new(AtomicBool::new(false));
    let hup_ignored = sighup_ignored();
    let f = flag.clone();
    match ctrlc::set_handler(move || f.store(true, Ordering::SeqCst)) {
        Ok(()) => {
            if hup_ignored {
                // SAFETY: SIG_IGN is a valid disposition; no handler state is touched.
                unsafe { libc::signal(libc::SIGHUP, libc::SIG_IGN) };
            }
        }
        Err(e) => eprintln!(
            "warning: cannot install the Ctrl-C/SIGTERM/SIGHUP handler ({e}); a signal will stop \
             without saving progress"
        ),
    }
    flag
}

/// Whether SIGHUP is currently ignored (inherited from `nohup` or a parent that ignores it).
fn sighup_ignored() -> bool {
    // SAFETY: a null new action only queries the current one into `old`.
    unsafe {
        let mut old: libc::sigaction = std::mem::zeroed();
        libc::sigaction(libc::SIGHUP, std::ptr::null(), &mut old) == 0
            && old.sa_sigaction == libc::SIG_IGN
    }
}
