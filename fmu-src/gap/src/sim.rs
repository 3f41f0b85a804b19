//! The simulator the workflow drives, and a wrapper that counts simulations, measures the wall
//! time during which at least one simulation runs (the "simulate" share of the timing split), and
//! remembers the last few results: the workflow asks for the same settings again (the optimum of
//! a fit is simulated by the roughness check, the interval ends and the final outputs), about one
//! simulation in fifteen. A simulation is deterministic in its settings, so a remembered result
//! is the result; the memory is a short list bounded by the values it holds, because the repeats
//! come soon after the first run.

use crate::spec::ParamSpec;
use std::collections::VecDeque;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

/// A model that can be simulated on the measured time grid. Implementations hold the measured
/// inputs and the time grid; `simulate` must be callable from several threads at once.
pub trait GridModel: Sync {
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

/// Most output values the memory of recent results holds (32 MB).
const MEMORY_VALUES: usize = 4 << 20;

/// Settings exactly as asked for (values by their bits, so that -0.0 and 0.0 differ).
type Key = Vec<(usize, u64)>;

/// One remembered result: its settings, its length in samples, its outputs.
type Remembered = (Key, usize, Vec<Vec<f64>>);

/// Counts simulations and the wall time during which any is running, and remembers recent
/// results (see the module documentation).
pub struct Counted<'a, S: GridModel + ?Sized> {
    pub inner: &'a S,
    active: AtomicUsize,
    count: AtomicUsize,
    busy_ns: AtomicU64,
    since: Mutex<Option<Instant>>,
    memory: Mutex<VecDeque<Remembered>>,
}

impl<'a, S: GridModel + ?Sized> Counted<'a, S> {
    pub fn new(inner: &'a S) -> Self {
        Counted {
            inner,
            active: AtomicUsize::new(0),
            count: AtomicUsize::new(0),
            busy_ns: AtomicU64::new(0),
            since: Mutex::new(None),
            memory: Mutex::new(VecDeque::new()),
        }
    }

    /// A remembered result of the same settings over the same samples. (Not a longer run's
    /// start: an FMU is told the stop time, and may use it.)
    fn recall(&self, key: &Key, n: usize) -> Option<Vec<Vec<f64>>> {
        let mem = self.memory.lock().unwrap_or_else(|e| e.into_inner());
        let (_, _, out) = mem.iter().find(|(k, len, _)| k == key && *len == n)?;
        Some(out.clone())
    }

    /// Remember a result, forgetting the oldest beyond [`MEMORY_VALUES`].
    fn remember(&self, key: Key, n: usize, out: &[Vec<f64>]) {
        let size = |o: &[Vec<f64>]| o.iter().map(Vec::len).sum::<usize>();
        if size(out) > MEMORY_VALUES {
            return;
        }
        let mut mem = self.memory.lock().unwrap_or_else(|e| e.into_inner());
        mem.retain(|(k, len, _)| !(k == &key && *len == n));
        mem.push_back((key, n, out.to_vec()));
        while mem.iter().map(|(_, _, o)| size(o)).sum::<usize>() > MEMORY_VALUES {
            mem.pop_front();
        }
    }

    /// Simulate through the wrapped simulator (or recall the same simulation's result),
    /// accounting for the time.
    pub fn simulate(&self, set: &[(usize, f64)], n: usize) -> Result<Vec<Vec<f64>>, SimError> {
        let key: Key = set.iter().map(|&(i, v)| (i, v.to_bits())).collect();
        if let Some(out) = self.recall(&key, n) {
            return Ok(out);
        }
        let out = self.simulate_now(set, n);
        if let Ok(o) = &out {
            self.remember(key, n, o);
        }
        out
    }

