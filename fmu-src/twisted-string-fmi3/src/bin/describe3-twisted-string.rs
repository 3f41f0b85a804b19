//! Writes the FMI 3.0 modelDescription.xml and documentation of TwistedString into the given directory.

fn main() {
    fmi3_export::describe_main::<twisted_string::TwistedString>();
}
