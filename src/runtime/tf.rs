//! A tf2 buffer: the transforms of /tf (kept for a while, interpolated at a stamp) and
//! /tf_static (kept for good), and the lookup of one frame in another through their tree.

use std::collections::{HashMap, VecDeque};

use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion};

use crate::msg::TransformStamped;

/// Why a transform is not available.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TfError {
    /// No transform names this frame.
    #[error("frame `{0}` is not known to tf (no transform names it)")]
    UnknownFrame(String),
    /// Both frames are known but no chain of transforms joins them.
    #[error("frames `{target}` and `{from}` are not connected in the tf tree")]
    NotConnected {
        /// The frame looked up in.
        target: String,
        /// The frame looked up.
        from: String,
    },
    /// A dynamic transform on the way is not known at the stamp asked for.
    #[error("transform `{parent}` -> `{child}` is not known at {at_s:.3} s (known from {from_s:.3} to {to_s:.3} s)")]
    Extrapolation {
        /// The transform's parent frame.
        parent: String,
        /// Its child frame.
        child: String,
        /// The stamp asked for, s.
        at_s: f64,
        /// The oldest stamp kept, s.
        from_s: f64,
        /// The newest stamp kept, s.
        to_s: f64,
    },
    /// A transform received has a non-finite value or a zero quaternion; it was not taken.
    #[error("transform `{parent}` -> `{child}` is not finite")]
    NotFinite {
        /// The transform's parent frame.
        parent: String,
        /// Its child frame.
        child: String,
    },
}

/// One frame's transforms to its parent: a static one, or stamped ones in time order.
#[derive(Clone, Debug)]
enum Link {
    Static(Isometry3<f64>),
    Dynamic(VecDeque<(i64, Isometry3<f64>)>),
}

/// Transforms by child frame.
#[derive(Clone, Debug)]
pub struct TfBuffer {
    links: HashMap<String, (String, Link)>,
    /// How long dynamic transforms are kept, ns.
    keep_ns: i64,
}

impl TfBuffer {
    /// An empty buffer that keeps dynamic transforms for `buffer_s` seconds.
    pub fn new(buffer_s: f64) -> Self {
        Self {
            links: HashMap::new(),
            keep_ns: (buffer_s * 1e9) as i64,
        }
    }

    /// Takes a transform from /tf (`is_static` false) or /tf_static.
    pub fn insert(&mut self, t: &TransformStamped, is_static: bool) -> Result<(), TfError> {
        let (parent, child) = (t.header.frame_id.clone(), t.child_frame_id.clone());
        let (p, q) = (&t.transform.translation, &t.transform.rotation);
        let quaternion = Quaternion::new(q.w, q.x, q.y, q.z);
        let finite = [p.x, p.y, p.z, q.x, q.y, q.z, q.w]
            .iter()
            .all(|v| v.is_finite());
        if !finite || quaternion.norm() < 1e-9 {
            return Err(TfError::NotFinite { parent, child });
        }
        let pose = Isometry3::from_parts(
            Translation3::new(p.x, p.y, p.z),
            UnitQuaternion::from_quaternion(quaternion),
        );
        let stamp = t.header.stamp.nanos();
        let entry = self
            .links
            .entry(child)
            .or_insert_with(|| (parent.clone(), Link::Dynamic(VecDeque::new())));
        entry.0 = parent;
        match (&mut entry.1, is_static) {
            (_, true) => entry.1 = Link::Static(pose),
            (Link::Static(_), false) => entry.1 = Link::Dynamic(VecDeque::from([(stamp, pose)])),
            (Link::Dynamic(samples), false) => {
                let at = samples.partition_point(|(s, _)| *s <= stamp);
                if at > 0 && samples[at - 1].0 == stamp {
                    samples[at - 1].1 = pose;
                } else {
                    samples.insert(at, (stamp, pose));
                }
                let newest = samples.back().map_or(stamp, |(s, _)| *s);
                while samples.len() > 1 && samples[0].0 < newest - self.keep_ns {
                    samples.pop_front();
                }
            }
        }
        Ok(())
    }

