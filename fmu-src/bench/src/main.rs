//! `fmu-bench`: simulate an FMU from Rust (through `host`, as the gap workflow does) several
//! times, print the timing as JSON on stdout and write the last result as CSV.
//! The FMU is opened and instantiated once; each repetition resets and re-initializes it, so the
//! time measured is simulation, not unzipping or loading. FMI 2.0 and FMI 3.0 FMUs (the version
//! the model description declares), Co-Simulation or (`--me`) Model Exchange.

use clap::Parser;
use host::fmi3::{Fmu3, Inputs3, Request3, Simulator3};
use host::{
    csv, FmiVersion, Fmu, InputSeries, SimulationRequest, SimulationResult, Simulator, Value,
};
use std::path::PathBuf;
use std::time::Instant;

#[derive(Parser)]
#[command(about = "Time repeated simulations of an FMU driven from Rust")]
struct Args {
    /// The .fmu to run.
    fmu: PathBuf,
    /// Input CSV (time + input columns), interpolated linearly.
    #[arg(long)]
    inputs: Option<PathBuf>,
    #[arg(long, default_value_t = 10.0)]
    stop: f64,
    #[arg(long, default_value_t = 1e-3)]
    step: f64,
    /// NAME=VALUE set before initialization (repeatable).
    #[arg(long = "set")]
    set: Vec<String>,
    /// Number of timed repetitions (the median is reported).
    #[arg(long, default_value_t = 5)]
    repeat: usize,
    /// Where to write the outputs of the last run.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Run the FMU's Model Exchange interface (integrated by the host) instead of its
    /// Co-Simulation one.
    #[arg(long)]
    me: bool,
    /// Relative tolerance (fmi2SetupExperiment; the host's integrator for --me).
    #[arg(long)]
    tolerance: Option<f64>,
}

/// What ends a benchmark, with its message.
#[derive(Debug, thiserror::Error)]
enum BenchError {
    /// Opening, setting up or running the FMU failed.
    #[error(transparent)]
    Host(#[from] host::HostError),
    /// The input CSV could not be read.
    #[error(transparent)]
    Csv(#[from] csv::CsvError),
    /// The output CSV could not be written.
    #[error(transparent)]
    Write(#[from] std::io::Error),
    /// A `--set` argument without `=`.
    #[error("--set {0}: expected NAME=VALUE")]
    SetSyntax(String),
    /// A `--set` naming no variable of the FMU.
    #[error("--set {name}={value}: no variable '{name}'")]
    UnknownVariable {
        /// The name given.
        name: String,
        /// The value given.
        value: String,
    },
}

/// The timed repetitions of one FMU: `run()` simulates once.
fn repeat(
    args: &Args,
    mut run: impl FnMut() -> host::Result<SimulationResult>,
) -> Result<serde_json::Value, BenchError> {
    let mut times = Vec::with_capacity(args.repeat);
    let mut result = None;
    for _ in 0..args.repeat.max(1) {
        let t0 = Instant::now();
        let r = run()?;
        times.push(t0.elapsed().as_secs_f64());
        result = Some(r);
    }
    let result = result.expect("at least one run");
    if let Some(out) = &args.out {
        csv::write_csv(out, &result.time, &result.names, &result.columns)?;
    }
    times.sort_by(f64::total_cmp);
    Ok(serde_json::json!({
        "median_s": times[times.len() / 2],
        "min_s": times[0],
        "repeat": times.len(),
        "steps": result.time.len() - 1,
    }))
}

fn interface(args: &Args) -> Option<host::Interface> {
    args.me.then_some(host::Interface::ModelExchange)
}

/// `--set NAME=VALUE` as (name, value text).
fn sets(args: &Args) -> Result<Vec<(&str, &str)>, BenchError> {
    args.set
        .iter()
        .map(|s| {
            s.split_once('=')
                .ok_or_else(|| BenchError::SetSyntax(s.clone()))
        })
        .collect()
}

fn run(args: &Args) -> Result<serde_json::Value, BenchError> {
    match host::fmi_version_of(&args.fmu)? {
        FmiVersion::Fmi2 => run2(args),
        FmiVersion::Fmi3 => run3(args),
    }
}

fn run2(args: &Args) -> Result<serde_json::Value, BenchError> {
    let opts = host::OpenOptions {
        interface: interface(args),
        ..Default::default()
    };
    let fmu = Fmu::open_with(&args.fmu, &opts)?;
    let md = host::ModelView::from(fmu.model_description());
    let mut req = SimulationRequest::new(0.0, args.stop, args.step);
    req.tolerance = args.tolerance;
    for (name, value) in sets(args)? {
        let var = md
            .variable(name)
            .ok_or_else(|| BenchError::UnknownVariable {
                name: name.to_string(),
                value: value.to_string(),
            })?;
        req.start_values
            .push((name.to_string(), Value::parse_for(var, value)?));
    }
    if let Some(path) = &args.inputs {
        let table = csv::read_csv(path)?;
        let names = table.input_columns(&md);
        req.inputs = InputSeries {
            time: table.time.clone(),
            columns: names
                .iter()
                .map(|n| (n.clone(), table.column(n).expect("listed column").to_vec()))
                .collect(),
            ..Default::default()
        };
    }
    let mut sim = Simulator::new(&fmu)?;
    repeat(args, || sim.run(&req))
}

/// An FMI 3.0 FMU: the same request through the FMI 3.0 calls (values as text, which the host
/// parses as each variable's type; numbers written shortest round-trip, so exactly).
fn run3(args: &Args) -> Result<serde_json::Value, BenchError> {
    let fmu = Fmu3::open_with(&args.fmu, interface(args))?;
    let mut req = Request3::new(0.0, args.stop, args.step);
    req.tolerance = args.tolerance;
    req.start_values = sets(args)?
        .into_iter()
        .map(|(n, v)| (n.to_string(), v.to_string()))
        .collect();
    if let Some(path) = &args.inputs {
        let table = csv::read_csv(path)?;
        let view = host::ModelView::from(fmu.model_description());
        req.inputs = Inputs3 {
            time: table.time.clone(),
            columns: table
                .input_columns(&view)
                .iter()
                .map(|n| {
                    let column = table.column(n).expect("listed column");
                    (n.clone(), column.iter().map(|x| x.to_string()).collect())
                })
                .collect(),
        };
    }
    let mut sim = Simulator3::new(&fmu)?;
    repeat(args, || sim.run(&req))
}

fn main() {
    let args = Args::parse();
    match run(&args) {
        Ok(v) => println!("{v}"),
        Err(e) => {
            eprintln!("fmu-bench: {e}");
            std::process::exit(2);
        }
    }
}
