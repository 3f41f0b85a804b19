fn main() {
    fmi2_export::describe_main::<test_oscillator::Oscillator>()
}
