//! `fmu-bench`: simulate an FMU from Rust (through `host`, as the gap workflow does) several
//! times, print the timing as JSON on stdout and write the last result as CSV.
//! The FMU is opened and instantiated once; each repetition resets and re-initializes it, so the
//! time measured is simulation, not unzipping or loading.

use clap::Parser;
use host::{csv, Fmu, InputSeries, SimulationRequest, Simulator, Value};
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

fn run(args: &Args) -> Result<serde_json::Value, String> {
    let opts = host::OpenOptions {
        interface: args.me.then_some(host::Interface::ModelExchange),
        ..Default::default()
    };
    let fmu = Fmu::open_with(&args.fmu, &opts).map_err(|e| e.to_string())?;
    let md = fmu.model_description();
    let mut req = SimulationRequest::new(0.0, args.stop, args.step);
    req.tolerance = args.tolerance;
    for s in &args.set {
        let (name, value) = s
            .split_once('=')
            .ok_or_else(|| format!("--set {s}: expected NAME=VALUE"))?;
        let var = md
            .model_variables
            .iter()
            .find(|v| v.name == name)
            .ok_or_else(|| format!("--set {s}: no variable '{name}'"))?;
        req.start_values.push((
            name.to_string(),
            Value::parse_for(var, value).map_err(|e| e.to_string())?,
        ));
    }
    if let Some(path) = &args.inputs {
        let table = csv::read_csv(path).map_err(|e| e.to_string())?;
        let names = table.input_columns(md);
        req.inputs = InputSeries {
            time: table.time.clone(),
            columns: names
                .iter()
                .map(|n| (n.clone(), table.column(n).expect("listed column").to_vec()))
                .collect(),
            ..Default::default()
        };
    }
    let mut sim = Simulator::new(&fmu).map_err(|e| e.to_string())?;
    let mut times = Vec::with_capacity(args.repeat);
    let mut result = None;
    for _ in 0..args.repeat.max(1) {
        let t0 = Instant::now();
        let r = sim.run(&req).map_err(|e| e.to_string())?;
        times.push(t0.elapsed().as_secs_f64());
        result = Some(r);
    }
    let result = result.expect("at least one run");
    if let Some(out) = &args.out {
        csv::write_csv(out, &result.time, &result.names, &result.columns)
            .map_err(|e| e.to_string())?;
    }
    times.sort_by(f64::total_cmp);
    Ok(serde_json::json!({
        "median_s": times[times.len() / 2],
        "min_s": times[0],
        "repeat": times.len(),
        "steps": result.time.len() - 1,
    }))
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
