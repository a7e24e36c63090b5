//! An LST skeleton under every gap policy; a valid skeleton is meshed.
#![no_main]
use libfuzzer_sys::fuzz_target;
use sylva::import::lst::{parse, GapPolicy, LstOptions};

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    for gap in [GapPolicy::Bridge, GapPolicy::Strict, GapPolicy::NewRoot] {
        let opts = LstOptions { gap, max_nodes: 10_000, ..Default::default() };
        if let Ok(sk) = parse("fuzz.lst", &text, &opts) {
            assert!(sk.validate().is_ok());
            let _ = sylva::mesh::tube::tube_mesh(&sk, &Default::default());
        }
    }
});
