//! Where each thread is in the FMU, on a page shared with a supervising process.
//!
//! A foreign FMU may crash the process or never return. The CLI therefore runs the work in a
//! child process; before each FMI call the child writes which function it calls and at what
//! simulation time into its thread's slot of a small memory-mapped file, and clears the
//! "in call" mark when the call returns. When the child dies from a signal, the supervisor reads
//! the slot still in a call and names it ("crashed in fmi2DoStep at t = 0.51 s"); when a slot
//! stays in the same call longer than the timeout, the supervisor ends the child and names the
//! call. Each mark is two relaxed atomic stores, so the watch costs nothing measurable; without
//! [`attach`] (library use, tests) marks are no-ops.

use memmap2::{MmapMut, MmapOptions};
use std::cell::Cell;
use std::fs::OpenOptions;
use std::io::Write;
use std::os::unix::ffi::OsStrExt;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering::Relaxed};
use std::sync::OnceLock;

/// Threads tracked; further threads share the last slot.
pub const SLOTS: usize = 64;
/// Words per slot: sequence number, call (with the in-call bit), time (f64 bits), spare.
const WORDS: usize = 4;
/// Size of the shared file.
pub const FILE_BYTES: usize = SLOTS * WORDS * 8;
const IN_CALL: u64 = 1 << 63;
/// Set with [`IN_CALL`] when the call is to an FMI 3.0 binary: the same [`Call`]s, named `fmi3*`.
const FMI3: u64 = 1 << 62;
const NO_TIME: u64 = u64::MAX;

/// The FMI functions (and library loading) a slot can name.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u64)]
pub enum Call {
    /// dlopen of the binary (its initialisers run).
    Load = 1,
    /// fmi2Instantiate
    Instantiate,
    /// fmi2SetupExperiment
    SetupExperiment,
    /// fmi2EnterInitializationMode
    EnterInitializationMode,
    /// fmi2ExitInitializationMode
    ExitInitializationMode,
    /// fmi2DoStep
    DoStep,
    /// fmi2Get{Real,Integer,Boolean,String}
    Get,
    /// fmi2Set{Real,Integer,Boolean,String}
    Set,
    /// fmi2Terminate
    Terminate,
    /// fmi2Reset
    Reset,
    /// fmi2FreeInstance
    FreeInstance,
    /// fmi2GetFMUstate, fmi2SetFMUstate, (de)serialization, fmi2FreeFMUstate
    FmuState,
    /// Any other FMI function.
    Other,
    /// fmi2SetTime
    SetTime,
    /// fmi2SetContinuousStates
    SetContinuousStates,
    /// fmi2GetContinuousStates
    GetContinuousStates,
    /// fmi2GetDerivatives
    GetDerivatives,
    /// fmi2GetEventIndicators
    GetEventIndicators,
    /// fmi2EnterEventMode
    EnterEventMode,
    /// fmi2NewDiscreteStates
    NewDiscreteStates,
    /// fmi2EnterContinuousTimeMode
    EnterContinuousTimeMode,
    /// fmi2CompletedIntegratorStep
    CompletedIntegratorStep,
    /// fmi2GetNominalsOfContinuousStates
    GetNominals,
    /// fmi2GetDirectionalDerivative
    DirectionalDerivative,
    /// The host's own Model Exchange integration between FMU calls (the time is the last one
    /// an FMU call was marked with).
    HostIntegration,
}

