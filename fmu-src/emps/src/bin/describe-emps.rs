//! Writes the FMI 2.0 modelDescription.xml and documentation of the EMPS FMU.

fn main() {
    fmi2_export::describe_main::<emps::Emps>()
}
