//! Writes the FMI 3.0 modelDescription.xml and documentation of HydraulicJoint into the given directory.

fn main() {
    fmi3_export::describe_main::<hydraulic_joint::HydraulicJoint>();
}
