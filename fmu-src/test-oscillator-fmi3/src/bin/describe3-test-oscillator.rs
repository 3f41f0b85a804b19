//! Writes the FMI 3.0 modelDescription.xml and documentation of the test oscillator.

fn main() {
    fmi3_export::describe_main::<test_oscillator::Oscillator>();
}
