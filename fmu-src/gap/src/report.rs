//! `report.json` (for scripts and CI) and `report.md` (for the engineer) of one gap run.

use crate::policy::NOISE_RMS_RATIO;
use crate::records_report::Extras;
use crate::workflow::{
    Candidate, CandidateVerdict, ClosestShortfall, Disagreement, GapResult, LeftOpen, Shortfall,
    Verdict,
};
use serde_json::{json, Value};
use std::fmt::Write as _;
use std::path::Path;

/// The verdict in plain words for the first line of the report: what was named, and which
/// candidates these data cannot show at all (the details and the statistics follow).
pub fn in_short(res: &GapResult) -> String {
    let mut s = if let (true, Some(d)) = (res.named.is_empty(), &res.disagreement) {
        format!(
            "no candidate effect explains the data, and a disagreement remains ({}): see the \
             warnings for where it sits and what its shape suggests.",
            d.outputs
                .iter()
                .map(|o| format!("{} {:.1}× its noise level", o.output, o.rmse_over_noise))
                .collect::<Vec<_>>()
                .join(", ")
        )
    } else if res.named.is_empty() {
        "no missing effect found.".to_string()
    } else {
        format!(
            "the data show {} missing from the model: {}.",
            if res.named.len() == 1 {
                "an effect"
            } else {
                "effects"
            },
            res.named.join(", ")
        )
    };
    if let (false, Some(d)) = (res.named.is_empty(), &res.disagreement) {
        s.push_str(&format!(
            " Even with {}, a disagreement remains that no candidate explains ({}): see the \
             warnings.",
            if res.named.len() == 1 { "it" } else { "them" },
            d.outputs
                .iter()
                .map(|o| format!("{} {:.1}× its noise level", o.output, o.rmse_over_noise))
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    let hidden = last_round(res, |c| (!c.detectable()).then(|| c.effect.clone()));
    if !hidden.is_empty() {
        s.push_str(&format!(
            " These data cannot show {} even at full strength: testing for it needs other \
             excitation or sensors (`actuator-fmu design` proposes an experiment; the commands \
             are in the report).",
            hidden.join(", ")
        ));
    }
    let weak = last_round(res, |c| {
        (c.detectable() && c.may_hide() && !c.inconclusive).then(|| c.effect.clone())
    });
    if !weak.is_empty() {
        s.push_str(&format!(
            " Weaker than their detection limits (in the report), {} could be present unseen: \
             `actuator-fmu design` proposes experiments that would show them at their weakest \
             (the commands are in the report).",
            weak.join(", ")
        ));
    }
    let unsettled = last_round(res, |c| {
        (c.detectable() && c.may_hide() && c.inconclusive)
            .then(|| format!("{} (ΔBIC {:.1})", c.effect, c.delta_bic))
    });
    if !unsettled.is_empty() {
        s.push_str(&format!(
            " The data hint at {} without showing it (below the naming threshold): \
             `actuator-fmu design` proposes an experiment that would settle it (the commands are \
             in the report).",
            unsettled.join(", ")
        ));
    }
    if !res.offsets.is_empty() {
        s.push_str(&format!(
            " Estimated sensor offsets (measured − model): {}.",
            res.offsets
                .iter()
                .map(|(k, e)| format!("{k} {:+.4e} [{:.4e}, {:.4e}]", e.value, e.ci_low, e.ci_high))
                .collect::<Vec<_>>()
                .join("; ")
        ));
    }
    if let Some(u) = &res.unexplained {
        if res.named.is_empty() {
            s.push_str(&format!(
                " The closest candidate, {u}, did not meet the naming criteria."
            ));
        }
    }
    s
}

/// The warning that the rows `left` of record `file` were left out for a missing sample.
pub fn left_out_text(file: &str, left: &crate::missing::LeftOut) -> String {
    let columns: Vec<String> = left
        .by_column
        .iter()
        .map(|(name, count)| format!("{name}: {count}"))
        .collect();
    format!(
        "{file}: {} of {} rows miss a sample and are left out ({}; the first at t = {} s); the \
         inputs are interpolated over them",
        left.rows,
        left.of,
        columns.join(", "),
        left.first_time
    )
}

/// The verdict line: the rounds' conclusion and, while the final model still disagrees with
/// the data, that a disagreement remains that no candidate explains (never that nothing is
/// missing or that the residuals are noise).
pub fn verdict_text(res: &GapResult) -> String {
    let rounds = rounds_text(&res.verdict);
    let Some(d) = &res.disagreement else {
        return rounds;
    };
    let remains = disagreement_words(d);
    match &res.verdict {
        Verdict::ConsistentWithNoise { .. } => remains,
        v if v.named().is_empty() => {
            let rest = rounds.strip_prefix(NOTHING_FOUND).unwrap_or(&rounds);
            format!("{remains}{rest}")
        }
        _ => format!("{rounds}; {remains}"),
    }
}

/// The opening words of a verdict that names nothing.
const NOTHING_FOUND: &str = "no missing effect found";

/// The rounds' conclusion in words.
fn rounds_text(v: &Verdict) -> String {
    match v {
        Verdict::Named { effects } if effects.is_empty() => NOTHING_FOUND.to_string(),
        Verdict::Named { effects } => format!("named {}", effects.join(", ")),
        Verdict::ConsistentWithNoise {
            closest,
            best_delta_bic,
            open,
        } => format!(
            "{NOTHING_FOUND}: the calibrated base model's residuals are consistent with noise (every output within {NOISE_RMS_RATIO}× its noise level and white; the best candidate, {}, has a linearised ΔBIC of {best_delta_bic:.1} < {}){}",
            closest.as_deref().unwrap_or("none"),
            open.min_delta_bic,
            left_open_text(open)
        ),
        Verdict::NothingFurther {
            named,
            closest,
            why,
            open,
        } => {
            let why = match why {
                ClosestShortfall::Refitted { shortfalls } => shortfalls_text(shortfalls),
                ClosestShortfall::NotRefitted {
                    delta_bic,
                    min_delta_bic,
                } => format!("linearised ΔBIC = {delta_bic:.1} < {min_delta_bic}: not refitted"),
            };
            let head = if named.is_empty() {
                format!("{NOTHING_FOUND}; the closest candidate, {closest}, is left unexplained ({why})")
            } else {
                format!(
                    "named {}; no further effect found; the closest remaining candidate, {closest}, is left unexplained ({why})",
                    named.join(", ")
                )
            };
            format!("{head}{}", left_open_text(open))
        }
    }
}

/// The sentences on the candidates a round leaves open (empty if none): those only screened
/// although the data could show them, and those the data cannot reveal.
fn left_open_text(open: &LeftOpen) -> String {
    let mut s = String::new();
    if !open.only_screened.is_empty() {
        let names: Vec<String> = open
            .only_screened
            .iter()
            .map(|c| format!("{} (linearised ΔBIC {:.1})", c.effect, c.delta_bic))
            .collect();
        s.push_str(&format!(
            ". Only screened, not refitted: {}. The data could show each of them from its weakest \
             detectable setting on (see the table), and the linearised test puts each below the \
             naming threshold of ΔBIC {}: none is present at that strength, though a \
             weaker one, or one the linearisation misjudges (a dead zone), is not ruled out",
            names.join(", "),
            open.min_delta_bic
        ));
    }
    if !open.unrevealable.is_empty() {
        let hidden: Vec<String> = open
            .unrevealable
            .iter()
            .map(|c| {
                format!(
                    "{} (at its strongest setting {})",
                    c.effect,
                    visibility_scale(c.reach.visibility, c.reach.needed)
                )
            })
            .collect();
        s.push_str(&format!(
            ". These data cannot reveal {}: even at the strongest setting in range, the base parameters absorb all but a change below the naming threshold, so their absence is not shown",
            hidden.join(", ")
        ));
    }
    s
}

/// The disagreement that remains, in one line: the outputs and their ratios.
fn disagreement_words(d: &Disagreement) -> String {
    format!(
        "a disagreement remains that no candidate explains ({})",
        d.outputs
            .iter()
            .map(|o| format!("{} {:.1}× noise", o.output, o.rmse_over_noise))
            .collect::<Vec<_>>()
            .join(", ")
    )
}

/// Why a candidate was or was not named, in words.
pub fn candidate_verdict_text(v: &CandidateVerdict) -> String {
    match v {
        CandidateVerdict::Unchecked => String::new(),
        CandidateVerdict::ScreenedOnly => "screened only (linearised ΔBIC)".into(),
        CandidateVerdict::ScreenedAgainstFinal { named } => format!(
            "screened against the final model (with {}), whose residuals are at the noise level",
            named.join(", ")
        ),
        CandidateVerdict::RefitFailed { cause } => format!("refit failed: {cause}"),
        CandidateVerdict::Named {
            delta_bic,
            min_delta_bic,
        } => format!(
            "named: ΔBIC = {delta_bic:.1} ≥ {min_delta_bic}, magnitude interval excludes 0, held-out error lower"
        ),
        CandidateVerdict::NotNamed {
            shortfalls,
            unrevealable,
        } => {
            let mut s = format!("not named: {}", shortfalls_text(shortfalls));
            if let Some(r) = unrevealable {
                s.push_str(&format!(
                    "; these data cannot reveal it (anywhere in its range, after the base parameters readjust, at most {})",
                    visibility_scale(r.visibility, r.needed)
                ));
            }
            s
        }
        CandidateVerdict::NotConsidered => {
            "not considered: a higher-ranked candidate was named".into()
        }
    }
}

/// Reasons not to name a candidate, in words, separated by semicolons.
fn shortfalls_text(shortfalls: &[Shortfall]) -> String {
    shortfalls
        .iter()
        .map(|s| match s {
            Shortfall::RefitFailed => "refit failed".to_string(),
            Shortfall::DeltaBicBelow {
                delta_bic,
                min_delta_bic,
            } => format!("ΔBIC = {delta_bic:.1} < {min_delta_bic}"),
            Shortfall::MagnitudeIncludesZero => "magnitude interval includes 0".into(),
            Shortfall::HoldoutNotLower => "does not lower the held-out error".into(),
            Shortfall::StartNotReproduced => {
                "does not explain why the record begins away from the model's initial state".into()
            }
            Shortfall::ExplainsLittle { share, min_share } => format!(
                "explains {:.0} % of the misfit beyond the noise (log scale), under the {:.0} % \
                 an explanation needs",
                100.0 * share,
                100.0 * min_share
            ),
        })
        .collect::<Vec<_>>()
        .join("; ")
}

/// A candidate's visibility on a scale an engineer reads at a glance: the most the effect could
/// explain anywhere in its range as a multiple of what naming it needs ("0.4×": it cannot be
/// revealed by these data; "2.3e+05×": it would stand out at its strongest setting).
pub fn visibility_scale(visibility: f64, needed: f64) -> String {
    if !(visibility.is_finite() && needed > 0.0) {
        return "unknown".into();
    }
    let r = visibility / needed;
    if r < 0.01 {
        "< 0.01× what naming needs".into()
    } else if r < 100.0 {
        format!("{r:.2}× what naming needs")
    } else {
        format!("{r:.1e}× what naming needs")
    }
}

/// The candidates per round as JSON, each with its verdict in words (`verdict`) beside the
/// typed one (`decision`).
fn candidates_json(res: &GapResult) -> Value {
    let rounds = res
        .candidates
        .iter()
        .map(|round| {
            round
                .iter()
                .map(|c| {
                    let mut v = serde_json::to_value(c).unwrap_or(Value::Null);
                    if let Value::Object(m) = &mut v {
                        m.insert(
                            "verdict".into(),
                            Value::String(candidate_verdict_text(&c.verdict)),
                        );
                    }
                    v
                })
                .collect()
        })
        .collect();
    Value::Array(rounds)
}

/// What `keep` makes of the candidates of the last round it keeps, in their order.
fn last_round(res: &GapResult, keep: impl Fn(&Candidate) -> Option<String>) -> Vec<String> {
    res.candidates
        .last()
        .map(|r| r.iter().filter_map(&keep).collect())
        .unwrap_or_default()
}

/// A word of a shell command, quoted when it holds anything but plain characters.
fn shell_word(w: &str) -> String {
    let plain = |c: char| c.is_ascii_alphanumeric() || "_-./=:+,@%".contains(c);
    if !w.is_empty() && w.chars().all(plain) {
        w.to_string()
    } else {
        format!("'{}'", w.replace('\'', r"'\''"))
    }
}

/// For every candidate of the last round these data may not show (not named, and invisible at
/// the weakest setting of its range: [`Candidate::may_hide`]), the `actuator-fmu design`
/// command that proposes an experiment that would: the same data (grid, outputs, noise), the
/// known settings, the named effects and the fitted values.
pub fn design_commands(
    res: &GapResult,
    fmu: &str,
    data: &str,
) -> std::collections::BTreeMap<String, String> {
    let Some(round) = res.candidates.last() else {
        return Default::default();
    };
    let mut sets: Vec<String> = res.fixed.iter().map(|(k, v)| format!("{k}={v}")).collect();
    sets.extend(res.named.iter().map(|e| format!("{e}.enabled=true")));
    sets.extend(
        res.parameters
            .iter()
            .map(|(k, e)| format!("{k}={}", e.value)),
    );
    round
        .iter()
        .filter(|c| c.may_hide())
        .map(|c| {
            let mut words = vec![
                "actuator-fmu".to_string(),
                "design".into(),
                shell_word(fmu),
                "--data".into(),
                shell_word(data),
                "--effect".into(),
                shell_word(&c.effect),
            ];
            for s in &sets {
                words.push("--set".into());
                words.push(shell_word(s));
            }
            words.push("--out".into());
            words.push(shell_word(&format!("design-{}.csv", c.effect)));
            (c.effect.clone(), words.join(" "))
        })
        .collect()
}

/// The JSON document: `named`, `candidates` (per round, ranked), `parameters`, `offsets` (the
/// outputs' estimated offsets, measured − model, when asked for), `outputs`,
/// `timing`, plus the diagnosis and settings.
pub fn to_json(res: &GapResult, fmu: &str, data: &str, extras: &Extras) -> Value {
    let mut doc = json!({
        "fmu": fmu,
        "data": data,
        "in_short": in_short(res),
        "verdict": verdict_text(res),
        "decision": res.verdict,
        "warnings": res.warnings,
        "convention_warnings": res.convention_warnings,
        "named": res.named,
        "unexplained": res.unexplained,
        "disagreement": res.disagreement,
        "candidates": candidates_json(res),
        "design_commands": design_commands(res, fmu, data),
        "redone_rounds": res.redone_rounds.iter().map(|(r, g)| json!({"round": r, "base_delta_bic": g})).collect::<Vec<_>>(),
        "calibration": res.calibration,
        "parameters": res.parameters,
        "offsets": res.offsets,
        "outputs": res.outputs,
        "timing": res.timing,
        "fixed": res.fixed,
        "diagnosis": res.diagnosis,
        "samples": res.samples,
        "train_samples": res.train_samples,
        "holdout_fraction": res.holdout_fraction,
    });
    extras.add_json(&mut doc);
    doc
}

/// A number for the report: plain when zero or not finite, 5 decimals in [1e-3, 1e4), else
/// scientific with 4.
pub(crate) fn g(x: f64) -> String {
    if x == 0.0 || !x.is_finite() {
        format!("{x}")
    } else if x.abs() >= 1e4 || x.abs() < 1e-3 {
        format!("{x:.4e}")
    } else {
        format!("{x:.5}")
    }
}

/// The human-readable report.
pub fn to_markdown(
    res: &GapResult,
    fmu: &str,
    data: &str,
    plots: &[String],
    extras: &Extras,
) -> String {
    let mut s = String::new();
    if extras.records.len() > 1 {
        let _ = writeln!(s, "# Gap report\n\nFMU `{fmu}`, {} records fitted together, the first `{data}` ({} samples in all; fits on the first {} of the joined records, the last {:.0} % of each held out).\n", extras.records.len(), res.samples, res.train_samples, 100.0 * res.holdout_fraction);
    } else {
        let _ = writeln!(s, "# Gap report\n\nFMU `{fmu}`, data `{data}` ({} samples; fits on the first {}, the last {:.0} % held out).\n", res.samples, res.train_samples, 100.0 * res.holdout_fraction);
    }
    let _ = writeln!(s, "**In short:** {}\n", in_short(res));
    let _ = writeln!(s, "**Verdict:** {}\n", verdict_text(res));
    for w in res.warnings.iter().chain(&res.convention_warnings) {
        let _ = writeln!(s, "**Warning:** {w}\n");
    }
    if !res.fixed.is_empty() {
        let _ = writeln!(
            s,
            "Known settings (`--set`): {}\n",
            res.fixed
                .iter()
                .map(|(k, v)| format!("`{k}={v}`"))
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    let _ = writeln!(s, "## Where the model disagrees\n");
    for (i, d) in res.diagnosis.iter().enumerate() {
        let title = if i == 0 {
            "Calibrated base model".to_string()
        } else {
            format!("After adding {}", res.named[..i].join(", "))
        };
        let _ = writeln!(s, "### {title}\n");
        if i == 0 {
            let _ = writeln!(
                s,
                "{}\n",
                res.calibration
                    .text(&res.traces.time, res.train_samples, res.outputs.len())
            );
        }
        let _ = writeln!(s, "{}\n", d.text);
        for o in &d.outputs {
            let _ = writeln!(s, "- {}", o.text);
        }
        let _ = writeln!(s);
    }
    let _ = writeln!(s, "## Candidate effects\n");
    for (r, round) in res.candidates.iter().enumerate() {
        let _ = writeln!(s, "### Round {}\n", r + 1);
        if let Some((_, gain)) = res.redone_rounds.iter().find(|x| x.0 == r + 1) {
            let _ = writeln!(s, "Done twice: its base re-check improved the base fit by ΔBIC = {gain:.1}, after which no candidate refitted from the worse base reached the threshold; screened and refitted again from the better base. The table is the second pass.\n");
        }
        let _ = writeln!(s, "| rank | effect | ΔBIC | screening score | magnitude 95 % CI | held-out SSE with / without | visibility: strongest setting, × what naming needs; weakest detectable setting | verdict |\n|---|---|---|---|---|---|---|---|");
        for (i, c) in round.iter().enumerate() {
            let mag = c
                .magnitude
                .as_ref()
                .map(|m| format!("[{:.3}, {:.3}]", m.ci_low, m.ci_high))
                .unwrap_or("–".into());
            let hold = match (c.holdout_sse_with, c.holdout_sse_without) {
                (Some(a), Some(b)) => format!("{} / {}", g(a), g(b)),
                _ => "–".into(),
            };
            let vis = match c.visibility {
                Some(v) => format!(
                    "{}; {}",
                    visibility_scale(v, c.visibility_needed),
                    c.detectable_from
                        .as_ref()
                        .map(|m| m
                            .iter()
                            .map(|(k, v)| format!("{k} = {}", g(*v)))
                            .collect::<Vec<_>>()
                            .join(", "))
                        .unwrap_or_else(|| "none in range".into())
                ),
                None => "–".into(),
            };
            let _ = writeln!(
                s,
                "| {} | {} | {:.1} | {:.1} | {} | {} | {} | {} |",
                i + 1,
                c.effect,
                c.delta_bic,
                c.score,
                mag,
                hold,
                vis,
                if c.profiled {
                    format!(
                        "{} (refit restarted from its profile)",
                        candidate_verdict_text(&c.verdict)
                    )
                } else {
                    candidate_verdict_text(&c.verdict)
                }
            );
        }
        let _ = writeln!(s);
    }
    let designs = design_commands(res, fmu, data);
    if !designs.is_empty() {
        let _ = writeln!(s, "## Experiments that would show what these data cannot, or do not settle\n\nEach command proposes an input (within the FMU's input ranges) under which the effect would be visible at the weakest setting of its range, with the predicted visibility; run the experiment, then `gap` on its data.\n");
        for (e, cmd) in &designs {
            let _ = writeln!(s, "- {e}:\n\n  ```sh\n  {cmd}\n  ```\n");
        }
    }
    let _ = writeln!(
        s,
        "## Parameters\n\n| parameter | value | 95 % CI | unit | start |\n|---|---|---|---|---|"
    );
    for (k, e) in &res.parameters {
        let _ = writeln!(
            s,
            "| `{k}` | {} | [{}, {}] | {} | {} |",
            g(e.value),
            g(e.ci_low),
            g(e.ci_high),
            e.unit,
            g(e.start)
        );
    }
    if !res.offsets.is_empty() {
        let _ = writeln!(
            s,
            "\n## Output offsets\n\nEstimated with the parameters (`--offset`): a constant measured − model per output, in the output's SI unit; the errors below include it.\n\n| output | offset | 95 % CI |\n|---|---|---|"
        );
        for (k, e) in &res.offsets {
            let _ = writeln!(
                s,
                "| {k} | {} | [{}, {}] |",
                g(e.value),
                g(e.ci_low),
                g(e.ci_high)
            );
        }
    }
    let _ = writeln!(s, "\n## Errors per output\n\n| output | noise σ | white noise | unexplained beyond white | RMSE before | RMSE base fit | RMSE after | max before | max base fit | max after |\n|---|---|---|---|---|---|---|---|---|---|");
    for (k, o) in &res.outputs {
        let _ = writeln!(
            s,
            "| {k} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
            g(o.noise_sigma),
            g(o.noise_white),
            g(o.unexplained_rms),
            g(o.rmse_before),
            g(o.rmse_base_fit),
            g(o.rmse_after),
            g(o.max_before),
            g(o.max_base_fit),
            g(o.max_after)
        );
    }
    let _ = writeln!(s, "\n\"noise σ\" is the noise model's level (the marginal one for correlated noise), \"white noise\" the level of the data's second differences that no model explains, \"unexplained beyond white\" √(RMSE after² − white²): where noise σ is far above the white level, the correlated part is noise or a misfit no candidate explains, and these two columns bound it. \"before\" is the model as given (start values, `--set` applied, effects off); \"base fit\" the calibrated model without effects; \"after\" the final model with the named effects (after the rounds, with the named effects chosen, its parameters are refitted on the whole trace; errors over the whole trace).\n");
    s.push_str(&extras.markdown());
    let t = &res.timing;
    let _ = writeln!(s, "## Timing\n\ntotal {:.2} s: simulation {:.2} s, fitting {:.2} s; {} simulations on {} threads.\n", t.total_s, t.simulate_s, t.fit_s, t.simulations, t.threads);
    if !plots.is_empty() {
        let _ = writeln!(s, "## Plots\n");
        for p in plots {
            let _ = writeln!(s, "![{p}]({p})\n");
        }
    }
    let _ = writeln!(s, "## Method\n\n{METHOD}");
    s
}

/// Write `report.json`, `report.md` and `traces.csv` into `dir`.
pub fn write(
    res: &GapResult,
    dir: &Path,
    fmu: &str,
    data: &str,
    plots: &[String],
    extras: &Extras,
) -> std::io::Result<()> {
    std::fs::create_dir_all(dir)?;
    let j = to_json(res, fmu, data, extras);
    let json = serde_json::to_string_pretty(&j).unwrap_or_default();
    let md = to_markdown(res, fmu, data, plots, extras);
    for (name, text) in [("report.json", json), ("report.md", md)] {
        host::csv::write_atomically(&dir.join(name), |mut f| {
            std::io::Write::write_all(&mut f, text.as_bytes())
        })?;
    }
    extras.write_traces(dir)?;
    host::csv::write_atomically(&dir.join("traces.csv"), |f| {
        let (mut names, mut columns) = trace_columns(res);
        if !extras.trace_origin.is_empty() {
            names.insert(0, "record".into());
            columns.insert(0, extras.trace_origin.iter().map(|o| o.0 as f64).collect());
            names.insert(1, "record_time".into());
            columns.insert(1, extras.trace_origin.iter().map(|o| o.1).collect());
        }
        host::csv::write_csv_to(
            std::io::BufWriter::new(f),
            &res.traces.time,
            &names,
            &columns,
        )
    })
}

/// The columns of `traces.csv`: per measured output `<output>.measured`, `.nominal` (the model
/// as given), `.base_fit` (the calibrated base model) and `.final` (the final model), each at
/// the data's times exactly as the workflow compared them.
fn trace_columns(res: &GapResult) -> (Vec<String>, Vec<Vec<f64>>) {
    let mut names = Vec::new();
    let mut columns = Vec::new();
    for o in &res.traces.outputs {
        for (kind, c) in [
            ("measured", &o.measured),
            ("nominal", &o.nominal),
            ("base_fit", &o.base_fit),
            ("final", &o.final_fit),
        ] {
            names.push(format!("{}.{kind}", o.name));
            columns.push(c.clone());
        }
    }
    (names, columns)
}

/// The Method section of report.md: how the verdict was reached, in the order the workflow runs.
const METHOD: &str = "\
**Calibration.** The base parameters are fitted by Levenberg–Marquardt to the weighted \
residual (model − measured)/σ, where σ is each output's noise level, estimated from the \
data's second differences (a robust median absolute deviation). Bounds are respected with an \
active set: a parameter at a bound that the descent would push out is held there while the \
others move. The fit is made directly over the training part and, when the model reproduces \
the first quarter of it to within √2 × the noise, also over growing horizons (the first \
quarter, half, then all of it, each fit starting from the previous one's values); the lower \
sum of squares is kept. When the trajectory's phase is sensitive to the parameters (a loop \
near its stability limit, oscillating), a long horizon's cost has many local minima, while \
over a short one the trajectories have not yet drifted apart.

**Candidates.** For each candidate effect a start is chosen by scanning its parameters along \
their ranges: six settings, each simulated with the base parameters at the current fit and \
scored after their linearised readjustment, and simulated with the base parameters as given; \
the lowest sum of squares wins. Candidates are screened by regressing the residual on the \
base Jacobian plus each effect's sensitivities at that start, and the best few are refitted \
from it together with the base parameters.

**Checks before naming.** The base model is refitted from the best candidate's base values, \
so that a gain the base model reaches alone is not credited to the effect; when that re-check \
improves the base fit by ΔBIC ≥ 10 and no candidate still reaches the threshold against it, \
the round is screened and refitted once more from the better base. A refit that lowers the \
held-out error but falls short of the evidence, although the scan says the data could show \
the effect, is restarted from its profile: the base parameters fitted with the effect held at \
each revealing setting, the best of these refitted in full (the base fit may have bent a base \
parameter to imitate the effect, and a local descent from there shrinks the effect instead).

**Naming.** Refits are ranked by BIC with a noise variance per output and an effective sample \
size N(1−ρ)/(1+ρ) from the residual's lag-1 autocorrelation ρ, so that correlated noise is \
not mistaken for evidence. An effect is named only if ΔBIC ≥ 10, the 95 % interval of its \
contribution's scale excludes 0, and it lowers the error on the held-out end of the trace.

**Final fit.** Once the effects are chosen, the model is refitted on the whole trace (the \
held-out end has served for the choice; a model with several friction parameters can fit the \
training part to the noise with values the held-out end contradicts). The parameters and \
intervals reported come from that fit.

**Visibility.** At every scanned setting, the change the effect makes to the outputs, in units \
of each output's noise, is projected off the base Jacobian (what the base parameters can \
absorb, linearised); its sum of squares is the most the effect could lower the chi-square \
there. Naming needs at least ΔBIC plus the BIC penalty of its parameters (`needed`). A \
candidate whose visibility stays below that everywhere in its range cannot be revealed by \
these data: not naming it is no evidence that it is absent, and the verdict says so. The \
weakest setting that reaches it is a detection limit (coarse: the scan's points; optimistic \
where discrete controller decisions make small parameter changes flip samples).";

#[cfg(test)]
mod tests {
    use super::{candidate_verdict_text, left_open_text, visibility_scale};
    use crate::workflow::{
        CandidateVerdict, LeftOpen, Reach, ScreenedHint, Shortfall, Unrevealable,
    };

    #[test]
    fn visibility_reads_as_a_multiple_of_the_threshold() {
        assert_eq!(visibility_scale(9.0, 18.0), "0.50× what naming needs");
        assert_eq!(visibility_scale(3.36e6, 18.7), "1.8e5× what naming needs");
        assert_eq!(visibility_scale(0.0, 18.7), "< 0.01× what naming needs");
        assert_eq!(visibility_scale(f64::NAN, 18.7), "unknown");
    }

    #[test]
    fn a_candidate_verdict_reads_as_its_reasons() {
        let v = CandidateVerdict::NotNamed {
            shortfalls: vec![
                Shortfall::DeltaBicBelow {
                    delta_bic: 4.31,
                    min_delta_bic: 10.0,
                },
                Shortfall::MagnitudeIncludesZero,
                Shortfall::StartNotReproduced,
            ],
            unrevealable: Some(Reach {
                visibility: 9.0,
                needed: 18.0,
            }),
        };
        assert_eq!(
            candidate_verdict_text(&v),
            "not named: ΔBIC = 4.3 < 10; magnitude interval includes 0; does not explain why the \
             record begins away from the model's initial state; these data cannot reveal it \
             (anywhere in its range, after the base parameters readjust, at most 0.50× what \
             naming needs)"
        );
        let named = CandidateVerdict::Named {
            delta_bic: 31.44,
            min_delta_bic: 10.0,
        };
        assert_eq!(
            candidate_verdict_text(&named),
            "named: ΔBIC = 31.4 ≥ 10, magnitude interval excludes 0, held-out error lower"
        );
    }

    #[test]
    fn what_a_round_leaves_open_is_said_with_the_reason() {
        let open = LeftOpen {
            min_delta_bic: 10.0,
            only_screened: vec![ScreenedHint {
                effect: "backlash".into(),
                delta_bic: 3.2,
            }],
            unrevealable: vec![Unrevealable {
                effect: "leak".into(),
                reach: Reach {
                    visibility: 2.0,
                    needed: 18.0,
                },
            }],
        };
        let s = left_open_text(&open);
        assert!(
            s.contains("Only screened, not refitted: backlash (linearised ΔBIC 3.2)"),
            "{s}"
        );
        assert!(s.contains("below the naming threshold of ΔBIC 10"), "{s}");
        assert!(
            s.contains(
                "These data cannot reveal leak (at its strongest setting 0.11× what naming needs)"
            ),
            "{s}"
        );
        let none = LeftOpen {
            only_screened: Vec::new(),
            unrevealable: Vec::new(),
            ..open
        };
        assert_eq!(left_open_text(&none), "");
    }
}
