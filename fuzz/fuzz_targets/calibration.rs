#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    lucent_fuzz::calls::run("calibration", data, lucent_fuzz::repo_root());
});
