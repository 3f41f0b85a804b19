//! Description rules both FMI versions state alike (FMI 2.0.4 chapter 2.2, FMI 3.0.2 section
//! 2.4), written once: names defined once, model identifiers that are C identifiers, and when a
//! variable needs or may not have a start value.

use super::Finding;
use host::md::{Initial, Variability};
use std::collections::HashMap;

/// Whether `s` is a C identifier (a `modelIdentifier` names the binary and prefixes its
/// functions: FMI 2.0.4 sections 3.3.1 and 4.3.1, FMI 3.0.2 section 2.4.1).
pub(crate) fn is_c_identifier(s: &str) -> bool {
    let mut chars = s.chars();
    matches!(chars.next(), Some(c) if c.is_ascii_alphabetic() || c == '_')
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
}

/// Whether a `modelIdentifier` names one file in a platform folder (`<id>.so` with no path
/// separator, NUL or dot segment), so that the archive can be searched for its library even when
/// it is not a C identifier: an FMU naming its model `watertank-c` is told both that the name is
/// invalid and whether `binaries/<platform>/watertank-c.so` is there.
pub(crate) fn names_one_file(id: &str) -> bool {
    !id.is_empty() && id.len() <= 255 && id != "." && id != ".." && !id.contains(['/', '\\', '\0'])
}

/// Whether an effective `initial` is approx or calculated: what makes an output or a state an
/// initial unknown (FMI 2.0.4 section 2.2.8, FMI 3.0.2 section 2.4.8).
pub(crate) fn approx_or_calculated(initial: Option<Initial>) -> bool {
    matches!(initial, Some(Initial::Approx | Initial::Calculated))
}

/// What is wrong with a `modelIdentifier`, if it is not a C identifier.
pub(crate) fn identifier_problem(id: &str) -> Option<String> {
    (!is_c_identifier(id)).then(|| format!("modelIdentifier \"{id}\" is not a valid C identifier"))
}

/// Records `name` as defined on `line` in `seen`; when it was defined before, what the finding
/// says (`unit 'm' is already defined on line 3`, naming the latest earlier definition).
pub(crate) fn defined_again<'a>(
    seen: &mut HashMap<&'a str, usize>,
    (kind, verb): (&str, &str),
    name: &'a str,
    line: usize,
) -> Option<String> {
    let first = seen.insert(name, line)?;
    Some(format!("{kind} '{name}' is already {verb} on line {first}"))
}

/// What is wrong with a variable's name (FMI 2.0.4 section 2.2.7, FMI 3.0.2 section 2.4.7): empty,
/// or the name of an earlier variable (recorded in `names`); as (check, message).
pub(crate) fn name_problems<'a>(
    names: &mut HashMap<&'a str, usize>,
    name: &'a str,
    line: usize,
) -> Vec<(&'static str, String)> {
    let mut problems = Vec::new();
    if name.trim().is_empty() {
        problems.push(("variable-name", "empty variable name".to_string()));
    }
    if let Some(m) = defined_again(names, ("name", "used"), name, line) {
        problems.push(("unique-names", m));
    }
    problems
}

/// What is wrong with a variable's start value, if anything (FMI 2.0.4 section 2.2.7, FMI 3.0.2
/// section 2.4.7.5): it is required for inputs, constants and `initial` exact or approx, and not
/// allowed for the independent variable and `initial` calculated. The text starts the finding.
pub(crate) fn start_problem(
    (input, independent): (bool, bool),
    variability: Variability,
    initial: Option<Initial>,
    has_start: bool,
) -> Option<&'static str> {
    let required = input
        || variability == Variability::Constant
        || matches!(initial, Some(Initial::Exact | Initial::Approx));
    let forbidden = independent || initial == Some(Initial::Calculated);
    match has_start {
        false if required => Some("start is required"),
        true if forbidden => Some("start is not allowed"),
        _ => None,
    }
}

/// What is wrong with the attributes of `<fmiModelDescription>` both versions require (FMI
/// 2.0.4 section 2.2.1, FMI 3.0.2 section 2.4.1), as (check, message): `fmiVersion` not the
/// version's (`accepted`; `expected` says which), and each of `required` (check, attribute,
/// value) missing or empty.
pub(crate) fn root_problems(
    (version, accepted, expected): (&str, bool, &str),
    required: [(&'static str, &str, &str); 2],
) -> Vec<(&'static str, String)> {
    let mut problems = Vec::new();
    if !accepted {
        let m = format!("fmiVersion is \"{version}\", expected \"{expected}\"");
        problems.push(("fmi-version", m));
    }
    for (check, attribute, value) in required {
        if value.trim().is_empty() {
            problems.push((check, format!("{attribute} is missing or empty")));
        }
    }
    problems
}

/// A group of rules on a description of type `M`: appends a finding for each departure.
pub(crate) type Rule<M> = fn(&M, &mut Vec<Finding>);

/// The findings of each group of `rules` on `md`, in their order.
pub(crate) fn apply<M>(md: &M, rules: &[Rule<M>]) -> Vec<Finding> {
    let mut f = Vec::new();
    for rule in rules {
        rule(md, &mut f);
    }
    f
}
