//! Does an FMU simulate in parallel through `host`? One [`host::Fmu`] is shared by `T` threads,
//! each with its own [`host::Simulator`] (as the gap workflow uses it); every thread runs `R`
//! simulations of a measured trace (inputs from the CSV, communication step = its sample
//! interval). Prints wall time, process CPU time and the per-simulation cost for T = 1 and
//! T = 2; a model whose instances share no lock gives ~2x throughput on 2 free cores.
//!
//! usage: cargo run --release -p host --example parallel-speedup -- FMU CSV [RUNS_PER_THREAD]

use host::{Fmu, InputSeries, SimulationRequest};
use std::path::Path;
use std::time::Instant;

/// Process CPU time (user + system) in seconds, from /proc/self/stat (Linux).
fn cpu_s() -> f64 {
    let s = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let rest = s.rsplit(')').next().unwrap_or("");
    let f: Vec<&str> = rest.split_whitespace().collect();
    let tick = |i: usize| f.get(i).and_then(|x| x.parse::<f64>().ok()).unwrap_or(0.0);
    // Fields after the command: state(0) ... utime(11) stime(12), in clock ticks (100 Hz).
    (tick(11) + tick(12)) / 100.0
}

/// Busy CPU seconds of the whole machine (all processes), from /proc/stat: a concurrent
/// build by someone else shows as busy time that is not this process's CPU time.
fn machine_busy_s() -> f64 {
    let s = std::fs::read_to_string("/proc/stat").unwrap_or_default();
    let f: Vec<f64> = s
        .lines()
        .next()
        .unwrap_or("")
        .split_whitespace()
        .skip(1)
        .filter_map(|x| x.parse().ok())
        .collect();
    // user nice system idle iowait irq softirq steal ...: busy = all but idle and iowait.
    let total: f64 = f.iter().take(8).sum();
    let idle = f.get(3).unwrap_or(&0.0) + f.get(4).unwrap_or(&0.0);
    (total - idle) / 100.0
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() < 2 {
        eprintln!("usage: parallel-speedup FMU CSV [RUNS_PER_THREAD]");
        std::process::exit(2);
    }
    let runs: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(6);
    let fmu = Fmu::open(Path::new(&args[0])).expect("open FMU");
    let table = host::csv::read_csv(Path::new(&args[1])).expect("read CSV");
    let md = host::ModelView::from(fmu.model_description());
    let step = table.sample_interval().expect("two rows");
    let mut req = SimulationRequest::new(table.time[0], *table.time.last().unwrap(), step);
    req.inputs = InputSeries {
        time: table.time.clone(),
        columns: table
            .input_columns(&md)
            .into_iter()
            .map(|n| {
                let c = table.column(&n).unwrap().to_vec();
                (n, c)
            })
            .collect(),
        ..Default::default()
    };
    println!(
        "{}: {} samples, step {step} s, inputs {:?}",
        args[0],
        table.time.len(),
        req.inputs.columns.iter().map(|c| &c.0).collect::<Vec<_>>()
    );
    for threads in [1usize, 2] {
        let (w0, c0, m0) = (Instant::now(), cpu_s(), machine_busy_s());
        std::thread::scope(|s| {
            for _ in 0..threads {
                s.spawn(|| {
                    let mut sim = host::Simulator::new(&fmu).expect("instantiate");
                    for _ in 0..runs {
                        sim.run(&req).expect("simulate");
                    }
                });
            }
        });
        let (wall, cpu) = (w0.elapsed().as_secs_f64(), cpu_s() - c0);
        let others = (machine_busy_s() - m0 - cpu).max(0.0) / wall;
        let n = threads * runs;
        println!(
            "threads {threads}: {n} sims, wall {wall:.3} s, cpu {cpu:.2} s ({:.0}% CPU), \
             {:.1} ms wall/sim, {:.1} ms cpu/sim; other processes busy {others:.2} cores",
            100.0 * cpu / wall,
            1e3 * wall / n as f64,
            1e3 * cpu / n as f64
        );
    }
}
