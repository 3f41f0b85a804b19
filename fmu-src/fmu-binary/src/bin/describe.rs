//! Writes modelDescription.xml and documentation/index.html of the model and FMI version this
//! crate was built with into the directory given as the only argument (default `.`).

fn main() {
    fmu_binary::describe()
}
