#![no_main]
//! cargo fuzz target `weights_json` (see fuzz/README.md); the checks live in `pgm_fuzz::weights_json`.

libfuzzer_sys::fuzz_target!(|data: &[u8]| pgm_fuzz::weights_json(data));
