//! The HTML documentation of the model (equations, sources, derivations, parameter tables).

/// HTML fragment for `documentation/index.html`.
pub fn html() -> String {
    String::from("<h1>HydraulicJoint</h1>")
}
