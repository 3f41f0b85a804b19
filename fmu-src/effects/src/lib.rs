//! The candidate-effect convention: how an FMU tells the gap workflow which physical effects it
//! can switch on, and which parameters are calibrated by default. One reading of it serves the
//! exporter's table check, the validator's findings and the gap workflow's candidate list.
//!
//! - A Boolean parameter `<effect>.enabled`, fixed, start false, switches the effect on.
//! - Every other parameter named `<effect>.<name>` belongs to it and must be a fixed Real with a
//!   unit and a finite range `min < max` (the plausible hardware range the refit searches) that
//!   contains its start.
//! - A parameter whose description starts with the tag `[calibrate]` is calibrated by default;
//!   at least one should be, and a tag anywhere else in a description is a mistake (it is not
//!   read there).
//! - A Real parameter whose description starts with the tag `[initial]` sets the value of a
//!   state at the start time (e.g. a current or speed the record may begin with): its start is
//!   the state at rest, its range `min < max` the states a record may begin in. The gap workflow
//!   estimates these with the base parameters, so a record need not begin at rest. Like
//!   `[calibrate]`, the tag is read only at the start of a description.

use fmi_types::{VarKind, Variability};
use std::fmt;

/// What the convention needs to know of one parameter (causality `parameter`).
#[derive(Clone, Copy, Debug)]
pub struct Param<'a> {
    /// Variable name.
    pub name: &'a str,
    /// Type element.
    pub kind: VarKind,
    /// Variability.
    pub variability: Variability,
    /// Start value (Booleans as 0/1), None when absent or not numeric.
    pub start: Option<f64>,
    /// Effective `min` (from the variable or its declared type).
    pub min: Option<f64>,
    /// Effective `max`.
    pub max: Option<f64>,
    /// True when the variable (or its declared type) has a unit.
    pub has_unit: bool,
    /// Description ("" when absent).
    pub description: &'a str,
}

/// One candidate effect: its switch and its Real parameters (indices into the scanned list,
/// in declaration order).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Effect {
    /// `<effect>`
    pub name: String,
    /// Index of `<effect>.enabled`.
    pub switch: usize,
    /// Indices of the Real `<effect>.<name>` parameters.
    pub params: Vec<usize>,
}

/// A departure from the convention, for one variable.
#[derive(Clone, Debug, PartialEq)]
pub enum Problem {
    /// `<effect>.enabled` is not a fixed Boolean parameter.
    SwitchNotFixedBoolean,
    /// `<effect>.enabled` does not start false.
    SwitchStartsOn,
    /// No parameter `<effect>.<name>` belongs to the switch.
    NoParameters { prefix: String },
    /// An effect parameter that is not Real.
    ParameterNotReal,
    /// An effect parameter that is not fixed.
    ParameterNotFixed,
    /// An effect parameter without a unit.
    ParameterWithoutUnit,
    /// An effect parameter without a finite range min < max.
    ParameterWithoutRange,
    /// An effect parameter whose start lies outside its range.
    StartOutsideRange { start: f64, min: f64, max: f64 },
    /// `[calibrate]` appears in a description but not at its start.
    CalibrateTagNotAtStart,
    /// No parameter is tagged `[calibrate]` (reported for the model, variable "").
    NoCalibrateTag,
    /// `[initial]` appears in a description but not at its start.
    InitialTagNotAtStart,
    /// A parameter tagged `[initial]` that is not a Real with a finite range `min < max`
    /// containing its start.
    InitialWithoutRange,
}

impl fmt::Display for Problem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Problem::SwitchNotFixedBoolean => {
                f.write_str("an effect switch must be a fixed Boolean parameter")
            }
            Problem::SwitchStartsOn => {
                f.write_str("an effect switch must start false (effect off)")
            }
            Problem::NoParameters { prefix } => {
                write!(f, "no parameter '{prefix}.<name>' belongs to this effect")
            }
            Problem::ParameterNotReal => f.write_str("an effect parameter must be Real"),
            Problem::ParameterNotFixed => f.write_str("an effect parameter must be fixed"),
            Problem::ParameterWithoutUnit => f.write_str("an effect parameter needs a unit"),
            Problem::ParameterWithoutRange => f.write_str(
                "an effect parameter needs finite min < max (the plausible hardware range)",
            ),
            Problem::StartOutsideRange { start, min, max } => {
                write!(f, "start {start} is outside [{min}, {max}]")
            }
            Problem::CalibrateTagNotAtStart => f.write_str(
                "the tag [calibrate] is only read at the start of a description; here it is not",
            ),
            Problem::NoCalibrateTag => f.write_str(
                "no parameter description starts with [calibrate] (the default calibration set)",
            ),
            Problem::InitialTagNotAtStart => f.write_str(
                "the tag [initial] is only read at the start of a description; here it is not",
            ),
            Problem::InitialWithoutRange => f.write_str(
                "an initial-state parameter ([initial]) must be a Real with finite min < max \
                 containing its start (the states a record may begin in); it is not estimated",
            ),
        }
    }
}

