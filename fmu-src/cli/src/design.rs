//! `actuator-fmu design FMU [--effect NAME ...] [--data measured.csv] [--set NAME=VALUE ...]
//! [--range INPUT=LO:HI ...] --out inputs.csv`: an experiment that would reveal candidate effects
//! (crate `gap`, module `design`), written as an input CSV that `simulate` and a test bench read.

use crate::common::{numeric_sets, CliError, CliResult};
use crate::gap_cmd::load_data;
use crate::open::AnyFmu;
use gap::design::{self, Design, DesignConfig, InputSpec, Noise};
use gap::GapError;
use host::view::{Causality, ModelView, VarKind};
use std::io::Write;
use std::path::PathBuf;

/// Arguments of `design`.
#[derive(clap::Args)]
pub struct Args {
    /// The FMU (.fmu file or extracted directory).
    pub fmu: PathBuf,
    /// Candidate effect to reveal (repeatable; default: every candidate). With several, the
    /// experiment maximises the weakest one's visibility.
    #[arg(long = "effect", value_name = "NAME")]
    pub effects: Vec<String>,
    /// The data at hand: the experiment keeps their time grid, measured outputs and noise levels,
    /// and the report says how visible each effect is in them.
    #[arg(long)]
    pub data: Option<PathBuf>,
    /// Known setting, or a base parameter's fitted value (the gap report lists them), applied
    /// to every simulation, e.g. `load_mass=2.4`.
    #[arg(long = "set", value_name = "NAME=VALUE")]
    pub set: Vec<String>,
    /// Base parameters the gap run calibrates (default: those tagged [calibrate]).
    #[arg(long, value_delimiter = ',')]
    pub fit: Option<Vec<String>>,
    /// Range an input may take, for an input whose description declares none or to narrow one
    /// (repeatable), e.g. `tau_ext=-5:5`.
    #[arg(long = "range", value_name = "INPUT=LO:HI")]
    pub ranges: Vec<String>,
    /// Measured outputs (without --data; default: every numeric output).
    #[arg(long, value_delimiter = ',')]
    pub outputs: Option<Vec<String>>,
    /// Duration of the experiment [s] (without --data).
    #[arg(long, default_value_t = 10.0)]
    pub duration: f64,
    /// Sample rate [Hz] (without --data).
    #[arg(long, default_value_t = 200.0)]
    pub rate: f64,
    /// Noise of each output as a fraction of its range in the experiment (without --data).
    #[arg(long, default_value_t = 0.01)]
    pub noise_fraction: f64,
    /// Fraction of the trace the gap run holds out.
    #[arg(long, default_value_t = 0.3)]
    pub holdout: f64,
    /// The input CSV to write (time and every input).
    #[arg(long)]
    pub out: PathBuf,
    /// No progress display (accepted for symmetry with gap; design prints only its summary).
    #[arg(long)]
    pub quiet: bool,
    /// How the FMU runs: its interface, the hang limit, the Python runtime.
    #[command(flatten)]
    pub run: crate::common::RunArgs,
}

/// Most samples an experiment may have (it is simulated a few hundred times).
const MAX_SAMPLES: f64 = 1e6;

/// The inputs of the FMU with their design ranges (declared, or from `--range`).
fn inputs(md: &ModelView, ranges: &[String]) -> Result<Vec<InputSpec>, CliError> {
    let mut given = Vec::new();
    for r in ranges {
        let bad = || CliError::input(format!("--range '{r}': expected INPUT=LO:HI with LO < HI"));
        let (name, span) = r.split_once('=').ok_or_else(bad)?;
        let (lo, hi) = span.split_once(':').ok_or_else(bad)?;
        let (lo, hi): (f64, f64) = (
            lo.trim().parse().map_err(|_| bad())?,
            hi.trim().parse().map_err(|_| bad())?,
        );
        if !(lo.is_finite() && hi.is_finite() && lo < hi) {
            return Err(bad());
        }
        let name = name.trim();
        let v = md.scalar(name).filter(|v| v.causality == Causality::Input);
        if v.is_none_or(|v| v.scalar_kind() != Some(VarKind::Real)) {
            return Err(CliError::input(format!(
                "--range '{r}': the FMU has no Real input '{name}'"
            )));
        }
        given.push((name.to_string(), lo, hi));
    }
    Ok(md
        .scalars_with(Causality::Input)
        .filter(|v| v.scalar_kind() == Some(VarKind::Real))
        .map(|v| {
            let range = given
                .iter()
                .rev()
                .find(|(n, _, _)| n == &v.name)
                .map(|&(_, lo, hi)| (lo, hi))
                .or(v.min.zip(v.max).filter(|(lo, hi)| lo < hi));
            InputSpec {
                name: v.name.clone(),
                start: v.start_number().unwrap_or(0.0),
                range,
                unit: v.unit.clone().unwrap_or_default(),
            }
        })
        .collect())
}

