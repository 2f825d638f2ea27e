//! The node's parameter files (ROS 2 YAML): refused with a reason or accepted valid.
#![no_main]

use libfuzzer_sys::fuzz_target;
use physskin::runtime::NodeParams;

fuzz_target!(|bytes: &[u8]| {
    let Ok(text) = std::str::from_utf8(bytes) else {
        return;
    };
    if let Ok(params) = NodeParams::from_yaml(text, "/physskin") {
        params.validate().expect("accepted parameters are valid");
    }
});