/// The convention as read from a parameter list.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Convention {
    /// Effects in the declaration order of their switches.
    pub effects: Vec<Effect>,
    /// Real parameters tagged `[calibrate]` that belong to no effect.
    pub calibrate: Vec<usize>,
    /// Real parameters tagged `[initial]` with a usable range that belong to no effect: the
    /// initial state, estimated with the base parameters.
    pub initial: Vec<usize>,
    /// Departures, each with the index of its variable (None: the model as a whole).
    pub problems: Vec<(Option<usize>, Problem)>,
}

const TAG: &str = "[calibrate]";
const INITIAL_TAG: &str = "[initial]";

/// True when the description starts (after white space) with `[calibrate]`.
pub fn is_tagged_calibrate(description: &str) -> bool {
    description.trim_start().starts_with(TAG)
}

/// True when the description starts (after white space) with `[initial]`.
pub fn is_tagged_initial(description: &str) -> bool {
    description.trim_start().starts_with(INITIAL_TAG)
}

/// Reads the convention from the parameters of a model.
pub fn scan(params: &[Param]) -> Convention {
    let mut c = Convention::default();
    for (i, p) in params.iter().enumerate() {
        let Some(prefix) = p.name.strip_suffix(".enabled").filter(|s| !s.is_empty()) else {
            continue;
        };
        let is_bool = p.kind == VarKind::Boolean;
        if !is_bool || p.variability != Variability::Fixed {
            c.problems.push((Some(i), Problem::SwitchNotFixedBoolean));
        }
        if p.start != Some(0.0) {
            c.problems.push((Some(i), Problem::SwitchStartsOn));
        }
        let dotted = format!("{prefix}.");
        let members: Vec<usize> = (0..params.len())
            .filter(|&j| j != i && params[j].name.starts_with(&dotted))
            .collect();
        if members.is_empty() {
            let prefix = prefix.to_string();
            c.problems.push((Some(i), Problem::NoParameters { prefix }));
        }
        let mut reals = Vec::new();
        for j in members {
            match member_problems(&params[j]) {
                Err(e) => c.problems.push((Some(j), e)),
                Ok(problems) => {
                    c.problems
                        .extend(problems.into_iter().map(|e| (Some(j), e)));
                    reals.push(j);
                }
            }
        }
        if is_bool {
            let name = prefix.to_string();
            c.effects.push(Effect {
                name,
                switch: i,
                params: reals,
            });
        }
    }
    for (i, p) in params.iter().enumerate() {
        if is_tagged_calibrate(p.description) {
            let in_effect = c.effects.iter().any(|e| e.params.contains(&i));
            if p.kind == VarKind::Real && !in_effect {
                c.calibrate.push(i);
            }
        } else if p.description.contains(TAG) {
            c.problems.push((Some(i), Problem::CalibrateTagNotAtStart));
        }
    }
    if !params.iter().any(|p| is_tagged_calibrate(p.description)) {
        c.problems.push((None, Problem::NoCalibrateTag));
    }
    scan_initial(params, &mut c);
    c
}

/// The initial-state parameters (`[initial]`) and their departures.
fn scan_initial(params: &[Param], c: &mut Convention) {
    for (i, p) in params.iter().enumerate() {
        if !is_tagged_initial(p.description) {
            if p.description.contains(INITIAL_TAG) {
                c.problems.push((Some(i), Problem::InitialTagNotAtStart));
            }
            continue;
        }
        if c.effects.iter().any(|e| e.params.contains(&i)) {
            continue;
        }
        let ranged = match (p.min, p.max, p.start) {
            (Some(min), Some(max), Some(start)) => {
                min.is_finite() && max.is_finite() && min < max && (min..=max).contains(&start)
            }
            _ => false,
        };
        if p.kind == VarKind::Real && ranged {
            c.initial.push(i);
        } else {
            c.problems.push((Some(i), Problem::InitialWithoutRange));
        }
    }
}

