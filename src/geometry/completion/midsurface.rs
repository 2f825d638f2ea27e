//! How deep a sprawling object reaches behind each pixel. An animal, a frame, anything whose
//! outline is limbs rather than one body, is not described by its seen side reflected through
//! one centre: a leg reflected lands where no leg is, and the coarse fill behind the near legs
//! reaches as deep as the whole body (`bench views`' ant was completed to 1.5 to 3.2 times its
//! volume). A limb is about as thick along the view as across it, and where it turns away from
//! the camera (the rim) it is about as deep as its middle: the hidden side behind a pixel lies
//! about as far behind the rim's depth there as the seen surface lies in front of it. The
//! rim's depth at a pixel is interpolated from the rim nearest to it. The reflection's depth
//! is kept where it is the nearer.

use nalgebra::{Vector2, Vector3};

use super::super::point_index::PointIndex;
use super::{ImageBins, ViewFrame};

/// An outline whose area is less than this share of its convex hull's sprawls: a body with
/// limbs (an ant seen from any side, 0.28 to 0.56 in `bench views`, printed; the creature 0.53
/// to 0.87; a ring, 0.78 and more; every other shape and real mesh there 0.84 to 1.26, the
/// bins' overlap with the outline counted in).
const SPRAWLING: f64 = 0.7;
/// The rim points a pixel's mid-surface depth is interpolated from.
const RIM_NEIGHBOURS: usize = 8;
/// How much deeper than the rim says the hidden side of a limb lies: the seen half-depth times
/// this. The rim's last pixel stands in front of where a round limb turns away, by about the
/// square root of twice its radius times a pixel (1.1 cm for a 3 cm limb seen at 2 mm pixels),
/// so the depth from the surface to the rim falls short of the limb's radius. In `bench views`
/// the same count of real scans came within 30 % at 1.5, 1.8 and 2.2 (printed); at 1 the
/// creature came out 0.51 to 0.69 of its volume, the ant 0.55 to 1.15.
const ROUND_LIMB: f64 = 1.8;

/// Brings each hidden point of `mirrors` forward along its ray to where the mid-surface puts
/// it, if nearer, when the outline of `points` sprawls (see `SPRAWLING`); `seen` are their
/// depths and image positions in `view`, `outline` the image's two-pixel bins and the rim
/// found on them (`rim::rim_points`). Whether it did.
pub(super) fn thin_limbs(
    mirrors: &mut [Option<Vector3<f64>>],
    points: &[Vector3<f64>],
    seen: (&[f64], &[Vector2<f64>]),
    view: &ViewFrame,
    outline: (&ImageBins, &[usize]),
) -> bool {
    let (depths, image) = seen;
    let (bins, rim) = outline;
    if rim.is_empty() || solidity(image, bins) >= SPRAWLING {
        return false;
    }
    let mid = MidSurface::new(image, depths, rim);
    let index = PointIndex::for_surface(&mid.rim_image);
    for (i, mirror) in mirrors.iter_mut().enumerate() {
        let Some(back) = *mirror else { continue };
        let local = depths[i] + 2.0 * ROUND_LIMB * (mid.depth_at(&index, &image[i]) - depths[i]);
        if local <= depths[i] {
            // A hollow seen into: nothing behind it on this ray.
            *mirror = None;
        } else if local < view.depth(&back) {
            *mirror = Some(view.viewpoint + (points[i] - view.viewpoint) * (local / depths[i]));
        }
    }
    true
}

/// The outline's area (the occupied bins') over its convex hull's in the image.
fn solidity(image: &[Vector2<f64>], bins: &ImageBins) -> f64 {
    let occupied = bins.cells.iter().filter(|c| !c.is_empty()).count() as f64;
    occupied * bins.pixel * bins.pixel / hull_area(image).max(1e-300)
}

/// The area of the convex hull of `points` (Andrew's monotone chain).
fn hull_area(points: &[Vector2<f64>]) -> f64 {
    let mut sorted = points.to_vec();
    sorted.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    let turns_left = |o: &Vector2<f64>, a: &Vector2<f64>, b: &Vector2<f64>| {
        (a.x - o.x) * (b.y - o.y) - (a.y - o.y) * (b.x - o.x) > 0.0
    };
    let mut hull: Vec<Vector2<f64>> = Vec::new();
    for pass in [sorted.clone(), sorted.into_iter().rev().collect()] {
        let start = hull.len();
        for p in pass {
            while hull.len() >= start + 2
                && !turns_left(&hull[hull.len() - 2], &hull[hull.len() - 1], &p)
            {
                hull.pop();
            }
            hull.push(p);
        }
        // Each chain's last point is the other's first.
        hull.pop();
    }
    let twice: f64 = (0..hull.len())
        .map(|i| {
            let (a, b) = (hull[i], hull[(i + 1) % hull.len()]);
            a.x * b.y - a.y * b.x
        })
        .sum();
    twice.abs() / 2.0
}

/// The rim's depth across the image: the surface midway between the seen and the hidden side.
struct MidSurface {
    /// The rim points' image positions (z = 0), for a point index.
    rim_image: Vec<Vector3<f64>>,
    rim_depth: Vec<f64>,
}

impl MidSurface {
    /// The rim points `rim` (indices into `image` and `depths`).
    fn new(image: &[Vector2<f64>], depths: &[f64], rim: &[usize]) -> Self {
        Self {
            rim_image: rim
                .iter()
                .map(|&i| Vector3::new(image[i].x, image[i].y, 0.0))
                .collect(),
            rim_depth: rim.iter().map(|&i| depths[i]).collect(),
        }
    }

    /// The rim's depth at `q`, from `index` over `rim_image`: its `RIM_NEIGHBOURS` nearest
    /// points' depths weighted by the inverse square of their distance in the image.
    fn depth_at(&self, index: &PointIndex, q: &Vector2<f64>) -> f64 {
        let at = Vector3::new(q.x, q.y, 0.0);
        let (mut total, mut weights) = (0.0, 0.0);
        for i in index.nearest(&at, RIM_NEIGHBOURS, None) {
            // A pixel on the rim is as deep as the rim there.
            let w = 1.0 / ((self.rim_image[i] - at).norm_squared() + 1e-18);
            total += w * self.rim_depth[i];
            weights += w;
        }
        total / weights
    }
}