/// The time grid, measured outputs, noise and given inputs: from the data, or from the flags.
fn experiment(a: &Args, md: &ModelView) -> Result<DesignConfig, CliError> {
    let mut cfg = DesignConfig {
        effects: (!a.effects.is_empty()).then(|| a.effects.clone()),
        fit: a.fit.clone(),
        fixed: numeric_sets(md, &a.set, "design")?,
        time: Vec::new(),
        inputs: inputs(md, &a.ranges)?,
        outputs: Vec::new(),
        noise: Noise::Fraction(a.noise_fraction),
        given: None,
        holdout: a.holdout,
        min_delta_bic: gap::Config::default().min_delta_bic,
    };
    if !(a.holdout > 0.0 && a.holdout < 0.9) {
        return Err(CliError::input(format!(
            "--holdout {}: must be in (0, 0.9)",
            a.holdout
        )));
    }
    if let Some(path) = &a.data {
        let (data, left_out) = load_data(md, path)?;
        if let Some(w) = left_out {
            out!("warning: {w}");
        }
        cfg.noise = Noise::Measured(data.outputs.iter().map(|(_, y)| y.clone()).collect());
        cfg.outputs = data.outputs.into_iter().map(|(n, _)| n).collect();
        cfg.time = data.time;
        cfg.given = Some(data.inputs);
        return Ok(cfg);
    }
    let n = a.duration * a.rate;
    if !(a.duration > 0.0 && a.rate > 0.0 && (20.0..=MAX_SAMPLES).contains(&n)) {
        return Err(CliError::input(format!(
            "--duration {} s at --rate {} Hz: the experiment needs 20 to {MAX_SAMPLES:e} samples",
            a.duration, a.rate
        )));
    }
    if !(a.noise_fraction > 0.0 && a.noise_fraction.is_finite()) {
        return Err(CliError::input(format!(
            "--noise-fraction {}: must be positive",
            a.noise_fraction
        )));
    }
    cfg.time = (0..=n.round() as usize)
        .map(|i| i as f64 / a.rate)
        .collect();
    cfg.outputs = match &a.outputs {
        Some(o) => o.clone(),
        None => md
            .scalars_with(Causality::Output)
            .filter(|v| v.scalar_kind() != Some(VarKind::String))
            .map(|v| v.name.clone())
            .collect(),
    };
    Ok(cfg)
}

/// The CSV with a comment header saying what it is and what it should reveal.
fn write(a: &Args, d: &Design) -> std::io::Result<()> {
    let names: Vec<String> = d.inputs.iter().map(|(n, _)| n.clone()).collect();
    let cols: Vec<Vec<f64>> = d.inputs.iter().map(|(_, v)| v.clone()).collect();
    host::csv::write_atomically(&a.out, |f| {
        let mut w = std::io::BufWriter::new(f);
        writeln!(
            w,
            "# experiment proposed by actuator-fmu design for {}",
            a.fmu.display()
        )?;
        for line in summary(d) {
            writeln!(w, "# {line}")?;
        }
        host::csv::write_csv_to(w, &d.time, &names, &cols)
    })
}

/// Ratio to what naming needs, as the gap report shows it.
fn times(v: Option<f64>, needed: f64) -> String {
    v.map_or("not simulated".into(), |v| {
        gap::workflow::visibility_scale(v, needed)
    })
}

/// One line per input and per effect.
fn summary(d: &Design) -> Vec<String> {
    let mut lines: Vec<String> = d
        .labels
        .iter()
        .map(|(n, l)| format!("input {n}: {l}"))
        .collect();
    lines.extend(
        d.held
            .iter()
            .map(|(n, why)| format!("input {n}: held at its start value ({why})")),
    );
    for e in &d.effects {
        let at: Vec<String> = e
            .weakest
            .iter()
            .map(|(k, v)| format!("{k} = {v:.4e}"))
            .collect();
        let given = match e.given {
            Some(_) => format!("{} in the data, ", times(e.given, e.needed)),
            None => String::new(),
        };
        lines.push(format!(
            "{} at its weakest ({}): visibility {given}{} in this experiment",
            e.effect,
            at.join(", "),
            times(e.designed, e.needed)
        ));
    }
    lines
}

/// Runs `design`.
pub fn run(a: Args) -> CliResult {
    let mut inputs: Vec<&std::path::Path> = vec![a.fmu.as_path()];
    inputs.extend(a.data.as_deref());
    crate::common::refuse_overwriting(&a.out, &inputs)?;
    let opts = a.run.open_options();
    let fmu = AnyFmu::open(&a.fmu, &opts)?;
    let md = fmu.view();
    let cfg = experiment(&a, md)?;
    let d = design::design(|data| fmu.simulator(data), &cfg).map_err(|e| match e {
        GapError::Input(e) => CliError::input(e),
        GapError::Simulation(m) => CliError::failure(format!("simulation failed: {m}")),
    })?;
    write(&a, &d)
        .map_err(|e| CliError::failure(format!("{}: cannot write: {e}", a.out.display())))?;
    for line in summary(&d) {
        out!("{line}");
    }
    out!(
        "{} experiments, {} simulations; {}: {}",
        d.experiments,
        d.simulations,
        if d.reveals_all() {
            "every effect shows at its weakest"
        } else {
            "not every effect reaches the naming threshold at its weakest (see above)"
        },
        a.out.display()
    );
    Ok(0)
}
