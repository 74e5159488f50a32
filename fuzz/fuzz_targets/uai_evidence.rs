#![no_main]
//! cargo fuzz target `uai_evidence` (see fuzz/README.md); the checks live in `pgm_fuzz::uai_evidence`.

libfuzzer_sys::fuzz_target!(|data: &[u8]| pgm_fuzz::uai_evidence(data));
