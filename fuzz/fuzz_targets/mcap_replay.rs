//! The replay's reader on any bytes: it keeps what is intact, names the damage, and never
//! panics; every intact message then goes through the decoder its topic calls for.
#![no_main]

use libfuzzer_sys::fuzz_target;
use physskin::bag::read_recording;
use physskin::fuzzing::{BuildRequest, TfBuffer};
use physskin::msg::{
    from_cdr, Interaction, JointState, Mesh, PointCloud2, TFMessage,
};

fuzz_target!(|bytes: &[u8]| {
    let Ok(recording) = read_recording(bytes, "fuzz") else {
        return;
    };
    let mut tf = TfBuffer::new(10.0);
    for m in &recording.messages {
        match m.type_name.as_str() {
            "tf2_msgs/msg/TFMessage" => {
                if let Ok(message) = from_cdr::<TFMessage>(&m.data) {
                    for t in &message.transforms {
                        let _ = tf.insert(t, m.topic == "/tf_static");
                        let _ = tf.lookup("world", &t.child_frame_id, t.header.stamp.nanos());
                    }
                }
            }
            "sensor_msgs/msg/PointCloud2" => {
                if let Ok(cloud) = from_cdr::<PointCloud2>(&m.data) {
                    let _ = BuildRequest::from_cloud(&cloud, 100_000, "instance");
                }
            }
            "shape_msgs/msg/Mesh" => {
                if let Ok(mesh) = from_cdr::<Mesh>(&m.data) {
                    let _ = BuildRequest::from_mesh(&mesh, "fuzz", 0, 100_000);
                }
            }
            "physskin/msg/Interaction" => {
                let _ = from_cdr::<Interaction>(&m.data);
            }
            _ => {
                let _ = from_cdr::<JointState>(&m.data);
            }
        }
    }
});
