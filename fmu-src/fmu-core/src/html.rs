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
