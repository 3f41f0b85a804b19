//! `actuator-fmu gap FMU --data measured.csv [--data more.csv ...] [--validate other.csv ...]
//! --out DIR [--fit NAME,...] [--effects a,b] [--rounds N] [--set NAME=VALUE ...]`: the gap
//! workflow (crate `gap`); several `--data` are fitted with one parameter set (`gap::records`),
//! `--validate` records are not fitted but reported (`gap::validation`).

use crate::common::{numeric_sets, CliError, CliResult};
use crate::open::AnyFmu;
use gap::missing::leave_out_missing;
use gap::records::Joined;
use gap::records_report::Extras;
use gap::{Config, Data, GapError, GapResult, GridModel};
use host::csv::{read_measured_csv, CsvError};
use std::path::{Path, PathBuf};

/// Arguments of `gap`.
#[derive(clap::Args)]
pub struct Args {
    /// The FMU (.fmu file or extracted directory).
    pub fmu: PathBuf,
    /// Measured CSV: `time` first, input columns named as FMU inputs (missing inputs keep their
    /// start value), output columns named as FMU outputs (any subset), SI units; a row missing
    /// a sample (an empty or NaN cell) is left out, at most 10 % of the rows. Repeatable:
    /// several records (the same output columns) are fitted with one parameter set, each
    /// beginning in its own state and weighted by its own noise levels.
    #[arg(long, required = true)]
    pub data: Vec<PathBuf>,
    /// A record not fitted: the report gives the error of the base and final models on it
    /// (repeatable; same columns as --data).
    #[arg(long, value_name = "CSV")]
    pub validate: Vec<PathBuf>,
    /// Directory for report.json, report.md, traces.csv and the PNG plots.
    #[arg(long)]
    pub out: PathBuf,
    /// Base parameters to calibrate (default: those whose description starts with [calibrate]).
    #[arg(long, value_delimiter = ',')]
    pub fit: Option<Vec<String>>,
    /// Candidate effects to consider (default: every `<effect>.enabled` of the FMU).
    #[arg(long, value_delimiter = ',')]
    pub effects: Option<Vec<String>>,
    /// Maximum number of effects to add.
    #[arg(long, default_value_t = 2)]
    pub rounds: usize,
    /// Known setting applied before initialization and never fitted, e.g. `load_mass=2.4` or
    /// `internal_controller=false`.
    #[arg(long = "set", value_name = "NAME=VALUE")]
    pub set: Vec<String>,
    /// Fraction of the trace held out at its end to check a named effect.
    #[arg(long, default_value_t = 0.3)]
    pub holdout: f64,
    /// Measured output whose constant offset (a sensor zero error, measured − model) is
    /// estimated with the parameters and reported with its interval (repeatable, or a
    /// comma-separated list).
    #[arg(long = "offset", value_name = "OUTPUT", value_delimiter = ',')]
    pub offsets: Vec<String>,
    /// No progress display on stderr.
    #[arg(long)]
    pub quiet: bool,
    /// Calibrate the base model by one direct fit only, without the growing horizons (for
    /// before/after comparisons of the calibration).
    #[arg(long)]
    pub no_horizons: bool,
    /// Never restart a refit from the profile of its effect's valley (for before/after
    /// comparisons).
    #[arg(long)]
    pub no_profile: bool,
    /// Print every stage (elapsed time, simulation count) and every fit iteration on stderr.
    #[arg(long)]
    pub trace: bool,
    /// How the FMU runs: its interface, the hang limit, the Python runtime.
    #[command(flatten)]
    pub run: crate::common::RunArgs,
}

/// The report directory must not be an input, nor hold an input under a name the report writes
/// (report.json, report.md, traces.csv, *.png).
fn refuse_writing_over_inputs(a: &Args) -> Result<(), CliError> {
    let inputs: Vec<&Path> = std::iter::once(a.fmu.as_path())
        .chain(a.data.iter().map(PathBuf::as_path))
        .chain(a.validate.iter().map(PathBuf::as_path))
        .collect();
    crate::common::refuse_overwriting(&a.out, &inputs)?;
    let Ok(out) = a.out.canonicalize() else {
        return Ok(());
    };
    for input in inputs {
        let Ok(real) = input.canonicalize() else {
            continue;
        };
        let name = real.file_name().unwrap_or_default().to_string_lossy();
        let written = ["report.json", "report.md", "traces.csv"].contains(&name.as_ref())
            || name.ends_with(".png")
            || (name.starts_with("validation-") && name.ends_with(".csv"));
        if written && real.parent() == Some(out.as_path()) {
            return Err(CliError::input(format!(
                "--out {}: the report would overwrite the input {}",
                a.out.display(),
                input.display()
            )));
        }
    }
    Ok(())
}

