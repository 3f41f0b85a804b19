//! GitHub Actions workflow commands: `::error file=<fmu>,title=<check>::<message>` per finding
//! and `::notice` per note, which the runner turns into annotations of the FMU file, then the
//! summary line of each FMU as plain log text.

use super::{summary, Report};

/// The reports as workflow commands and summary lines.
pub fn render(reports: &[Report]) -> String {
    let mut s = String::new();
    for r in reports {
        for f in r.results() {
            let command = if f.is_required() { "error" } else { "notice" };
            let message = format!("{}: {} ({})", f.location, f.message, f.clause);
            s += &format!(
                "::{command} file={},title={}::{}\n",
                property(&r.fmu),
                property(&f.check),
                data(&message)
            );
        }
    }
    for r in reports {
        s += &summary(r);
        s.push('\n');
    }
    s
}

/// A command's message: `%`, CR and LF percent-encoded, as the runner decodes them.
pub fn data(text: &str) -> String {
    text.replace('%', "%25")
        .replace('\r', "%0D")
        .replace('\n', "%0A")
}

/// A command's property value: as [`data`], and `:` and `,`, which end a property, too.
pub fn property(text: &str) -> String {
    data(text).replace(':', "%3A").replace(',', "%2C")
}