    /// Run one simulation, accounting for the time.
    fn simulate_now(&self, set: &[(usize, f64)], n: usize) -> Result<Vec<Vec<f64>>, SimError> {
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
    /// samples each: see [`select_outputs`].
    pub fn measured(
        &self,
        set: &[(usize, f64)],
        n: usize,
        out_idx: &[usize],
    ) -> Result<Vec<Vec<f64>>, SimError> {
        select_outputs(self.inner, self.simulate(set, n)?, n, out_idx)
    }

    /// Number of simulations run (a recalled result is not counted).
    pub fn count(&self) -> usize {
        self.count.load(Ordering::SeqCst)
    }

    /// Wall seconds during which at least one simulation was running.
    pub fn busy_s(&self) -> f64 {
        self.busy_ns.load(Ordering::SeqCst) as f64 * 1e-9
    }
}

/// The outputs `out_idx` (indices into `model.output_names()`) of the simulation `all`, first
/// `n` samples each; an error names a missing output, a short column or the first non-finite
/// sample (a simulation that produced one is no evidence to fit).
pub fn select_outputs<S: GridModel + ?Sized>(
    model: &S,
    all: Vec<Vec<f64>>,
    n: usize,
    out_idx: &[usize],
) -> Result<Vec<Vec<f64>>, SimError> {
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
                let output = model.output_names()[k].clone();
                return Err(SimError::NonFinite { output, sample });
            }
            Ok(v[..n].to_vec())
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::{Counted, GridModel, SimError, MEMORY_VALUES};
    use crate::spec::ParamSpec;
    use std::sync::atomic::{AtomicUsize, Ordering};

    /// Outputs `[p0 + i]` for sample i, counting its runs.
    struct Ramp {
        runs: AtomicUsize,
    }
    impl GridModel for Ramp {
        fn params(&self) -> &[ParamSpec] {
            &[]
        }
        fn output_names(&self) -> &[String] {
            &[]
        }
        fn simulate(&self, set: &[(usize, f64)], n: usize) -> Result<Vec<Vec<f64>>, SimError> {
            self.runs.fetch_add(1, Ordering::SeqCst);
            let p = set.first().map_or(0.0, |s| s.1);
            Ok(vec![(0..n).map(|i| p + i as f64).collect()])
        }
    }

    #[test]
    fn a_repeated_simulation_is_recalled_and_anything_else_is_run() {
        let sim = Ramp {
            runs: AtomicUsize::new(0),
        };
        let c = Counted::new(&sim);
        let a = c.simulate(&[(0, 1.0)], 5).unwrap();
        assert_eq!(c.simulate(&[(0, 1.0)], 5).unwrap(), a);
        assert_eq!(sim.runs.load(Ordering::SeqCst), 1);
        // another value, another length, -0.0 against 0.0: each is run
        assert_eq!(c.simulate(&[(0, 2.0)], 5).unwrap()[0][0], 2.0);
        assert_eq!(c.simulate(&[(0, 1.0)], 4).unwrap()[0].len(), 4);
        c.simulate(&[(0, 0.0)], 5).unwrap();
        c.simulate(&[(0, -0.0)], 5).unwrap();
        assert_eq!(sim.runs.load(Ordering::SeqCst), 5);
        assert_eq!(c.count(), 5);
    }

    #[test]
    fn the_memory_forgets_the_oldest_beyond_its_bound() {
        let sim = Ramp {
            runs: AtomicUsize::new(0),
        };
        let c = Counted::new(&sim);
        let n = MEMORY_VALUES / 3 + 1;
        for p in [1.0, 2.0, 3.0] {
            c.simulate(&[(0, p)], n).unwrap();
        }
        // three results exceed the bound: the first is forgotten, the last two kept
        c.simulate(&[(0, 3.0)], n).unwrap();
        c.simulate(&[(0, 2.0)], n).unwrap();
        assert_eq!(sim.runs.load(Ordering::SeqCst), 3);
        c.simulate(&[(0, 1.0)], n).unwrap();
        assert_eq!(sim.runs.load(Ordering::SeqCst), 4);
    }
}