/// The measured data of `path` checked against the FMU: inputs and outputs it has, at least
/// one output to compare and 20 rows; the rows missing a sample left out, and the warning that
/// says so.
pub fn load_data(md: &host::ModelView, path: &Path) -> Result<(Data, Option<String>), CliError> {
    let table = read_measured_csv(path).map_err(CliError::input)?;
    table.check_against(md).map_err(CliError::input)?;
    let col = |n: &String| (n.clone(), table.column(n).unwrap_or_default().to_vec());
    let outputs: Vec<(String, Vec<f64>)> = table.output_columns(md).iter().map(col).collect();
    let bad = |line: usize, column: usize, message: String| {
        CliError::input(CsvError {
            file: path.display().to_string(),
            line,
            column,
            message,
        })
    };
    if outputs.is_empty() {
        return Err(bad(
            1,
            0,
            format!(
                "no column is an output of the FMU: nothing to compare (outputs: {})",
                md.output_names().join(", ")
            ),
        ));
    }
    let data = Data {
        time: table.time.clone(),
        inputs: table.input_columns(md).iter().map(col).collect(),
        outputs,
    };
    let (data, left_out) =
        leave_out_missing(data).map_err(|e| CliError::input(format!("{}: {e}", path.display())))?;
    if data.time.len() < 20 {
        let n = data.time.len();
        return Err(bad(
            n + 1,
            1,
            format!("{n} rows: the gap workflow needs at least 20"),
        ));
    }
    let warning = left_out.map(|l| gap::report::left_out_text(&path.display().to_string(), &l));
    Ok((data, warning))
}

/// The gap workflow on one record, or on several joined (`gap::records`): the result with
/// its scale taken off, and the report's record map.
fn run_records(
    fmu: &AnyFmu,
    data: &[Data],
    names: &[String],
    cfg: &Config,
) -> Result<(GapResult, Extras), CliError> {
    let fail = |e: GapError| match e {
        GapError::Input(e) => CliError::input(e),
        GapError::Simulation(m) => CliError::failure(format!("simulation failed: {m}")),
    };
    let sims = data
        .iter()
        .map(|d| fmu.simulator(d))
        .collect::<Result<Vec<_>, GapError>>()
        .map_err(CliError::input)?;
    if let [sim] = sims.as_slice() {
        let res = gap::run(sim, &data[0], cfg).map_err(fail)?;
        return Ok((res, Extras::default()));
    }
    let (joined, jdata, train) =
        Joined::new(sims.iter().collect(), data, names, cfg.holdout).map_err(CliError::input)?;
    let cfg = Config {
        train_samples: Some(train),
        ..cfg.clone()
    };
    let mut res = gap::run(&joined, &jdata, &cfg).map_err(fail)?;
    joined.unscale(&mut res);
    let trace_origin = joined
        .sample_origin()
        .into_iter()
        .map(|(r, i)| (r + 1, data[r].time[i]))
        .collect();
    let extras = Extras {
        records: joined.spans().to_vec(),
        trace_origin,
        ..Extras::default()
    };
    Ok((res, extras))
}

/// The base and final models of `res` on each record not fitted.
fn validate_records(
    fmu: &AnyFmu,
    paths: &[PathBuf],
    res: &GapResult,
) -> Result<Vec<gap::validation::Validation>, CliError> {
    let md = fmu.view();
    paths
        .iter()
        .map(|p| {
            let (data, left_out) = load_data(md, p)?;
            if let Some(w) = left_out {
                out!("warning: {w}");
            }
            let sim = fmu.simulator(&data).map_err(CliError::input)?;
            check_columns(&sim, &data, p)?;
            gap::validation::validate(&sim, &data, &p.display().to_string(), res).map_err(|e| {
                match e {
                    GapError::Input(e) => CliError::input(e),
                    GapError::Simulation(m) => CliError::failure(format!(
                        "--validate {}: simulation failed: {m}",
                        p.display()
                    )),
                }
            })
        })
        .collect()
}

