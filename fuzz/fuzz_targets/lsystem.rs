//! An L-system file: preprocess, parse, derive (small budget), homomorphism, turtle.
#![no_main]
use libfuzzer_sys::fuzz_target;
use sylva::lsystem::{DeriveOptions, LSystem};

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let Ok(ls) = LSystem::parse("fuzz.l", text, &[]) else { return };
    let budget = 100_000;
    let opts = DeriveOptions { steps: ls.derivation_length.min(64), budget, seed: 1 };
    let Ok((m, mut ev)) = ls.derive_full(&opts, Default::default(), Some(&Default::default()), None) else {
        return;
    };
    let Ok(shown) = ls.interpretation(&m, &mut ev, budget) else { return };
    if let Ok(sk) = sylva::lsystem::interpret(&ls.symbols, &shown, &Default::default(), &ls.source) {
        assert!(sk.validate().is_ok());
    }
});
