//! Writes modelDescription.xml and documentation/index.html of the HydraulicJoint FMU.
fn main() {
    fmi2_export::describe_main::<hydraulic_joint::HydraulicJoint>()
}