/// Every output column of a record not fitted is an output of the model.
fn check_columns(sim: &impl GridModel, data: &Data, path: &Path) -> Result<(), CliError> {
    for (name, _) in &data.outputs {
        if !sim.output_names().contains(name) {
            return Err(CliError::input(format!(
                "--validate {}: '{name}' is not an output of the FMU",
                path.display()
            )));
        }
    }
    Ok(())
}

/// Runs `gap`.
pub fn run(a: Args) -> CliResult {
    refuse_writing_over_inputs(&a)?;
    let opts = a.run.open_options();
    let fmu = AnyFmu::open(&a.fmu, &opts)?;
    let md = fmu.view();
    let fixed = numeric_sets(md, &a.set, "gap")?;
    let (data, left_out): (Vec<Data>, Vec<Option<String>>) = a
        .data
        .iter()
        .map(|p| load_data(md, p))
        .collect::<Result<Vec<_>, CliError>>()?
        .into_iter()
        .unzip();
    let names: Vec<String> = a.data.iter().map(|p| p.display().to_string()).collect();
    // The held-out end decides whether an effect generalises; without it nothing can be named.
    if !(a.holdout > 0.0 && a.holdout < 0.9) {
        return Err(CliError::input(format!(
            "--holdout {}: must be in (0, 0.9): the held-out end decides whether an effect is named",
            a.holdout
        )));
    }
    let cfg = Config {
        fit: a.fit.clone(),
        effects: a.effects.clone(),
        rounds: a.rounds,
        fixed,
        holdout: a.holdout,
        progress: !a.quiet,
        calibration_horizons: !a.no_horizons,
        profile_restart: !a.no_profile,
        trace: a.trace,
        offsets: a.offsets.clone(),
        ..Config::default()
    };
    let (mut res, mut extras) = run_records(&fmu, &data, &names, &cfg)?;
    res.warnings.splice(0..0, left_out.into_iter().flatten());
    extras.validation = validate_records(&fmu, &a.validate, &res)?;
    std::fs::create_dir_all(&a.out)
        .map_err(|e| CliError::failure(format!("{}: {e}", a.out.display())))?;
    let mut plots = gap::plots::write(&res, &a.out);
    plots.extend(gap::plots::write_validation(&extras.validation, &a.out));
    let fmu_s = a.fmu.display().to_string();
    gap::report::write(&res, &a.out, &fmu_s, &names[0], &plots, &extras)
        .map_err(|e| CliError::failure(format!("{}: {e}", a.out.display())))?;
    out!("{}: {}", names.join(" + "), gap::report::verdict_text(&res));
    for w in res.warnings.iter().chain(&res.convention_warnings) {
        out!("warning: {w}");
    }
    out!(
        "named: [{}]",
        res.named
            .iter()
            .map(|s| format!("\"{s}\""))
            .collect::<Vec<_>>()
            .join(", ")
    );
    for (name, b) in &res.offsets {
        out!(
            "offset of {name} (measured − model): {:.4e}, 95 % interval [{:.4e}, {:.4e}]",
            b.value,
            b.ci_low,
            b.ci_high
        );
    }
    for (name, o) in &res.outputs {
        out!(
            "  {name}: RMSE {:.4e} -> {:.4e} (noise {:.3e}), max {:.4e} -> {:.4e}",
            o.rmse_before,
            o.rmse_after,
            o.noise_sigma,
            o.max_before,
            o.max_after
        );
    }
    for v in &extras.validation {
        for (name, e) in &v.outputs {
            out!(
                "  {} (not fitted) {name}: RMSE base fit {:.4e}, final {:.4e}; max final {:.4e} at t = {} s",
                v.data,
                e.rmse_base,
                e.rmse_final,
                e.max_final,
                e.max_final_at_s
            );
        }
    }
    out!(
        "time {:.1} s (simulation {:.1} s, fitting {:.1} s, {} simulations); report: {}",
        res.timing.total_s,
        res.timing.simulate_s,
        res.timing.fit_s,
        res.timing.simulations,
        a.out.join("report.md").display()
    );
    Ok(0)
}
