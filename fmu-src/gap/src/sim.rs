//! The simulator the workflow drives, and a wrapper that counts simulations and measures the wall
//! time during which at least one simulation runs (the "simulate" share of the timing split).

use crate::spec::ParamSpec;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

/// A model that can be simulated on the measured time grid. Implementations hold the measured
/// inputs and the time grid; `simulate` must be callable from several threads at once.
pub trait Simulator: Sync {
    /// Every parameter that can be set before initialization.
    fn params(&self) -> &[ParamSpec];
    /// Names of every model output, in the order `simulate` returns them.
    fn output_names(&self) -> &[String];
    /// Simulate the first `n` samples of the time grid (the communication step is the sample
    /// interval) with the given parameters set (index into `params()`, value; Booleans 0/1), all
    /// others at their start values. Returns `out[k][i]`, output `k` at sample `i < n`.
    fn simulate(&self, set: &[(usize, f64)], n: usize) -> Result<Vec<Vec<f64>>, SimError>;
}

/// Why a simulation gave no usable outputs. Cloneable so that parallel refits can report it.
#[derive(Clone, Debug, thiserror::Error)]
pub enum SimError {
    /// The model itself failed (for an FMU: the host's message, which names the FMI function,
    /// the time and what the FMU logged).
    #[error("{0}")]
    Model(String),
    /// A model output the workflow needs was not recorded.
    #[error("output '{0}' not recorded")]
    MissingOutput(String),
    /// Fewer outputs or samples than asked for.
    #[error("the simulator returned {got} of {want} {what}")]
    Short {
        what: &'static str,
        got: usize,
        want: usize,
    },
    /// An output that is NaN or infinite.
    #[error("output '{output}' is not finite at sample {sample}")]
    NonFinite { output: String, sample: usize },
    /// Every start of an effect's refit failed; the first failure is the cause.
    #[error("refit of {effect} failed from every start: {cause}")]
    Refit {
        effect: String,
        cause: Box<SimError>,
    },
    /// The residual at the starting point of a fit is not finite.
    #[error("non-finite residual at the starting point of a fit")]
    NonFiniteStart,
}

impl From<host::HostError> for SimError {
    fn from(e: host::HostError) -> Self {
        SimError::Model(e.to_string())
    }
}

/// Counts simulations and the wall time during which any is running.
pub struct Counted<'a, S: Simulator + ?Sized> {
    pub inner: &'a S,
    active: AtomicUsize,
    count: AtomicUsize,
    busy_ns: AtomicU64,
    since: Mutex<Option<Instant>>,
}

impl<'a, S: Simulator + ?Sized> Counted<'a, S> {
    pub fn new(inner: &'a S) -> Self {
        Counted {
            inner,
            active: AtomicUsize::new(0),
            count: AtomicUsize::new(0),
            busy_ns: AtomicU64::new(0),
            since: Mutex::new(None),
        }
    }

    /// Simulate through the wrapped simulator, accounting for the time.
    pub fn simulate(&self, set: &[(usize, f64)], n: usize) -> Result<Vec<Vec<f64>>, SimError> {
        {
            let mut g = self.since.lock().unwrap_or_else(|e| e.into_inner());
            if self.active.fetch_add(1, Ordering::SeqCst) == 0 {
                *g = Some(Instant::now());
            }
        }
        let out = self.inner.simulate(set, n);
        {
            let mut g = self.since.lock().unwrap_or_else(|e| e.into_inner());
            if self.active.fetch_sub(1, Ordering::SeqCst) == 1 {
                if let Some(t0) = g.take() {
                    self.busy_ns
                        .fetch_add(t0.elapsed().as_nanos() as u64, Ordering::SeqCst);
                }
            }
        }
        self.count.fetch_add(1, Ordering::SeqCst);
        out
    }

    /// Simulate and return the outputs `out_idx` (indices into `output_names()`), first `n`
    /// samples each; an error names a missing output, a short column or the first non-finite
    /// sample.
    pub fn measured(
        &self,
        set: &[(usize, f64)],
        n: usize,
        out_idx: &[usize],
    ) -> Result<Vec<Vec<f64>>, SimError> {
        let all = self.simulate(set, n)?;
        out_idx
            .iter()
            .map(|&k| {
                let v = all.get(k).ok_or(SimError::Short {
                    what: "outputs",
                    got: all.len(),
                    want: k + 1,
                })?;
                if v.len() < n {
                    let (got, want) = (v.len(), n);
                    return Err(SimError::Short {
                        what: "samples",
                        got,
                        want,
                    });
                }
                if let Some(sample) = v[..n].iter().position(|x| !x.is_finite()) {
                    let output = self.inner.output_names()[k].clone();
                    return Err(SimError::NonFinite { output, sample });
                }
                Ok(v[..n].to_vec())
            })
            .collect()
    }

    /// Number of simulations run.
    pub fn count(&self) -> usize {
        self.count.load(Ordering::SeqCst)
    }

    /// Wall seconds during which at least one simulation was running.
    pub fn busy_s(&self) -> f64 {
        self.busy_ns.load(Ordering::SeqCst) as f64 * 1e-9
    }
}
