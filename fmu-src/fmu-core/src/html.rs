//! `documentation/index.html` generated from the same variable table as the model description,
//! with the model's own fragment (equations, sources, derivations).

use crate::xml::fmt_f64;
use crate::{Causality, Model, VarType};
use std::fmt::Write;

/// Escape text for HTML.
pub fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

fn opt(x: Option<f64>) -> String {
    x.map(fmt_f64).unwrap_or_default()
}

/// The interfaces the FMU offers, from the model: Co-Simulation always; Model Exchange (with its
/// numbers of continuous states and event indicators) where the model implements it; directional
/// derivatives, in both interfaces, where it has an analytic Jacobian.
pub fn interfaces<M: Model>() -> String {
    let Some(me) = M::model_exchange() else {
        return "Co-Simulation".to_string();
    };
    let plural = |n: usize, what: &str| format!("{n} {what}{}", if n == 1 { "" } else { "s" });
    let derivatives = if me.provides_jacobian {
        ", both with directional derivatives"
    } else {
        ""
    };
    format!(
        "Model Exchange ({}, {}) and Co-Simulation{derivatives}",
        plural(me.states, "continuous state"),
        plural(me.event_indicators, "event indicator")
    )
}

/// The page's interface line: FMI version, [`interfaces`] and GUID.
pub fn interface_line<M: Model>() -> String {
    format!(
        "<p>FMI 2.0 {}, GUID <code>{}</code>.</p>\n",
        escape(&interfaces::<M>()),
        crate::xml::guid::<M>()
    )
}

