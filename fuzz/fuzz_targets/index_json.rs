#![no_main]
//! cargo fuzz target `index_json` (see fuzz/README.md); the checks live in `pgm_fuzz::index_json`.

libfuzzer_sys::fuzz_target!(|data: &[u8]| pgm_fuzz::index_json(data));