    /// The transform taking points of `source` into `target` at `stamp_ns` (0: the latest).
    pub fn lookup(
        &self,
        target: &str,
        source: &str,
        stamp_ns: i64,
    ) -> Result<Isometry3<f64>, TfError> {
        if target == source {
            return Ok(Isometry3::identity());
        }
        let up_source = self.chain(source, stamp_ns)?;
        let up_target = self.chain(target, stamp_ns)?;
        // Both chains end at their root; they meet at the first frame of one on the other.
        for (frame, to_frame) in &up_source {
            if let Some((_, target_to_frame)) = up_target.iter().find(|(f, _)| f == frame) {
                return Ok(target_to_frame.inverse() * to_frame);
            }
        }
        Err(TfError::NotConnected {
            target: target.into(),
            from: source.into(),
        })
    }

    /// `frame` and every ancestor, each with the transform from `frame` into it.
    fn chain(&self, frame: &str, stamp_ns: i64) -> Result<Vec<(String, Isometry3<f64>)>, TfError> {
        let known = self.links.contains_key(frame) || self.links.values().any(|(p, _)| p == frame);
        if !known {
            return Err(TfError::UnknownFrame(frame.into()));
        }
        let mut out = vec![(frame.to_string(), Isometry3::identity())];
        let mut current = frame.to_string();
        while let Some((parent, link)) = self.links.get(&current) {
            if out.iter().any(|(f, _)| f == parent) {
                break; // A loop in the tree: stop where it closes.
            }
            let step = sample(link, stamp_ns).map_err(|(from, to)| TfError::Extrapolation {
                parent: parent.clone(),
                child: current.clone(),
                at_s: stamp_ns as f64 / 1e9,
                from_s: from as f64 / 1e9,
                to_s: to as f64 / 1e9,
            })?;
            let to_parent = step * out.last().expect("never empty").1;
            out.push((parent.clone(), to_parent));
            current = parent.clone();
        }
        Ok(out)
    }
}

