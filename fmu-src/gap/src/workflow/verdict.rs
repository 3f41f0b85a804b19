//! Verdict texts: convention warnings, candidates the data cannot reveal, reasons not to name.

use super::*;

/// One line per departure from the candidate-effect convention, naming the variable
/// ("model" for the FMU as a whole). The missing `[calibrate]` tag is not reported when the
/// user names the parameters to fit (`fit_given`).
pub(super) fn convention_warnings(params: &[ParamSpec], fit_given: bool) -> Vec<String> {
    spec::convention(params)
        .problems
        .into_iter()
        .filter(|(_, p)| !(fit_given && *p == fmi2_types::effects::Problem::NoCalibrateTag))
        .map(|(i, p)| match i {
            Some(i) => format!("{}: {p}", params[i].name),
            None => format!("model: {p}"),
        })
        .collect()
}

/// Verdict sentence listing the candidates these data cannot reveal (empty if none): for them
/// "not named" is no evidence of absence, and the user needs other excitation or sensors.
pub(super) fn hidden_from_data(round: &[Candidate]) -> String {
    let hidden: Vec<String> = round
        .iter()
        .filter(|c| !c.detectable())
        .map(|c| {
            format!(
                "{} (at most Δχ² = {:.1}, naming needs {:.1})",
                c.effect,
                c.visibility.unwrap_or(0.0),
                c.visibility_needed
            )
        })
        .collect();
    if hidden.is_empty() {
        String::new()
    } else {
        format!(
            ". These data cannot reveal {}: even at the strongest setting in range, the base parameters absorb all but a change below the naming threshold, so their absence is not shown",
            hidden.join(", ")
        )
    }
}

/// Why a refitted candidate may not be named (empty: it may).
pub(super) fn reasons(c: &Candidate, min_delta_bic: f64, no_holdout: bool) -> Vec<String> {
    let mut why = Vec::new();
    if c.delta_bic == f64::NEG_INFINITY {
        why.push("refit failed".to_string());
    } else if c.delta_bic < min_delta_bic {
        why.push(format!("ΔBIC = {:.1} < {}", c.delta_bic, min_delta_bic));
    }
    if !c
        .magnitude
        .as_ref()
        .map(|m| m.ci_low > 0.0)
        .unwrap_or(false)
    {
        why.push("magnitude interval includes 0".to_string());
    }
    let hold_ok = match (c.holdout_sse_with, c.holdout_sse_without) {
        (Some(w), Some(wo)) => w < wo,
        _ => no_holdout,
    };
    if !hold_ok {
        why.push("does not lower the held-out error".to_string());
    }
    why
}

#[cfg(test)]
mod convention_tests {
    use super::*;

    fn params() -> Vec<ParamSpec> {
        vec![
            ParamSpec::real(
                "inertia",
                1.0,
                Some(0.1),
                Some(10.0),
                "kg.m2",
                "rotor [calibrate]",
            ),
            ParamSpec::flag("backlash.enabled", false, "switch"),
            ParamSpec::real("backlash.width", 0.01, None, None, "rad", "gap width"),
        ]
    }

    #[test]
    fn each_departure_is_a_warning_naming_its_variable() {
        let w = convention_warnings(&params(), false);
        assert!(
            w.iter()
                .any(|s| s.starts_with("inertia: ") && s.contains("[calibrate]")),
            "{w:?}"
        );
        assert!(
            w.iter()
                .any(|s| s.starts_with("backlash.width: ") && s.contains("min < max")),
            "{w:?}"
        );
        assert!(w.iter().any(|s| s.starts_with("model: ")), "{w:?}");
        // With --fit the missing default calibration set is no departure.
        let w = convention_warnings(&params(), true);
        assert!(!w.iter().any(|s| s.starts_with("model: ")), "{w:?}");
    }
}
