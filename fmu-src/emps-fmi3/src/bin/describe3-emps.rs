//! Writes the FMI 3.0 modelDescription.xml and documentation of the EMPS FMU.

fn main() {
    fmi3_export::describe_main::<emps::Emps>();
}
