//! Compiles the small C shim that turns the variadic FMI logger call into a formatted string
//! (`vsnprintf`), which Rust cannot do on stable.
fn main() {
    println!("cargo:rerun-if-changed=csrc/logger.c");
    cc::Build::new()
        .file("csrc/logger.c")
        .warnings(true)
        .compile("fmi2hostshim");
}
