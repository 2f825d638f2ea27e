//! Every message type the node reads or writes, from CDR: no panic, and whatever decodes
//! encodes back to bytes that decode to the same message.
#![no_main]

use libfuzzer_sys::fuzz_target;
use physskin::msg::{
    from_cdr, to_cdr, Clock, Interaction, JointState, SkinningWeights, Status, SubspaceState,
};

fn round_trip<M>(bytes: &[u8])
where
    M: serde::Serialize + for<'de> serde::Deserialize<'de> + PartialEq + std::fmt::Debug,
{
    if let Ok(message) = from_cdr::<M>(bytes) {
        let again: M = from_cdr(&to_cdr(&message)).expect("our own encoding decodes");
        // NaN is not equal to itself: compare the encodings instead.
        assert_eq!(to_cdr(&again), to_cdr(&message));
    }
}

fuzz_target!(|bytes: &[u8]| {
    round_trip::<Interaction>(bytes);
    round_trip::<JointState>(bytes);
    round_trip::<Status>(bytes);
    round_trip::<SubspaceState>(bytes);
    round_trip::<SkinningWeights>(bytes);
    round_trip::<Clock>(bytes);
});
