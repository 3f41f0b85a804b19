//! Concurrency check (instances of one FMU in parallel threads), using the project's `host` crate.
//!
//! For every FMU given: one [`host::Fmu`] (one loaded binary) shared by `--threads` threads; each
//! thread owns one instance of every FMU and drives it with its own inputs (a different
//! amplitude, frequency and phase per thread). First every scenario runs alone, one after the
//! other on the main thread; then all threads run at once (started together on a barrier, the
//! FMUs' steps interleaved), `--rounds` times. Every output at every step must have the same bits
//! as the lone run. Exit status 1 on any difference or failed call.
//!
//! usage: concurrency-driver [--threads N] [--steps N] [--rounds N] FMU...

use host::md::{Causality, VarKind};
use host::Fmu;
use std::sync::Barrier;

const H: f64 = 1e-3;

/// One scenario: its FMU, its thread number and what it records.
struct Scenario<'a> {
    fmu: &'a Fmu,
    inputs: Vec<(u32, f64, f64)>, // (vr, centre, amplitude)
    outputs: Vec<u32>,
    thread: usize,
}

impl Scenario<'_> {
    fn new(fmu: &Fmu, thread: usize) -> Scenario<'_> {
        let md = fmu.model_description();
        let inputs = md
            .model_variables
            .iter()
            .filter(|v| v.causality == Causality::Input && v.kind == VarKind::Real)
            .map(|v| {
                let start = v.start.as_ref().and_then(|s| s.as_f64()).unwrap_or(0.0);
                let (centre, amp) = match (v.min, v.max) {
                    (Some(lo), Some(hi)) => (0.5 * (lo + hi), 0.3 * (hi - lo)),
                    _ => (start, 0.5 * start.abs().max(1.0)),
                };
                (v.value_reference, centre, amp)
            })
            .collect();
        let outputs = md
            .model_variables
            .iter()
            .filter(|v| v.causality == Causality::Output && v.kind == VarKind::Real)
            .map(|v| v.value_reference)
            .collect();
        Scenario {
            fmu,
            inputs,
            outputs,
            thread,
        }
    }

    /// Input j of this thread at time t: centre + amplitude * (0.3 + 0.1 thread) * sin(...).
    fn input(&self, j: usize, t: f64) -> f64 {
        let (_, c, a) = self.inputs[j];
        let k = self.thread as f64;
        let w = 2.0 + 1.5 * k + 0.7 * j as f64;
        c + a * (0.3 + 0.08 * k) * (w * t + 0.4 * k).sin()
    }
}

/// A running simulation of one scenario: the instance and the recorded output bits.
struct Run<'a> {
    s: &'a Scenario<'a>,
    inst: host::Instance<'a>,
    bits: Vec<u64>,
    buf: Vec<f64>,
}

impl<'a> Run<'a> {
    fn start(s: &'a Scenario<'a>) -> Result<Run<'a>, String> {
        let e = |x: host::HostError| format!("{x}");
        let mut inst = s
            .fmu
            .instantiate(&format!("thread{}", s.thread))
            .map_err(e)?;
        inst.setup_experiment(None, 0.0, None).map_err(e)?;
        inst.enter_initialization_mode().map_err(e)?;
        inst.exit_initialization_mode().map_err(e)?;
        Ok(Run {
            s,
            inst,
            bits: Vec::new(),
            buf: vec![0.0; s.outputs.len()],
        })
    }

    fn step(&mut self, k: usize) -> Result<(), String> {
        let e = |x: host::HostError| format!("{x}");
        let t = k as f64 * H;
        let vrs: Vec<u32> = self.s.inputs.iter().map(|i| i.0).collect();
        let u: Vec<f64> = (0..vrs.len()).map(|j| self.s.input(j, t)).collect();
        self.inst.set_real(&vrs, &u).map_err(e)?;
        self.inst.do_step(t, H, true).map_err(e)?;
        self.inst
            .get_real(&self.s.outputs, &mut self.buf)
            .map_err(e)?;
        self.bits.extend(self.buf.iter().map(|x| x.to_bits()));
        Ok(())
    }
}

