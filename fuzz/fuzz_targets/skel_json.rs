//! A sylva JSON skeleton; a valid skeleton is meshed.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    if let Ok(sk) = sylva::import::skel_json::from_json(&text) {
        assert!(sk.validate().is_ok());
        let _ = sylva::mesh::tube::tube_mesh(&sk, &Default::default());
    }
});
