//! Verdicts as typed values: why a candidate was or was not named ([`CandidateVerdict`]), what
//! a run concluded ([`Verdict`]), and what its last round leaves open ([`LeftOpen`]); `report`
//! puts them into words. Also the departures from the candidate-effect convention.

use super::Candidate;
use crate::sim::SimError;
use crate::spec::{self, ParamSpec};
use serde::{Serialize, Serializer};

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

/// How visible an effect is: the most it could explain anywhere in its range (chi-square drop,
/// linearised; see `Candidate::visibility`) and the drop naming it needs.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Reach {
    pub visibility: f64,
    pub needed: f64,
}

/// One reason a refitted candidate is not named.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Shortfall {
    /// The refit failed from every start.
    RefitFailed,
    /// Its ΔBIC stays below the naming threshold.
    DeltaBicBelow { delta_bic: f64, min_delta_bic: f64 },
    /// The 95 % interval of its contribution's scale includes 0.
    MagnitudeIncludesZero,
    /// It does not lower the error on the held-out part.
    HoldoutNotLower,
    /// The record begins away from the model's initial state and its fit does not explain why.
    StartNotReproduced,
    /// It covers only `share` of the way from the current misfit to the data's white noise level
    /// (in log sum of squares), less than `min_share`: it helps, but the disagreement stands.
    ExplainsLittle { share: f64, min_share: f64 },
}

/// Why a candidate of one round was or was not named.
#[derive(Clone, Debug, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum CandidateVerdict {
    /// Refitted, not yet checked against the naming criteria.
    Unchecked,
    /// Screened by the linearised test, not refitted.
    ScreenedOnly,
    /// Screened against the final model (with these named effects), whose residuals are at the
    /// noise level.
    ScreenedAgainstFinal { named: Vec<String> },
    /// Its refit failed from every start.
    RefitFailed {
        #[serde(serialize_with = "as_text")]
        cause: SimError,
    },
    /// Named: ΔBIC at least the threshold, magnitude interval excluding 0, held-out error lower.
    Named { delta_bic: f64, min_delta_bic: f64 },
    /// Not named, for these reasons; `unrevealable` when these data cannot reveal it anywhere in
    /// its range.
    NotNamed {
        shortfalls: Vec<Shortfall>,
        unrevealable: Option<Reach>,
    },
    /// Not checked: a higher-ranked candidate was named.
    NotConsidered,
}

/// A simulation error as its message.
fn as_text<S: Serializer>(e: &SimError, s: S) -> Result<S::Ok, S::Error> {
    s.collect_str(e)
}

/// A candidate the data could show that was only screened, with its linearised ΔBIC.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ScreenedHint {
    pub effect: String,
    pub delta_bic: f64,
}

/// A candidate these data cannot reveal, with its reach at its strongest setting.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Unrevealable {
    pub effect: String,
    pub reach: Reach,
}

/// What the candidates of a round that named nothing leave open: those only screened although
/// the data could show them, and those the data cannot reveal.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LeftOpen {
    pub min_delta_bic: f64,
    pub only_screened: Vec<ScreenedHint>,
    pub unrevealable: Vec<Unrevealable>,
}

/// Why the closest candidate of a round that named nothing fell short.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum ClosestShortfall {
    /// Refitted, and short for these reasons.
    Refitted { shortfalls: Vec<Shortfall> },
    /// Not refitted: its linearised ΔBIC stays below the threshold.
    NotRefitted { delta_bic: f64, min_delta_bic: f64 },
}

/// What a run concluded from its rounds (the disagreement the final model leaves, if any, is
/// `GapResult::disagreement`).
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Verdict {
    /// The rounds named these effects (none: no missing effect found) and ran their course.
    Named { effects: Vec<String> },
    /// The calibrated base model's residuals are consistent with noise: every output at its
    /// noise level and white, and no candidate's linearised ΔBIC reaches the threshold.
    ConsistentWithNoise {
        /// The candidate with the largest linearised ΔBIC (None: no candidate).
        closest: Option<String>,
        best_delta_bic: f64,
        open: LeftOpen,
    },
    /// A round named nothing (after the effects `named`): its closest candidate and why.
    NothingFurther {
        named: Vec<String>,
        closest: String,
        why: ClosestShortfall,
        open: LeftOpen,
    },
}

impl Verdict {
    /// The effects the run named.
    pub fn named(&self) -> &[String] {
        match self {
            Verdict::Named { effects } => effects,
            Verdict::ConsistentWithNoise { .. } => &[],
            Verdict::NothingFurther { named, .. } => named,
        }
    }
}

/// What the candidates of `round` leave open ([`LeftOpen`]).
pub(super) fn left_open(round: &[Candidate], min_delta_bic: f64) -> LeftOpen {
    let only_screened = round
        .iter()
        .filter(|c| !c.refit && c.visibility.is_some() && c.detectable())
        .map(|c| ScreenedHint {
            effect: c.effect.clone(),
            delta_bic: c.delta_bic,
        })
        .collect();
    let unrevealable = round
        .iter()
        .filter(|c| !c.detectable())
        .map(|c| Unrevealable {
            effect: c.effect.clone(),
            reach: c.reach(),
        })
        .collect();
    LeftOpen {
        min_delta_bic,
        only_screened,
        unrevealable,
    }
}

/// Why a refitted candidate may not be named (empty: it may).
pub(super) fn shortfalls(c: &Candidate, min_delta_bic: f64, no_holdout: bool) -> Vec<Shortfall> {
    let mut why = Vec::new();
    if c.delta_bic == f64::NEG_INFINITY {
        why.push(Shortfall::RefitFailed);
    } else if c.delta_bic < min_delta_bic {
        why.push(Shortfall::DeltaBicBelow {
            delta_bic: c.delta_bic,
            min_delta_bic,
        });
    }
    if !c
        .magnitude
        .as_ref()
        .map(|m| m.ci_low > 0.0)
        .unwrap_or(false)
    {
        why.push(Shortfall::MagnitudeIncludesZero);
    }
    let hold_ok = match (c.holdout_sse_with, c.holdout_sse_without) {
        (Some(w), Some(wo)) => w < wo,
        _ => no_holdout,
    };
    if !hold_ok {
        why.push(Shortfall::HoldoutNotLower);
    }
    why
}

#[cfg(test)]
mod text_tests {
    use super::{left_open, Reach, ScreenedHint, Unrevealable};
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
        let open = left_open(&[seen, hidden], 10.0);
        assert_eq!(
            open.only_screened,
            vec![ScreenedHint {
                effect: "backlash".into(),
                delta_bic: 3.2
            }]
        );
        assert_eq!(open.min_delta_bic, 10.0);
        // an undetectable one is listed as such, with its reach
        assert_eq!(
            open.unrevealable,
            vec![Unrevealable {
                effect: "leak".into(),
                reach: Reach {
                    visibility: 2.0,
                    needed: 18.0
                }
            }]
        );
        // a refitted candidate is not "only screened"
        let mut refitted = Candidate::screened_only("friction", 30.0, 30.0);
        refitted.refit = true;
        refitted.visibility = Some(500.0);
        assert!(left_open(&[refitted], 10.0).only_screened.is_empty());
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
