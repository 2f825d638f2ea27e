//! The Rust message types against the .msg files in msg/, field by field, and their CDR bytes.

use physskin::msg::{
    from_cdr, to_cdr, Header, Interaction, MeshStamped, RosMessage, SkinningWeights, Status,
    SubspaceState, Time,
};

/// (name, type) of every field of a .msg file; constants and comments skipped, package-local
/// types given their package.
fn parse_msg(text: &str) -> Vec<(String, String)> {
    text.lines()
        .map(|l| l.split('#').next().unwrap_or("").trim())
        .filter(|l| !l.is_empty() && !l.contains('='))
        .map(|l| {
            let mut parts = l.split_whitespace();
            let ty = parts.next().expect("a type").to_string();
            let name = parts.next().expect("a name").to_string();
            (name, ty)
        })
        .collect()
}

fn check<M: RosMessage>() {
    let path = format!("{}/msg/{}.msg", env!("CARGO_MANIFEST_DIR"), M::NAME);
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"));
    let expected = parse_msg(&text);
    let actual: Vec<(String, String)> = M::fields()
        .into_iter()
        .map(|(n, t)| (n.to_string(), t))
        .collect();
    assert_eq!(actual, expected, "{} differs from {path}", M::type_name());
}

#[test]
fn rust_types_match_the_msg_files() {
    check::<SkinningWeights>();
    check::<SubspaceState>();
    check::<Interaction>();
    check::<Status>();
    check::<MeshStamped>();
}

#[test]
fn skinning_weights_cdr_layout_is_the_ros_one() {
    let m = SkinningWeights {
        header: Header {
            stamp: Time { sec: 3, nanosec: 7 },
            frame_id: "ab".into(),
        },
        shape_id: 5,
        point_count: 1,
        handle_count: 2,
        weights: vec![1.0, 0.5],
    };
    let bytes = to_cdr(&m);
    let mut expected = vec![0, 1, 0, 0];
    expected.extend(3i32.to_le_bytes());
    expected.extend(7u32.to_le_bytes());
    expected.extend(3u32.to_le_bytes()); // string length including the NUL
    expected.extend(b"ab\0");
    expected.push(0); // padding to 4
    expected.extend(5u32.to_le_bytes());
    expected.extend(1u32.to_le_bytes());
    expected.extend(2u32.to_le_bytes());
    expected.extend(2u32.to_le_bytes()); // sequence length
    expected.extend(1.0f32.to_le_bytes());
    expected.extend(0.5f32.to_le_bytes());
    assert_eq!(bytes, expected);
    assert_eq!(from_cdr::<SkinningWeights>(&bytes).unwrap(), m);
    assert!(from_cdr::<SkinningWeights>(&bytes[..10]).is_err());
}
