#![no_main]
//! cargo fuzz target `pair_json` (see fuzz/README.md); the checks live in `pgm_fuzz::pair_json`.

libfuzzer_sys::fuzz_target!(|data: &[u8]| pgm_fuzz::pair_json(data));
