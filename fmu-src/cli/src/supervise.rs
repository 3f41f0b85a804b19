//! The commands that run FMU code do so in a child process of this program, supervised here.
//!
//! A foreign FMU may crash the process (SIGSEGV), hang in a call, or leave files behind. The
//! supervisor re-runs the same command line in a child (`--supervised WATCH`), with its own
//! scratch directory as the child's TMPDIR, so that every extraction and temporary file of the
//! child (and of validate's probe processes) lies under one directory the supervisor removes on
//! every exit path: success, error, crash, hang, Ctrl-C, SIGTERM, SIGHUP. The child marks each
//! FMI call in a shared page ([`host::watch`]); a crash is reported with the call and time it
//! happened in, and a call that does not return within the timeout ends the child.
//! The child's stdout and stderr are the user's, unchanged.

use crate::common::{CliError, CliResult};
use host::watch::{InCall, Monitor};
use std::collections::HashMap;
use std::os::unix::process::ExitStatusExt;
use std::path::Path;
use std::process::{Child, Command, ExitStatus};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// What the supervisor needs to know about the command.
pub struct Supervision {
    /// The FMU named in messages.
    pub fmu: String,
    /// Longest one FMU call may take; None: no limit.
    pub call_timeout: Option<Duration>,
}

/// Exit status after Ctrl-C / SIGTERM / SIGHUP (128 + SIGINT, as shells report it).
pub const EXIT_INTERRUPTED: i32 = 130;

/// Exit status of a run that completed and wrote its results, after which the FMU crashed (in
/// fmi2FreeInstance, say). Not 0: a crashing FMU is a defect a CI must see. Not 2 (bad input,
/// nothing written) nor 1 (the run failed): the output is complete and may be used.
pub const EXIT_CRASHED_AFTER_RESULTS: i32 = 3;

/// Runs this program's command line again as a supervised child and returns its exit status.
pub fn run(s: Supervision) -> CliResult {
    let scratch = tempfile::Builder::new()
        .prefix("actuator-fmu-")
        .tempdir()
        .map_err(|e| CliError::input(format!("cannot create a temporary directory: {e}")))?;
    let tmp = scratch.path().join("tmp");
    std::fs::create_dir(&tmp)
        .map_err(|e| CliError::input(format!("cannot create a temporary directory: {e}")))?;
    let watch_path = scratch.path().join("watch");
    let monitor = Monitor::create(&watch_path)
        .map_err(|e| CliError::input(format!("cannot create the watch file: {e}")))?;
    let interrupted = Arc::new(AtomicBool::new(false));
    let flag = interrupted.clone();
    // Fails only if a handler is already set (never in this program).
    let _ = ctrlc::set_handler(move || flag.store(true, Ordering::SeqCst));
    let exe = std::env::current_exe()
        .map_err(|e| CliError::input(format!("cannot find own executable: {e}")))?;
    let mut child = Command::new(exe)
        .arg("--supervised")
        .arg(&watch_path)
        .args(std::env::args_os().skip(1))
        .env("TMPDIR", &tmp)
        .spawn()
        .map_err(|e| CliError::input(format!("cannot start the worker process: {e}")))?;
    let outcome = watch(&mut child, (&monitor, &watch_path), &s, &interrupted);
    // The temporary output files the child made next to its outputs and did not rename (it was
    // interrupted or crashed while writing); then everything it left in the scratch directory.
    host::watch::remove_outputs(&watch_path);
    drop(scratch);
    outcome
}

/// Waits for the child, ending it on a hung call or a signal to this process.
fn watch(
    child: &mut Child,
    (monitor, watch_path): (&Monitor, &Path),
    s: &Supervision,
    interrupted: &AtomicBool,
) -> CliResult {
    let mut seen: HashMap<usize, (u64, Instant)> = HashMap::new();
    loop {
        match child.try_wait() {
            Ok(Some(status)) => {
                let written = host::watch::results_written(watch_path);
                return finished(status, (monitor, written), s, interrupted);
            }
            Ok(None) => {}
            Err(e) => return Err(CliError::input(format!("waiting for the worker: {e}"))),
        }
        if interrupted.load(Ordering::SeqCst) {
            end(child);
            return Err(interruption());
        }
        if let Some(limit) = s.call_timeout {
            if let Some(call) = hung(monitor, &mut seen, limit) {
                end(child);
                return Err(CliError::input(format!(
                    "{}: the FMU did not return from {call} within {} s (--timeout); it was \
                     stopped and nothing was written",
                    s.fmu,
                    limit.as_secs_f64()
                )));
            }
        }
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// A thread that has been in the same call for longer than `limit`.
fn hung(
    monitor: &Monitor,
    seen: &mut HashMap<usize, (u64, Instant)>,
    limit: Duration,
) -> Option<InCall> {
    let now = Instant::now();
    let calls = monitor.in_calls();
    seen.retain(|slot, _| calls.iter().any(|c| c.slot == *slot));
    for c in calls {
        let entry = seen.entry(c.slot).or_insert((c.seq, now));
        if entry.0 != c.seq {
            *entry = (c.seq, now);
        } else if now.duration_since(entry.1) > limit {
            return Some(c);
        }
    }
    None
}

fn end(child: &mut Child) {
    let _ = child.kill();
    let _ = child.wait();
}

fn interruption() -> CliError {
    CliError {
        code: EXIT_INTERRUPTED,
        message: "interrupted; temporary files removed, no output written".into(),
    }
}

/// The child's exit status, or a message for a child killed by a signal. `written`: the child
/// had written all its results before.
fn finished(
    status: ExitStatus,
    (monitor, written): (&Monitor, bool),
    s: &Supervision,
    interrupted: &AtomicBool,
) -> CliResult {
    let Some(sig) = status.signal() else {
        // The child printed its own message.
        return Ok(status.code().unwrap_or(1));
    };
    // SIGINT, SIGTERM, SIGHUP reach the child from the terminal or the process group.
    if interrupted.load(Ordering::SeqCst) || matches!(sig, 1 | 2 | 15) {
        return Err(interruption());
    }
    let name = signal_name(sig);
    if let (Some(call), true) = (monitor.in_calls().first(), written) {
        eprintln!(
            "actuator-fmu: warning: {}: the FMU crashed ({name}) in {call} after the run \
             completed; its results were written",
            s.fmu
        );
        return Ok(EXIT_CRASHED_AFTER_RESULTS);
    }
    Err(CliError::input(match monitor.in_calls().first() {
        Some(call) => format!(
            "{}: the FMU crashed ({name}) in {call}; nothing was written",
            s.fmu
        ),
        None => format!(
            "{}: the worker process ended with {name} outside any FMU call",
            s.fmu
        ),
    }))
}

/// The conventional name of a fatal signal.
pub fn signal_name(sig: i32) -> String {
    match sig {
        4 => "SIGILL".into(),
        6 => "SIGABRT".into(),
        7 => "SIGBUS".into(),
        8 => "SIGFPE".into(),
        9 => "SIGKILL".into(),
        11 => "SIGSEGV".into(),
        n => format!("signal {n}"),
    }
}