impl Call {
    /// The function's name as users read it.
    pub fn name(self) -> &'static str {
        match self {
            Call::Load => "loading the binary",
            Call::Instantiate => "fmi2Instantiate",
            Call::SetupExperiment => "fmi2SetupExperiment",
            Call::EnterInitializationMode => "fmi2EnterInitializationMode",
            Call::ExitInitializationMode => "fmi2ExitInitializationMode",
            Call::DoStep => "fmi2DoStep",
            Call::Get => "fmi2Get*",
            Call::Set => "fmi2Set*",
            Call::Terminate => "fmi2Terminate",
            Call::Reset => "fmi2Reset",
            Call::FreeInstance => "fmi2FreeInstance",
            Call::FmuState => "an FMU-state function",
            Call::Other => "an FMI function",
            Call::SetTime => "fmi2SetTime",
            Call::SetContinuousStates => "fmi2SetContinuousStates",
            Call::GetContinuousStates => "fmi2GetContinuousStates",
            Call::GetDerivatives => "fmi2GetDerivatives",
            Call::GetEventIndicators => "fmi2GetEventIndicators",
            Call::EnterEventMode => "fmi2EnterEventMode",
            Call::NewDiscreteStates => "fmi2NewDiscreteStates",
            Call::EnterContinuousTimeMode => "fmi2EnterContinuousTimeMode",
            Call::CompletedIntegratorStep => "fmi2CompletedIntegratorStep",
            Call::GetNominals => "fmi2GetNominalsOfContinuousStates",
            Call::DirectionalDerivative => "fmi2GetDirectionalDerivative",
            Call::HostIntegration => "the host's Model Exchange integration",
        }
    }

    fn from_word(w: u64) -> Option<Call> {
        const ALL: [Call; 25] = [
            Call::SetTime,
            Call::SetContinuousStates,
            Call::GetContinuousStates,
            Call::GetDerivatives,
            Call::GetEventIndicators,
            Call::EnterEventMode,
            Call::NewDiscreteStates,
            Call::EnterContinuousTimeMode,
            Call::CompletedIntegratorStep,
            Call::GetNominals,
            Call::DirectionalDerivative,
            Call::HostIntegration,
            Call::Load,
            Call::Instantiate,
            Call::SetupExperiment,
            Call::EnterInitializationMode,
            Call::ExitInitializationMode,
            Call::DoStep,
            Call::Get,
            Call::Set,
            Call::Terminate,
            Call::Reset,
            Call::FreeInstance,
            Call::FmuState,
            Call::Other,
        ];
        ALL.into_iter().find(|c| *c as u64 == w & !(IN_CALL | FMI3))
    }
}

static PAGE: OnceLock<&'static [AtomicU64]> = OnceLock::new();
/// Where this process lists the temporary output files it creates (see [`register_output`]).
static OUTPUTS: OnceLock<PathBuf> = OnceLock::new();
static NEXT_SLOT: AtomicUsize = AtomicUsize::new(0);
thread_local! {
    static SLOT: Cell<Option<usize>> = const { Cell::new(None) };
}

/// Maps the supervisor's file (made by [`Monitor::create`]) for this process's marks.
pub fn attach(path: &Path) -> std::io::Result<()> {
    let file = OpenOptions::new().read(true).write(true).open(path)?;
    if file.metadata()?.len() < FILE_BYTES as u64 {
        return Err(std::io::Error::other("watch file too short"));
    }
    // SAFETY: the file has FILE_BYTES bytes (checked by map_mut's length) and is only ever
    // accessed through atomics, here and in the supervisor.
    let map: MmapMut = unsafe { MmapOptions::new().len(FILE_BYTES).map_mut(&file)? };
    let map: &'static mut MmapMut = Box::leak(Box::new(map));
    // SAFETY: the mapping is page-aligned, FILE_BYTES long and lives for the process.
    let words =
        unsafe { std::slice::from_raw_parts(map.as_mut_ptr().cast::<AtomicU64>(), FILE_BYTES / 8) };
    let _ = PAGE.set(words);
    let _ = OUTPUTS.set(outputs_list(path));
    Ok(())
}

/// The list of temporary output files beside the watch file at `watch`.
fn outputs_list(watch: &Path) -> PathBuf {
    watch.with_extension("outputs")
}

/// Records that this process is about to create the temporary output file `path` (outside the
/// supervisor's scratch directory, next to the file it will replace), before it exists: when the
/// process dies before renaming it (Ctrl-C while writing, SIGKILL), the supervisor removes it
/// ([`remove_outputs`]). Without [`attach`] nothing is recorded.
pub fn register_output(path: &Path) -> std::io::Result<()> {
    let Some(list) = OUTPUTS.get() else {
        return Ok(());
    };
    let mut entry = path.as_os_str().as_bytes().to_vec();
    entry.push(0);
    // One write(2) of the whole entry to a file opened for appending: the supervisor reads
    // whole entries even if this process dies right after.
    OpenOptions::new()
        .create(true)
        .append(true)
        .open(list)?
        .write_all(&entry)
}

