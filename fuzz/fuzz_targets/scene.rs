//! Scene files: refused with the key named, or accepted.
#![no_main]

use libfuzzer_sys::fuzz_target;
use physskin::scene::SceneFile;

fuzz_target!(|bytes: &[u8]| {
    if let Ok(text) = std::str::from_utf8(bytes) {
        let _ = SceneFile::parse(text);
    }
});
