//! The hidden side of a completed view: the observed surface reflected through the object's
//! centre, read per view ray, and what the camera saw to be empty, which a reflection may not
//! fill.

use nalgebra::{Vector2, Vector3};

use super::{ImageBins, ViewFrame};

/// The share of a coarse bin's deepest reflected depth in its hidden side (the rest: the mean).
const DEEPEST_SHARE: f64 = 0.8;

/// The observed surface reflected through a centre, its depths gathered in image bins: the
/// prior on the hidden side.
pub(super) struct Reflection {
    /// Mean depths in bins of about two pixels, where the reflection is followed that closely.
    fine: Option<BackMap>,
    /// Depths in the coarse bins of the observed points (a few spacings wide), read generously.
    coarse: BackMap,
}

impl Reflection {
    /// `points` (seen at `image`) reflected through `centre`, gathered in `coarse` (the
    /// observed points' bins) and, when `fine_pixel` is given, in bins that wide.
    pub(super) fn new(
        points: &[Vector3<f64>],
        image: &[Vector2<f64>],
        view: &ViewFrame,
        centre: &Vector3<f64>,
        fine_pixel: Option<f64>,
        coarse: ImageBins,
    ) -> Self {
        let back: Vec<(Vector2<f64>, f64)> = points
            .iter()
            .map(|p| 2.0 * centre - p)
            .filter(|r| view.depth(r) > 0.0)
            .map(|r| (view.image(&r), view.depth(&r)))
            .collect();
        // The fine grid spans both, so that reflected points beyond the observed outline are
        // not clamped into its edge bins.
        let fine = fine_pixel.map(|pixel| {
            let spanned: Vec<Vector2<f64>> = image
                .iter()
                .copied()
                .chain(back.iter().map(|b| b.0))
                .collect();
            BackMap::new(ImageBins::new(&spanned, pixel), &back)
        });
        Self {
            fine,
            coarse: BackMap::new(coarse, &back),
        }
    }

    /// Per observed point, where its ray leaves the object on the hidden side: the reflection's
    /// mean depth in the point's fine bin or the bins around it (where perspective leaves the
    /// reflection sparser), so that a tilted hidden side is followed, not flattened to a bin's
    /// deepest point; where it has none there, or is coarse only, the coarse bin's generous
    /// depth (mostly its deepest). None when that is not behind the point. Stops at the floor
    /// when the ray reaches it first.
    pub(super) fn hidden_side(
        &self,
        points: &[Vector3<f64>],
        depths: &[f64],
        image: &[Vector2<f64>],
        view: &ViewFrame,
        floor_z: Option<f64>,
    ) -> Vec<Option<Vector3<f64>>> {
        points
            .iter()
            .zip(depths)
            .zip(image)
            .map(|((p, &s), q)| {
                let b = self
                    .fine
                    .as_ref()
                    .and_then(|m| m.mean_near(q))
                    .or_else(|| self.coarse.generous_at(q))?;
                if b <= s {
                    return None;
                }
                let mut q = view.viewpoint + (p - view.viewpoint) * (b / s);
                if let Some(floor) = floor_z {
                    if q.z < floor && p.z > floor {
                        // Where the segment from p to q crosses the floor.
                        q = p + (q - p) * ((p.z - floor) / (p.z - q.z));
                    }
                }
                Some(q)
            })
            .collect()
    }
}

/// What the camera saw to be empty: the rays outside the observed outline, and the stretch of
/// each ray in front of the surface it met.
pub(super) struct Carving<'a> {
    bins: &'a ImageBins,
    /// Per bin, the least observed depth in it and the bins around it (infinite where nothing
    /// was seen there), taken once: every reflected point of a completion asks for it.
    front: Vec<f64>,
    /// How far in front of the surface seen a point may lie: the scan's noise.
    tolerance: f64,
}

impl<'a> Carving<'a> {
    pub(super) fn new(bins: &'a ImageBins, depths: &[f64], tolerance: f64) -> Self {
        let own: Vec<f64> = bins
            .cells
            .iter()
            .map(|cell| {
                cell.iter()
                    .map(|&i| depths[i])
                    .fold(f64::INFINITY, f64::min)
            })
            .collect();
        let front = (0..own.len())
            .map(|c| bins.around(c).map(|k| own[k]).fold(own[c], f64::min))
            .collect();
        Self {
            bins,
            front,
            tolerance,
        }
    }

    /// Whether `p` may be part of the object: within a bin of the observed outline and not in
    /// front of the surface seen there (the nearest in its bin and those around it, so that
    /// a pixel's jitter keeps it).
    pub(super) fn keeps(&self, p: &Vector3<f64>, view: &ViewFrame) -> bool {
        let depth = view.depth(p);
        if depth <= 0.0 {
            return false;
        }
        let q = view.image(p);
        let at = (q - self.bins.lo) / self.bins.pixel;
        let inside = [0, 1]
            .iter()
            .all(|&a| at[a] >= -1.0 && at[a] < self.bins.dims[a] as f64 + 1.0);
        if !inside {
            return false;
        }
        let seen = self.front[self.bins.cell(&q)];
        seen.is_finite() && depth >= seen - self.tolerance
    }
}

/// The depths of the reflected surface gathered in image bins.
struct BackMap {
    bins: ImageBins,
    /// Per bin, the sum of its depths, the deepest of them and how many there are.
    sum: Vec<f64>,
    deepest: Vec<f64>,
    count: Vec<usize>,
}

impl BackMap {
    /// The depths of `back` (image position, depth) gathered in `bins`.
    fn new(bins: ImageBins, back: &[(Vector2<f64>, f64)]) -> Self {
        let cells = bins.cells.len();
        let mut map = Self {
            sum: vec![0.0; cells],
            deepest: vec![f64::NEG_INFINITY; cells],
            count: vec![0; cells],
            bins,
        };
        for (q, depth) in back {
            let c = map.bins.cell(q);
            map.sum[c] += depth;
            map.deepest[c] = map.deepest[c].max(*depth);
            map.count[c] += 1;
        }
        map
    }

    /// A generous depth for the bin of `q`: mostly its deepest, `DEEPEST_SHARE` of it, the rest
    /// its mean. The deepest point of a bin a few pixels wide lies behind the hidden surface
    /// at the bin's middle wherever that surface slopes, and more so the steeper; it makes up
    /// for a centre estimated short of a round object's (the rim lies in front of its centre).
    /// With the rim's centroid weighted along the rim, closer to the centre, the deepest alone
    /// completed the creature from `bench real`'s first side to 1.328 of its volume (printed);
    /// mixed, 1.257, and the sphere's first side from 1.092 to 1.070.
    fn generous_at(&self, q: &Vector2<f64>) -> Option<f64> {
        let c = self.bins.cell(q);
        (self.count[c] > 0).then(|| {
            let mean = self.sum[c] / self.count[c] as f64;
            DEEPEST_SHARE * self.deepest[c] + (1.0 - DEEPEST_SHARE) * mean
        })
    }

    /// The mean depth in the bin of `q` or, when it holds none, in the bins around it.
    fn mean_near(&self, q: &Vector2<f64>) -> Option<f64> {
        let c = self.bins.cell(q);
        if self.count[c] > 0 {
            return Some(self.sum[c] / self.count[c] as f64);
        }
        let (total, n) = self
            .bins
            .around(c)
            .fold((0.0, 0), |(t, n), k| (t + self.sum[k], n + self.count[k]));
        (n > 0).then(|| total / n as f64)
    }
}
