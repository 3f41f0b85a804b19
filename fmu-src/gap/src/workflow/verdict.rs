//! Verdict texts: convention warnings, candidates the data cannot reveal, reasons not to name.

use super::Candidate;
use crate::spec::{self, ParamSpec};

/// One line per departure from the candidate-effect convention, naming the variable
/// ("model" for the FMU as a whole). The missing `[calibrate]` tag is not reported when the
/// user names the parameters to fit (`fit_given`).
pub(super) fn convention_warnings(params: &[ParamSpec], fit_given: bool) -> Vec<String> {
    spec::convention(params)
        .problems
        .into_iter()
        .filter(|(_, p)| !(fit_given && *p == effects::Problem::NoCalibrateTag))
        .map(|(i, p)| match i {
            Some(i) => format!("{}: {p}", params[i].name),
            None => format!("model: {p}"),
        })
        .collect()
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

/// Verdict sentence for the candidates these data could show but that were only screened, not
/// refitted (empty if none): why they were not refitted and what "not named" then means.
pub(super) fn only_screened(round: &[Candidate], min_delta_bic: f64) -> String {
    let names: Vec<String> = round
        .iter()
        .filter(|c| !c.refit && c.visibility.is_some() && c.detectable())
        .map(|c| format!("{} (linearised ΔBIC {:.1})", c.effect, c.delta_bic))
        .collect();
    if names.is_empty() {
        return String::new();
    }
    format!(
        ". Only screened, not refitted: {}. The data could show each of them from its weakest \
         detectable setting on (see the table), and the linearised test puts each below the \
         naming threshold of ΔBIC {min_delta_bic}: none is present at that strength, though a \
         weaker one, or one the linearisation misjudges (a dead zone), is not ruled out",
        names.join(", ")
    )
}

/// Verdict sentence listing the candidates these data cannot reveal (empty if none): for them
/// "not named" is no evidence of absence, and the user needs other excitation or sensors.
pub(super) fn hidden_from_data(round: &[Candidate]) -> String {
    let hidden: Vec<String> = round
        .iter()
        .filter(|c| !c.detectable())
        .map(|c| {
            format!(
                "{} (at its strongest setting {})",
                c.effect,
                visibility_scale(c.visibility.unwrap_or(0.0), c.visibility_needed)
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
mod text_tests {
    use super::{hidden_from_data, only_screened, visibility_scale};
    use crate::workflow::reliably_visible;
    use crate::workflow::BTreeMap;
    use crate::workflow::Candidate;
    use crate::workflow::VisibilityPoint;

    #[test]
    fn reliably_visible_means_named_in_95_of_100_noisy_datasets() {
        // Monte Carlo of the drop a one-parameter effect of visibility v brings on noisy data,
        // (√v + Z)², against the closed-form 5 % quantile the rule uses.
        let needed = 17.9;
        let share = |v: f64| {
            let mut s: u64 = 12345;
            let mut u = || {
                s = s
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                ((s >> 11) as f64 + 0.5) / (1u64 << 53) as f64
            };
            let n = 20000;
            (0..n)
                .filter(|_| {
                    let z = (-2.0 * libm::log(u())).sqrt() * libm::cos(std::f64::consts::TAU * u());
                    crate::stats::sq(v.sqrt() + z) >= needed
                })
                .count() as f64
                / n as f64
        };
        let edge = crate::stats::sq(needed.sqrt() + 1.644_853_6_f64);
        assert!((share(edge) - 0.95).abs() < 0.01, "{}", share(edge));
        assert!(reliably_visible(edge * 1.001, needed) && !reliably_visible(edge * 0.999, needed));
        // Just at the threshold an effect is named only about half the time.
        assert!((share(needed) - 0.5).abs() < 0.05, "{}", share(needed));
        assert!(!reliably_visible(needed, needed));
    }

    #[test]
    fn visibility_reads_as_a_multiple_of_the_threshold() {
        assert_eq!(visibility_scale(9.0, 18.0), "0.50× what naming needs");
        assert_eq!(visibility_scale(3.36e6, 18.7), "1.8e5× what naming needs");
        assert_eq!(visibility_scale(0.0, 18.7), "< 0.01× what naming needs");
        assert_eq!(visibility_scale(f64::NAN, 18.7), "unknown");
    }

    #[test]
    fn a_candidate_shown_only_above_its_weakest_setting_may_hide_unless_named() {
        let point = |fraction: f64, v: f64| VisibilityPoint {
            parameters: BTreeMap::new(),
            fraction,
            visibility: Some(v),
        };
        let mut c = Candidate::screened_only("backlash", -3.0, -3.0);
        c.visibility = Some(500.0);
        c.visibility_needed = 18.0;
        // Weakest setting at 1.2× what naming needs: named only about 6 times in 10.
        c.visibility_scan = vec![point(0.0, 21.6), point(1.0, 500.0)];
        assert!(c.detectable() && !c.detectable_at_weakest() && c.may_hide());
        // At 3× it shows with 95 % probability: nothing hides.
        c.visibility_scan[0].visibility = Some(54.0);
        assert!(c.detectable_at_weakest() && !c.may_hide());
        // Named: present, nothing to design for.
        c.visibility_scan[0].visibility = Some(2.0);
        c.named = true;
        assert!(!c.may_hide());
        // Shown at its weakest, but its refit was inconclusive: the data do not settle it.
        c.named = false;
        c.visibility_scan[0].visibility = Some(54.0);
        c.inconclusive = true;
        assert!(c.detectable_at_weakest() && c.may_hide());
        // The weak end may be the top of the range (a valve lag at its highest frequency).
        c.inconclusive = false;
        c.visibility_scan = vec![point(0.0, 500.0), point(0.5, 80.0), point(1.0, 21.6)];
        assert!(!c.detectable_at_weakest() && c.may_hide());
    }

    #[test]
    fn a_positive_linearised_delta_bic_below_the_threshold_is_a_hint_to_settle() {
        let shown_at_weakest = |c: Candidate| {
            let mut c = c;
            c.visibility = Some(500.0);
            c.visibility_needed = 18.0;
            c.visibility_scan = vec![VisibilityPoint {
                parameters: BTreeMap::new(),
                fraction: 0.0,
                visibility: Some(400.0),
            }];
            c
        };
        let hint = shown_at_weakest(Candidate::screened_only("valve", 2.3, 2.3).hinted(10.0));
        assert!(hint.inconclusive && hint.may_hide());
        for delta_bic in [-1.8, 10.0, 25.0] {
            let c =
                shown_at_weakest(Candidate::screened_only("valve", delta_bic, 0.0).hinted(10.0));
            assert!(!c.inconclusive && !c.may_hide(), "{delta_bic}");
        }
        // A refitted candidate's own ΔBIC decides (in `choose`), not the linearised one.
        let mut refitted = Candidate::screened_only("valve", 2.3, 2.3);
        refitted.refit = true;
        assert!(!refitted.hinted(10.0).inconclusive);
    }

    #[test]
    fn a_detectable_candidate_only_screened_is_said_so_with_the_reason() {
        let mut seen = Candidate::screened_only("backlash", 3.2, 3.2);
        seen.visibility = Some(500.0);
        seen.visibility_needed = 18.0;
        let mut hidden = Candidate::screened_only("leak", 1.0, 1.0);
        hidden.visibility = Some(2.0);
        hidden.visibility_needed = 18.0;
        let s = only_screened(&[seen.clone(), hidden.clone()], 10.0);
        assert!(
            s.contains("Only screened, not refitted: backlash (linearised ΔBIC 3.2)"),
            "{s}"
        );
        assert!(s.contains("below the naming threshold of ΔBIC 10"), "{s}");
        assert!(!s.contains("leak"), "{s}");
        // an undetectable one goes to the other sentence, on the readable scale
        let h = hidden_from_data(&[seen, hidden]);
        assert!(
            h.contains("leak (at its strongest setting 0.11× what naming needs)"),
            "{h}"
        );
        // a refitted candidate is not "only screened"
        let mut refitted = Candidate::screened_only("friction", 30.0, 30.0);
        refitted.refit = true;
        refitted.visibility = Some(500.0);
        assert_eq!(only_screened(&[refitted], 10.0), "");
    }
}

#[cfg(test)]
mod convention_tests {
    use super::convention_warnings;
    use crate::ParamSpec;

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