/// All scenarios of one thread, stepped interleaved; returns the output bits per scenario.
fn run_thread(scenarios: &[&Scenario], steps: usize) -> Result<Vec<Vec<u64>>, String> {
    let mut runs = scenarios
        .iter()
        .map(|s| Run::start(s))
        .collect::<Result<Vec<_>, _>>()?;
    for k in 0..steps {
        for r in runs.iter_mut() {
            r.step(k)?;
        }
    }
    Ok(runs.into_iter().map(|r| r.bits).collect())
}

fn main() {
    let mut threads = 8usize;
    let mut steps = 2000usize;
    let mut rounds = 2usize;
    let mut paths = Vec::new();
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        let mut num = |name: &str| -> usize {
            args.next()
                .and_then(|v| v.parse().ok())
                .unwrap_or_else(|| panic!("{name} needs a number"))
        };
        match a.as_str() {
            "--threads" => threads = num("--threads"),
            "--steps" => steps = num("--steps"),
            "--rounds" => rounds = num("--rounds"),
            _ => paths.push(a),
        }
    }
    if paths.is_empty() {
        eprintln!("usage: concurrency-driver [--threads N] [--steps N] [--rounds N] FMU...");
        std::process::exit(2);
    }
    let fmus: Vec<Fmu> = paths
        .iter()
        .map(|p| Fmu::open(p).unwrap_or_else(|e| panic!("cannot open {p}: {e}")))
        .collect();
    // scenarios[thread][fmu]
    let scenarios: Vec<Vec<Scenario>> = (0..threads)
        .map(|t| fmus.iter().map(|f| Scenario::new(f, t)).collect())
        .collect();

    // 1. every scenario alone, sequentially on this thread
    let t0 = std::time::Instant::now();
    let mut alone: Vec<Vec<Vec<u64>>> = Vec::new();
    for per_thread in &scenarios {
        let mut row = Vec::new();
        for s in per_thread {
            let bits = run_thread(&[s], steps).unwrap_or_else(|e| {
                eprintln!("lone run failed: {e}");
                std::process::exit(1)
            });
            row.push(bits.into_iter().next().unwrap());
        }
        alone.push(row);
    }
    let lone_time = t0.elapsed();

    // the threads really have different inputs: their lone results differ
    for f in 0..fmus.len() {
        for t in 1..threads {
            if alone[t][f] == alone[0][f] {
                eprintln!("{}: thread {t} has the same result as thread 0", paths[f]);
                std::process::exit(1);
            }
        }
    }

    // 2. all threads at once
    let mut failures = 0;
    let mut conc_time = std::time::Duration::ZERO;
    for round in 0..rounds {
        let barrier = Barrier::new(threads);
        let t0 = std::time::Instant::now();
        let results: Vec<Result<Vec<Vec<u64>>, String>> = std::thread::scope(|scope| {
            let handles: Vec<_> = scenarios
                .iter()
                .map(|per_thread| {
                    let barrier = &barrier;
                    scope.spawn(move || {
                        let refs: Vec<&Scenario> = per_thread.iter().collect();
                        barrier.wait();
                        run_thread(&refs, steps)
                    })
                })
                .collect();
            handles
                .into_iter()
                .map(|h| h.join().unwrap_or_else(|_| Err("thread panicked".into())))
                .collect()
        });
        conc_time += t0.elapsed();
        for (t, r) in results.into_iter().enumerate() {
            match r {
                Err(e) => {
                    eprintln!("round {round}, thread {t}: {e}");
                    failures += 1;
                }
                Ok(per_fmu) => {
                    for (f, bits) in per_fmu.iter().enumerate() {
                        if *bits != alone[t][f] {
                            let first = bits
                                .iter()
                                .zip(&alone[t][f])
                                .position(|(a, b)| a != b)
                                .unwrap_or(bits.len());
                            eprintln!(
                                "round {round}, thread {t}, {}: differs from the lone run at value {first}",
                                paths[f]
                            );
                            failures += 1;
                        }
                    }
                }
            }
        }
    }
    let n_values: usize = alone.iter().flatten().map(|b| b.len()).sum();
    println!(
        "{threads} threads x {} FMUs x {steps} steps, {rounds} concurrent rounds: {} output values each round, {failures} differences (lone runs {:.2} s, concurrent rounds {:.2} s)",
        fmus.len(),
        n_values,
        lone_time.as_secs_f64(),
        conc_time.as_secs_f64()
    );
    if failures > 0 {
        std::process::exit(1);
    }
    println!("bit-identical");
}