/// A link's transform at `stamp_ns` (0: its latest), interpolated between the samples around
/// it; the known time range when it lies outside.
fn sample(link: &Link, stamp_ns: i64) -> Result<Isometry3<f64>, (i64, i64)> {
    let samples = match link {
        Link::Static(pose) => return Ok(*pose),
        Link::Dynamic(samples) => samples,
    };
    let (Some(first), Some(last)) = (samples.front(), samples.back()) else {
        return Err((0, 0));
    };
    if stamp_ns == 0 {
        return Ok(last.1);
    }
    if stamp_ns < first.0 || stamp_ns > last.0 {
        return Err((first.0, last.0));
    }
    let after = samples.partition_point(|(s, _)| *s < stamp_ns);
    let (t1, p1) = samples[after];
    if t1 == stamp_ns || after == 0 {
        return Ok(p1);
    }
    let (t0, p0) = samples[after - 1];
    let s = (stamp_ns - t0) as f64 / (t1 - t0) as f64;
    Ok(p0.lerp_slerp(&p1, s))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msg::{Header, Quaternion as Q, Time, Transform, Vector3 as V};
    use nalgebra::{Point3, Vector3};

    fn tf(parent: &str, child: &str, t_s: f64, xyz: [f64; 3], q: [f64; 4]) -> TransformStamped {
        TransformStamped {
            header: Header {
                stamp: Time::from_nanos((t_s * 1e9) as i64),
                frame_id: parent.into(),
            },
            child_frame_id: child.into(),
            transform: Transform {
                translation: V {
                    x: xyz[0],
                    y: xyz[1],
                    z: xyz[2],
                },
                rotation: Q {
                    x: q[0],
                    y: q[1],
                    z: q[2],
                    w: q[3],
                },
            },
        }
    }

    /// REP 103's optical frame of a camera looking along world +x: z forward, x right, y down.
    const OPTICAL: [f64; 4] = [-0.5, 0.5, -0.5, 0.5];

    #[test]
    fn an_optical_frame_maps_forward_to_world_x_and_down_to_world_minus_z() {
        let mut buffer = TfBuffer::new(10.0);
        buffer
            .insert(
                &tf(
                    "world",
                    "camera_link",
                    0.0,
                    [0.0, 0.0, 0.5],
                    [0.0, 0.0, 0.0, 1.0],
                ),
                true,
            )
            .unwrap();
        buffer
            .insert(
                &tf("camera_link", "camera_optical", 0.0, [0.0; 3], OPTICAL),
                true,
            )
            .unwrap();
        let t = buffer.lookup("world", "camera_optical", 5).unwrap();
        let ahead = t * Point3::new(0.0, 0.0, 1.0);
        assert!(
            (ahead.coords - Vector3::new(1.0, 0.0, 0.5)).norm() < 1e-12,
            "{ahead}"
        );
        let below = t * Point3::new(0.0, 1.0, 0.0);
        assert!(
            (below.coords - Vector3::new(0.0, 0.0, -0.5)).norm() < 1e-12,
            "{below}"
        );
        // And back: world into the optical frame.
        let back = buffer.lookup("camera_optical", "world", 0).unwrap() * ahead;
        assert!((back.coords - Vector3::new(0.0, 0.0, 1.0)).norm() < 1e-12);
    }

    #[test]
    fn dynamic_transforms_interpolate_and_refuse_extrapolation() {
        let mut buffer = TfBuffer::new(10.0);
        let id = [0.0, 0.0, 0.0, 1.0];
        buffer
            .insert(&tf("odom", "base", 1.0, [0.0; 3], id), false)
            .unwrap();
        buffer
            .insert(&tf("odom", "base", 2.0, [1.0, 0.0, 0.0], id), false)
            .unwrap();
        let half = buffer.lookup("odom", "base", 1_500_000_000).unwrap();
        assert!((half.translation.vector.x - 0.5).abs() < 1e-12);
        let latest = buffer.lookup("odom", "base", 0).unwrap();
        assert_eq!(latest.translation.vector.x, 1.0);
        let e = buffer.lookup("odom", "base", 3_000_000_000).unwrap_err();
        assert!(matches!(e, TfError::Extrapolation { .. }), "{e}");
        // Siblings meet at their common parent.
        buffer
            .insert(&tf("odom", "arm", 0.0, [0.0, 2.0, 0.0], id), true)
            .unwrap();
        let t = buffer.lookup("arm", "base", 2_000_000_000).unwrap();
        assert!((t.translation.vector - Vector3::new(1.0, -2.0, 0.0)).norm() < 1e-12);
        // Samples older than the buffer are dropped.
        buffer
            .insert(&tf("odom", "base", 20.0, [2.0, 0.0, 0.0], id), false)
            .unwrap();
        assert!(buffer.lookup("odom", "base", 1_500_000_000).is_err());
    }

    #[test]
    fn unknown_and_disconnected_frames_are_named() {
        let mut buffer = TfBuffer::new(10.0);
        let id = [0.0, 0.0, 0.0, 1.0];
        buffer
            .insert(&tf("a", "b", 0.0, [0.0; 3], id), true)
            .unwrap();
        buffer
            .insert(&tf("c", "d", 0.0, [0.0; 3], id), true)
            .unwrap();
        let e = buffer.lookup("a", "camera", 0).unwrap_err().to_string();
        assert!(e.contains("camera"), "{e}");
        let e = buffer.lookup("a", "d", 0).unwrap_err().to_string();
        assert!(e.contains("`a`") && e.contains("`d`"), "{e}");
        let nan = tf("a", "e", 0.0, [f64::NAN, 0.0, 0.0], id);
        assert!(buffer.insert(&nan, false).is_err());
    }
}
