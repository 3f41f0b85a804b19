//! Writes `modelDescription.xml` and `documentation/index.html` of the TwistedString FMU.
fn main() {
    fmi2_export::describe_main::<twisted_string::TwistedString>()
}