/// Problems of one effect member: Err when it is not Real (then it cannot be a member at all).
fn member_problems(p: &Param) -> Result<Vec<Problem>, Problem> {
    if p.kind != VarKind::Real {
        return Err(Problem::ParameterNotReal);
    }
    let mut out = Vec::new();
    if p.variability != Variability::Fixed {
        out.push(Problem::ParameterNotFixed);
    }
    if !p.has_unit {
        out.push(Problem::ParameterWithoutUnit);
    }
    match (p.min, p.max) {
        (Some(min), Some(max)) if min.is_finite() && max.is_finite() && min < max => {
            if let Some(start) = p.start.filter(|s| *s < min || *s > max) {
                out.push(Problem::StartOutsideRange { start, min, max });
            }
        }
        _ => out.push(Problem::ParameterWithoutRange),
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::{scan, Param, Problem};
    use fmi_types::{VarKind, Variability};

    fn real<'a>(name: &'a str, range: Option<(f64, f64)>, description: &'a str) -> Param<'a> {
        Param {
            name,
            kind: VarKind::Real,
            variability: Variability::Fixed,
            start: Some(1.0),
            min: range.map(|r| r.0),
            max: range.map(|r| r.1),
            has_unit: true,
            description,
        }
    }

    fn switch(name: &str, start: f64) -> Param<'_> {
        Param {
            name,
            kind: VarKind::Boolean,
            variability: Variability::Fixed,
            start: Some(start),
            min: None,
            max: None,
            has_unit: false,
            description: "switch",
        }
    }

    #[test]
    fn effects_and_the_calibration_set_follow_the_names_and_tags() {
        let params = [
            real("load_mass", Some((0.0, 20.0)), "[calibrate] mass"),
            switch("seal_friction.enabled", 0.0),
            real("seal_friction.coulomb", Some((0.5, 500.0)), "Coulomb"),
            real("seal_friction.viscous", Some((0.5, 5000.0)), "viscous"),
            switch("internal_controller", 1.0),
            switch("valve_overlap.enabled", 0.0),
            real(
                "valve_overlap.width",
                Some((0.01, 2.0)),
                "[calibrate] width",
            ),
            real("seal_friction_like", None, "  [calibrate] not a member"),
        ];
        let c = scan(&params);
        let names: Vec<_> = c
            .effects
            .iter()
            .map(|e| (e.name.as_str(), e.params.clone()))
            .collect();
        assert_eq!(
            names,
            [("seal_friction", vec![2, 3]), ("valve_overlap", vec![6])]
        );
        // An effect parameter is never a base calibration parameter, even when tagged.
        assert_eq!(c.calibrate, [0, 7]);
        assert_eq!(c.problems, []);
    }

    #[test]
    fn every_departure_is_named_with_its_variable() {
        let mut on = switch("backlash.enabled", 1.0);
        on.variability = Variability::Tunable;
        let mut flag = switch("backlash.flag", 0.0);
        flag.description = "a Boolean member";
        let params = [
            on,
            real("backlash.width", None, "no range"),
            flag,
            real("backlash.gap", Some((1.0, 2.0)), "start 1 is fine"),
            real("backlash.late", Some((2.0, 3.0)), "start 1 below min"),
            real("mass", Some((0.0, 1.0)), "mass [calibrate]"),
            switch("lonely.enabled", 0.0),
        ];
        let c = scan(&params);
        assert_eq!(
            c.problems,
            [
                (Some(0), Problem::SwitchNotFixedBoolean),
                (Some(0), Problem::SwitchStartsOn),
                (Some(1), Problem::ParameterWithoutRange),
                (Some(2), Problem::ParameterNotReal),
                (
                    Some(4),
                    Problem::StartOutsideRange {
                        start: 1.0,
                        min: 2.0,
                        max: 3.0
                    }
                ),
                (
                    Some(6),
                    Problem::NoParameters {
                        prefix: "lonely".into()
                    }
                ),
                (Some(5), Problem::CalibrateTagNotAtStart),
                (None, Problem::NoCalibrateTag),
            ]
        );
        assert_eq!(c.effects[0].params, [1, 3, 4]);
        assert!(c.calibrate.is_empty());
    }

    #[test]
    fn initial_state_parameters_need_the_tag_first_and_a_range() {
        let params = [
            real("mass", Some((0.0, 2.0)), "[calibrate] mass"),
            real("speed_start", Some((-10.0, 10.0)), " [initial] speed at t0"),
            real("angle_start", None, "[initial] no range"),
            real("current_start", Some((-1.0, 1.0)), "current [initial]"),
            real("far_start", Some((2.0, 3.0)), "[initial] start 1 outside"),
        ];
        let c = scan(&params);
        assert_eq!(c.initial, [1]);
        assert_eq!(c.calibrate, [0]);
        assert_eq!(
            c.problems,
            [
                (Some(2), Problem::InitialWithoutRange),
                (Some(3), Problem::InitialTagNotAtStart),
                (Some(4), Problem::InitialWithoutRange),
            ]
        );
    }
}