/// Records that this process has written all its results: whatever happens after (an FMU that
/// crashes while being freed), the supervisor knows the run's output is complete
/// ([`results_written`]). Without [`attach`] nothing is recorded.
pub fn mark_results_written() -> std::io::Result<()> {
    match OUTPUTS.get() {
        Some(list) => std::fs::write(list.with_extension("written"), b""),
        None => Ok(()),
    }
}

/// The supervisor's side of [`mark_results_written`] for the child of the watch file `watch`.
pub fn results_written(watch: &Path) -> bool {
    outputs_list(watch).with_extension("written").exists()
}

/// The supervisor's side of [`register_output`]: removes every listed file the child of the
/// watch file `watch` left behind (a completed output was renamed away and is not touched).
pub fn remove_outputs(watch: &Path) {
    let Ok(list) = std::fs::read(outputs_list(watch)) else {
        return;
    };
    for entry in list.split(|b| *b == 0).filter(|e| !e.is_empty()) {
        let path = Path::new(std::ffi::OsStr::from_bytes(entry));
        let _ = std::fs::remove_file(path);
    }
}

fn slot(page: &'static [AtomicU64]) -> &'static [AtomicU64] {
    let i = SLOT.with(|s| match s.get() {
        Some(i) => i,
        None => {
            let i = NEXT_SLOT.fetch_add(1, Relaxed).min(SLOTS - 1);
            s.set(Some(i));
            i
        }
    });
    &page[i * WORDS..(i + 1) * WORDS]
}

/// Marks the calling thread as inside `call` (at simulation time `t` when known) until the
/// returned guard is dropped.
#[must_use = "the call is marked as finished when the guard drops"]
pub fn enter(call: Call, t: Option<f64>) -> Guard {
    mark(call as u64, t)
}

/// [`enter`] for a call to an FMI 3.0 binary (the supervisor names it `fmi3DoStep`, ...).
#[must_use = "the call is marked as finished when the guard drops"]
pub fn enter3(call: Call, t: Option<f64>) -> Guard {
    mark(call as u64 | FMI3, t)
}

fn mark(word: u64, t: Option<f64>) -> Guard {
    let Some(page) = PAGE.get() else {
        return Guard(None);
    };
    let s = slot(page);
    s[0].fetch_add(1, Relaxed);
    if let Some(t) = t {
        s[2].store(t.to_bits(), Relaxed);
    }
    let outer = s[1].swap(word | IN_CALL, Relaxed);
    Guard(Some((s, outer)))
}

/// Restores its slot's mark as it was before [`enter`] when dropped: cleared, or the enclosing
/// mark when calls nest (an FMU call inside the host's integration loop).
pub struct Guard(Option<(&'static [AtomicU64], u64)>);

impl Drop for Guard {
    fn drop(&mut self) {
        if let Some((s, outer)) = self.0 {
            s[1].store(outer, Relaxed);
        }
    }
}

/// A thread inside an FMU call, as the supervisor sees it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InCall {
    /// The slot (one per thread).
    pub slot: usize,
    /// Calls entered on that thread so far: unchanged means the same call.
    pub seq: u64,
    /// The function.
    pub call: Call,
    /// The simulation time of the last fmi2DoStep (or setup), if any.
    pub time: Option<f64>,
    /// The call is to an FMI 3.0 binary.
    pub fmi3: bool,
}

impl std::fmt::Display for InCall {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.fmi3 {
            // FMI 3.0 renamed two of the Model Exchange functions.
            match self.call {
                Call::GetDerivatives => write!(f, "fmi3GetContinuousStateDerivatives")?,
                Call::NewDiscreteStates => write!(f, "fmi3UpdateDiscreteStates")?,
                call => write!(f, "{}", call.name().replacen("fmi2", "fmi3", 1))?,
            }
        } else {
            write!(f, "{}", self.call.name())?;
        }
        if let Some(t) = self.time {
            write!(f, " at t = {t} s")?;
        }
        Ok(())
    }
}

/// The supervisor's side: creates the shared file and reads the slots.
pub struct Monitor {
    map: MmapMut,
}

impl Monitor {
    /// Creates the shared file at `path` (zeroed, [`FILE_BYTES`] long) and maps it.
    pub fn create(path: &Path) -> std::io::Result<Monitor> {
        let file = OpenOptions::new()
            .read(true)
            .write(true)
            .create_new(true)
            .open(path)?;
        file.set_len(FILE_BYTES as u64)?;
        // SAFETY: as in `attach`; the child writes only through atomics.
        let mut map = unsafe { MmapOptions::new().len(FILE_BYTES).map_mut(&file)? };
        for w in map.chunks_mut(8).skip(2).step_by(WORDS) {
            w.copy_from_slice(&NO_TIME.to_ne_bytes());
        }
        Ok(Monitor { map })
    }

    /// Every thread currently inside a call, most recently entered first.
    pub fn in_calls(&self) -> Vec<InCall> {
        // SAFETY: page-aligned mapping of FILE_BYTES bytes, accessed through atomics only.
        let words = unsafe {
            std::slice::from_raw_parts(self.map.as_ptr().cast::<AtomicU64>(), FILE_BYTES / 8)
        };
        let mut found: Vec<InCall> = words
            .chunks(WORDS)
            .enumerate()
            .filter_map(|(slot, w)| {
                let word = w[1].load(Relaxed);
                if word & IN_CALL == 0 {
                    return None;
                }
                let t = w[2].load(Relaxed);
                Some(InCall {
                    slot,
                    seq: w[0].load(Relaxed),
                    call: Call::from_word(word)?,
                    time: (t != NO_TIME).then(|| f64::from_bits(t)),
                    fmi3: word & FMI3 != 0,
                })
            })
            .collect();
        found.sort_by_key(|c| std::cmp::Reverse(c.seq));
        found
    }
}

#[cfg(test)]
mod tests {
    use super::{attach, enter, enter3, Call, InCall, Monitor, FMI3, IN_CALL};

    #[test]
    fn model_exchange_calls_are_named_as_each_version_names_them() {
        let at = |call, fmi3| {
            InCall {
                slot: 0,
                seq: 0,
                call,
                time: Some(0.5),
                fmi3,
            }
            .to_string()
        };
        assert_eq!(
            at(Call::GetDerivatives, false),
            "fmi2GetDerivatives at t = 0.5 s"
        );
        assert_eq!(
            at(Call::GetDerivatives, true),
            "fmi3GetContinuousStateDerivatives at t = 0.5 s"
        );
        assert_eq!(
            at(Call::NewDiscreteStates, true),
            "fmi3UpdateDiscreteStates at t = 0.5 s"
        );
        assert_eq!(at(Call::SetTime, true), "fmi3SetTime at t = 0.5 s");
        for w in 1..=25 {
            let call = Call::from_word(w).expect("every call has a word");
            assert_eq!(Call::from_word(call as u64 | IN_CALL | FMI3), Some(call));
        }
    }

    #[test]
    fn a_call_in_progress_is_seen_with_its_time_and_cleared_on_return() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("watch");
        let monitor = Monitor::create(&path).unwrap();
        attach(&path).unwrap();
        assert!(monitor.in_calls().is_empty());
        let g = enter(Call::DoStep, Some(0.25));
        let seen = monitor.in_calls();
        assert_eq!(seen.len(), 1);
        assert_eq!((seen[0].call, seen[0].time), (Call::DoStep, Some(0.25)));
        assert_eq!(seen[0].to_string(), "fmi2DoStep at t = 0.25 s");
        drop(g);
        assert!(monitor.in_calls().is_empty());
        let g = enter3(Call::DoStep, Some(0.5));
        assert_eq!(monitor.in_calls()[0].to_string(), "fmi3DoStep at t = 0.5 s");
        drop(g);
        // another thread gets its own slot
        let h = std::thread::spawn(|| {
            let _g = enter(Call::Instantiate, None);
            std::thread::sleep(std::time::Duration::from_millis(50));
        });
        std::thread::sleep(std::time::Duration::from_millis(20));
        let seen = monitor.in_calls();
        assert_eq!(seen.len(), 1);
        assert_eq!((seen[0].call, seen[0].time), (Call::Instantiate, None));
        h.join().unwrap();
    }
}
