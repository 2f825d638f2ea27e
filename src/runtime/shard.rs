//! Objects split among instances: `instances.shard: "k/N"` makes an instance take only its
//! share, so that N of them on one ROS graph simulate every object exactly once. A labelled
//! object goes by its id (k modulo N); a frame's one object (a mesh, an unlabelled cloud) by a
//! hash of the frame's name that every instance computes alike (FNV-1a: std's hasher is seeded
//! per process). Each instance numbers its objects k + 1, k + 1 + N, ... so that their
//! `shape_id`s never meet.

use std::fmt;

use super::object_key::ObjectKey;

/// This instance's share of the objects: number `index` of `count` (0-based).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Shard {
    index: u32,
    count: u32,
}

impl Default for Shard {
    /// The whole: one instance takes every object.
    fn default() -> Self {
        Self { index: 0, count: 1 }
    }
}

impl Shard {
    /// `"k/N"` (0 <= k < N), or `""` for the whole; why not, naming the text.
    pub fn parse(text: &str) -> Result<Self, String> {
        if text.is_empty() {
            return Ok(Self::default());
        }
        let bad = || format!("`{text}` is not k/N with 0 <= k < N (e.g. 0/2 and 1/2)");
        let (k, n) = text.split_once('/').ok_or_else(bad)?;
        let (index, count) = match (k.trim().parse::<u32>(), n.trim().parse::<u32>()) {
            (Ok(k), Ok(n)) if k < n => (k, n),
            _ => return Err(bad()),
        };
        Ok(Self { index, count })
    }

    /// Whether this is one of several instances.
    pub fn is_split(&self) -> bool {
        self.count > 1
    }

    /// Whether this is instance 0 (the whole is too).
    pub fn index_is_first(&self) -> bool {
        self.index == 0
    }

    /// Whether this instance's is `key`'s object: by its id when labelled, else by its frame.
    pub fn owns(&self, key: &ObjectKey) -> bool {
        match key.label {
            Some(id) => self.owns_id(id),
            None => self.owns_frame(&key.frame),
        }
    }

    /// Whether the labelled object `id` is this instance's (negative ids too).
    pub fn owns_id(&self, id: i64) -> bool {
        id.rem_euclid(i64::from(self.count)) == i64::from(self.index)
    }

    /// Whether `frame`'s one object is this instance's.
    pub fn owns_frame(&self, frame: &str) -> bool {
        fnv1a(frame.as_bytes()) % u64::from(self.count) == u64::from(self.index)
    }

    /// The first of this instance's shape ids above `after`.
    pub fn id_after(&self, after: u32) -> u32 {
        let next = after + 1;
        // Ids k + 1 + j N: ids minus one are k modulo N.
        let offset = (self.index + self.count - (next - 1) % self.count) % self.count;
        next + offset
    }
}

impl fmt::Display for Shard {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

/// 64-bit FNV-1a: the same on every machine and in every process.
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |hash, &b| {
        (hash ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_k_of_n_and_refuses_the_rest() {
        assert_eq!(Shard::parse("").unwrap(), Shard::default());
        assert_eq!(Shard::parse("1/3").unwrap().to_string(), "1/3");
        for bad in ["3/3", "1", "a/2", "-1/2", "0/0", "1/2/3"] {
            let e = Shard::parse(bad).unwrap_err();
            assert!(e.contains(bad), "{e}");
        }
    }

    #[test]
    fn every_object_and_every_id_has_exactly_one_instance() {
        let shards: Vec<Shard> = (0..3).map(|k| Shard { index: k, count: 3 }).collect();
        for id in -5..40 {
            assert_eq!(shards.iter().filter(|s| s.owns_id(id)).count(), 1, "{id}");
        }
        let frames = [
            "camera_color_optical_frame",
            "cam",
            "world",
            "left",
            "right",
        ];
        for frame in frames {
            assert_eq!(shards.iter().filter(|s| s.owns_frame(frame)).count(), 1);
        }
        // The hash is FNV-1a's: fixed, whoever computes it.
        assert_eq!(fnv1a(b"a"), 0xaf63_dc4c_8601_ec8c);
        let mut ids: Vec<u32> = Vec::new();
        for s in &shards {
            let mut id = 0;
            for _ in 0..4 {
                id = s.id_after(id);
                assert_eq!((id - 1) % 3, s.index, "{id}");
                ids.push(id);
            }
        }
        ids.sort_unstable();
        assert_eq!(ids, (1..=12).collect::<Vec<u32>>(), "no id twice");
        assert_eq!(Shard::default().id_after(7), 8);
        assert_eq!(Shard { index: 1, count: 2 }.id_after(3), 4);
    }
}
