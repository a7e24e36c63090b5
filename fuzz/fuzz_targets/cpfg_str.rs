//! A cpfg string file, drawn by the turtle.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    let Ok((symbols, string)) = sylva::import::cpfg_str::parse("fuzz.str", &text) else { return };
    let Ok(source) = sylva::lsystem::source::Source::new("fuzz.str", "", &[]) else { return };
    let opts = sylva::lsystem::TurtleOptions { max_nodes: 100_000, ..Default::default() };
    if let Ok(sk) = sylva::lsystem::interpret(&symbols, &string, &opts, &source) {
        assert!(sk.validate().is_ok());
    }
});