/// The whole documentation page.
pub fn documentation<M: Model>() -> String {
    let mut h = String::new();
    let name = escape(M::NAME);
    let _ = write!(
        h,
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>{name}</title>\n\
         <style>body{{font-family:sans-serif;max-width:70em;margin:auto;line-height:1.4}}\
         table{{border-collapse:collapse}}td,th{{border:1px solid #bbb;padding:2px 6px;font-size:90%}}\
         th{{background:#eee}}code{{background:#f4f4f4}}</style>\n</head>\n<body>\n\
         <h1>{name}</h1>\n<p>{}</p>\n{}",
        escape(M::DESCRIPTION),
        interface_line::<M>()
    );
    h.push_str(&M::documentation_html());
    type Keep = fn(&crate::Variable) -> bool;
    let groups: [(&str, Keep); 5] = [
        ("Inputs", |v| v.causality == Causality::Input),
        ("Outputs", |v| v.causality == Causality::Output),
        ("Parameters", |v| {
            v.causality == Causality::Parameter && v.effect().is_none()
        }),
        ("Candidate effects (off by default)", |v| {
            v.causality == Causality::Parameter && v.effect().is_some()
        }),
        ("Other variables", |v| {
            !matches!(
                v.causality,
                Causality::Input | Causality::Output | Causality::Parameter
            )
        }),
    ];
    for (title, keep) in groups {
        let rows: Vec<_> = M::variables()
            .iter()
            .filter(|v| keep(v))
            .map(|v| (v.value_reference, v))
            .collect();
        if rows.is_empty() {
            continue;
        }
        let _ = write!(
            h,
            "<h2>{title}</h2>\n<table>\n<tr><th>name</th><th>vr</th><th>type</th><th>unit</th>\
             <th>display</th><th>start</th><th>min</th><th>max</th><th>description</th></tr>\n"
        );
        for (vr, v) in rows {
            let start = if !v.has_start() {
                String::new()
            } else if v.vtype == VarType::Boolean {
                (v.start != 0.0).to_string()
            } else {
                fmt_f64(v.start)
            };
            let _ = writeln!(
                h,
                "<tr><td><code>{}</code></td><td>{vr}</td><td>{:?}</td><td>{}</td><td>{}</td>\
                 <td>{start}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
                escape(v.name),
                v.vtype,
                escape(v.unit.unwrap_or("")),
                escape(v.display_unit.unwrap_or("")),
                opt(v.min),
                opt(v.max),
                escape(v.description)
            );
        }
        h.push_str("</table>\n");
    }
    h.push_str("</body>\n</html>\n");
    h
}

/// The documentation page of the FMI 3.0 archive: the model's page (the same model, variables and
/// value references as in FMI 2.0) with the FMI 3.0 interface line, and a note that maps the FMI
/// 2.0 function names the model's text uses onto their FMI 3.0 counterparts.
pub fn documentation_fmi3<M: Model>() -> String {
    use crate::xml3::TIME_VALUE_REFERENCE;
    let html = documentation::<M>();
    let token = crate::xml::guid::<M>();
    let interfaces = escape(&interfaces::<M>());
    let fmi3 = format!(
        "<p>FMI 3.0 {interfaces}, instantiationToken <code>{token}</code> (the model is also \
         shipped as FMI 2.0, with the same variables and value references, plus <code>time</code>, \
         value reference {TIME_VALUE_REFERENCE}).</p>\n<p>Where this page names an FMI 2.0 \
         function, the FMI 3.0 one applies: <code>fmi2SetupExperiment</code> and \
         <code>fmi2EnterInitializationMode</code> are <code>fmi3EnterInitializationMode</code>, \
         <code>fmi2ExitInitializationMode</code> is <code>fmi3ExitInitializationMode</code>, \
         <code>fmi2GetReal</code>/<code>fmi2SetReal</code> are \
         <code>fmi3GetFloat64</code>/<code>fmi3SetFloat64</code>, \
         <code>fmi2NewDiscreteStates</code> is <code>fmi3UpdateDiscreteStates</code> and \
         <code>fmi2GetDerivatives</code> is <code>fmi3GetContinuousStateDerivatives</code>.</p>\n"
    );
    let fmi2 = interface_line::<M>();
    if let Some(i) = html.find(&fmi2) {
        return format!("{}{fmi3}{}", &html[..i], &html[i + fmi2.len()..]);
    }
    match html.find("</h1>\n") {
        Some(i) => format!("{}{fmi3}{}", &html[..i + 6], &html[i + 6..]),
        None => format!("{fmi3}{html}"),
    }
}

/// Why a documentation fragment's placeholder of a start value cannot be filled
/// ([`with_start_values`]).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum PlaceholderError {
    #[error("placeholder '{{{{{placeholder}}}}}': no variable '{name}' in the table")]
    UnknownVariable { placeholder: String, name: String },
    #[error("placeholder '{{{{{placeholder}}}}}': '{unit}' is no display unit of '{name}'")]
    UnknownDisplayUnit {
        placeholder: String,
        name: String,
        unit: String,
    },
    #[error(
        "placeholder '{{{{{placeholder}}}}}': format '{format}' is not '', 'e', '.N' or '.Ne'"
    )]
    UnknownFormat { placeholder: String, format: String },
    #[error("placeholder '{{{{{placeholder}}}}}': scale '{scale}' is not a number")]
    BadScale { placeholder: String, scale: String },
    #[error("a placeholder opened at byte {at} is not closed")]
    Unclosed { at: usize },
}

/// A documentation fragment with the start values of its variables written in from the table,
/// so that a table of defaults and their reasons never repeats a number by hand: every
/// `{{name}}` becomes the start value of the variable `name` (a Boolean as `true`/`false`, a
/// number as Rust's `{}` writes it), `{{name in unit}}` the value in one of its display units
/// (`{{supply_pressure in bar}}`), `{{name*1e6}}` the value times a scale, and a trailing
/// `:e`, `:.N` or `:.Ne` the format (`{{bulk_modulus:.1e}}` writes `1.0e9`).
pub fn with_start_values(
    fragment: &str,
    table: &[crate::Variable],
) -> Result<String, PlaceholderError> {
    let mut out = String::with_capacity(fragment.len());
    let mut rest = fragment;
    while let Some(open) = rest.find("{{") {
        out.push_str(&rest[..open]);
        let after = &rest[open + 2..];
        let at = fragment.len() - rest.len() + open;
        let close = after.find("}}").ok_or(PlaceholderError::Unclosed { at })?;
        out.push_str(&start_value(&after[..close], table)?);
        rest = &after[close + 2..];
    }
    out.push_str(rest);
    Ok(out)
}

/// One placeholder `name[ in unit][*scale][:format]` filled.
fn start_value(placeholder: &str, table: &[crate::Variable]) -> Result<String, PlaceholderError> {
    let (value, format) = placeholder.split_once(':').unwrap_or((placeholder, ""));
    let (value, scale) = value.split_once('*').unwrap_or((value, "1"));
    let (name, unit) = match value.split_once(" in ") {
        Some((name, unit)) => (name, Some(unit)),
        None => (value, None),
    };
    let owned = |s: &str| s.to_string();
    let Some(v) = table.iter().find(|v| v.name == name) else {
        return Err(PlaceholderError::UnknownVariable {
            placeholder: owned(placeholder),
            name: owned(name),
        });
    };
    if v.vtype == VarType::Boolean {
        return Ok((v.start != 0.0).to_string());
    }
    let mut x = v.start;
    if let Some(unit) = unit {
        let display = v
            .unit
            .and_then(crate::units::lookup)
            .and_then(|u| u.display.iter().find(|d| d.name == unit));
        let Some(d) = display else {
            return Err(PlaceholderError::UnknownDisplayUnit {
                placeholder: owned(placeholder),
                name: owned(name),
                unit: owned(unit),
            });
        };
        x = d.factor * x + d.offset;
    }
    if scale != "1" {
        let factor: f64 = scale.parse().map_err(|_| PlaceholderError::BadScale {
            placeholder: owned(placeholder),
            scale: owned(scale),
        })?;
        x *= factor;
    }
    formatted(x, format).ok_or_else(|| PlaceholderError::UnknownFormat {
        placeholder: owned(placeholder),
        format: owned(format),
    })
}

/// `x` in `format`: `` (Rust's `{}`), `e`, `.N` or `.Ne`.
fn formatted(x: f64, format: &str) -> Option<String> {
    match format {
        "" => return Some(format!("{x}")),
        "e" => return Some(format!("{x:e}")),
        _ => {}
    }
    let digits = format.strip_prefix('.')?;
    match digits.strip_suffix('e') {
        Some(n) => Some(format!("{x:.*e}", n.parse().ok()?)),
        None => Some(format!("{x:.*}", digits.parse().ok()?)),
    }
}

#[cfg(test)]
mod tests {
    use super::{with_start_values, PlaceholderError};
    use crate::Variable;

    #[test]
    fn placeholders_take_the_start_values() {
        let table = [
            Variable::parameter("p", 1.0e7, "Pa", "pressure").display("bar"),
            Variable::parameter("area", 2.010_619_298_297_467_7e-4, "m2", "area"),
            Variable::parameter("j", 1.09e-6, "kg.m2", "inertia"),
            Variable::flag("on", false, "switch"),
        ];
        let filled = with_start_values(
            "{{p in bar:.0}} bar, {{area:.3e}}, {{p:.1e}}, {{j*1e6:.2}}, {{on}}, {{p:e}} {x}",
            &table,
        );
        assert_eq!(
            filled.unwrap(),
            "100 bar, 2.011e-4, 1.0e7, 1.09, false, 1e7 {x}"
        );
        let unknown = with_start_values("{{q}}", &table).unwrap_err();
        assert!(matches!(unknown, PlaceholderError::UnknownVariable { .. }));
        let unclosed = with_start_values("a {{p", &table).unwrap_err();
        assert_eq!(unclosed, PlaceholderError::Unclosed { at: 2 });
    }
}
