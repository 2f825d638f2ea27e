//! Completion of one camera's view of an object. A depth camera sees one side: an open patch
//! whose inside test leaves a thin shell, a small fraction of the object's mass. When a cloud
//! is such a view (its image bins hold one surface, not a front and a back), what lies behind
//! the observed surface along the view rays is filled up to a prior on the hidden side: the
//! observed surface reflected through the object's estimated centre, which is exact for
//! centrally symmetric objects. The centre is the rim's centroid, per length of rim; a long
//! object's (a long outline whose middle is no deeper than a round object's: not a ring seen
//! edge-on) is moved along its axis to the middle of its outline, and onto the axis of the
//! circle fitted to its surface across its middle where that is round, or of the ellipse fitted
//! there where it is elliptic (else taken as deep behind the surface in front of it as a round
//! rod's axis lies: half its width over the sine of its tilt from the view). A compact object
//! that the visible half of an ellipsoid describes (a ball, an egg) is centred on the ellipsoid
//! fitted to what was seen, and a box with two or three faces in view (a long one too, whose
//! section fits no circle or ellipse) on the box they give;
//! another compact object's centre is at least half its breadth deep behind the nearer of its
//! nearest point and the surface in front of the centre, and at least midway between the
//! nearest and the deepest point seen. A long object's and a fitted one's
//! hidden side follows the reflection pixel by pixel, and the completion is joined by its own
//! reflection (less what the camera saw to be empty), so that it is as symmetric as the prior;
//! another compact object's takes a generous depth (mostly the deepest) of the reflected points
//! in coarser bins, except that an object whose outline sprawls (an animal's legs) reaches no
//! deeper behind each pixel than its limbs are thick (see `midsurface`).
//! Side walls join the patch's rim to the hidden side, so the completed surface is closed; a
//! known floor cuts the hidden side off where it would go below.

use nalgebra::{Matrix2, Matrix3, Vector2, Vector3};
use serde::Serialize;

mod cuboid;
mod midsurface;
mod prior;
mod quadric;
mod reflection;
mod rim;
mod section;
mod silhouette;

use super::point_index::neighbour_distance;
use super::shape::principal_extents;
use crate::linalg::tangents;
pub use prior::Prior;
use reflection::{Carving, Reflection};
use rim::{rim_centroid, rim_points};
use section::{elliptic_axis, round_axis};

/// Clouds with fewer points are not examined: too few to tell one side from two.
const EXAMINED_FROM: usize = 32;
/// A view with fewer points is refused rather than completed.
const COMPLETED_FROM: usize = 200;
/// Below this fraction of view-ray bins that hold two surfaces, a cloud is one side's view.
const TWO_SIDED_FRACTION: f64 = 0.25;
/// A patch thinner than this fraction of its width is flat: one view cannot tell its depth.
const FLAT_PATCH: f64 = 0.08;
/// Fill points per longest side of the completed surface: two per voxel at the inside test's
/// default resolution (64).
const FILL_STEPS_PER_SIDE: f64 = 128.0;
/// The outline's extremes are taken at this quantile of the points and its complement, so
/// that a few stray pixels do not move them.
const OUTLINE_QUANTILE: f64 = 0.005;
/// The longest axis must be this close to the image plane (the cosine between them) to move
/// the centre along it.
const MIN_AXIS_TILT: f64 = 0.3;
/// Half the width, as a fraction of the patch's length across the view, of the band through
/// the centre where its width and the surface in front of it are read.
const CENTRE_BAND: f64 = 0.05;
/// A patch at least this many times longer than it is broad across the view is a long object,
/// taken to be round across its axis.
const LONG_OBJECT: f64 = 2.0;
/// A long outline is round across its axis where the depths across its middle span at most
/// this many times a round object's (see `Strip::is_round`).
const ROUND_ACROSS: f64 = 2.0;
/// A box's points must lie within this many point spacings of its fitted faces.
const BOX_TOLERANCE: f64 = 2.0;
/// The name of the method, as reported.
pub const METHOD: &str = "reflected_through_centre";

/// Why a view cannot be completed.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum CompletionError {
    /// The view has fewer than 200 points: too few to complete.
    #[error("the cloud is one camera's view of an object and has {count} points: at least {COMPLETED_FROM} are needed to complete it")]
    TooFewPoints {
        /// The view's points.
        count: usize,
    },
    /// The view is a flat patch (thinner than 8 % of its width): its depth cannot be told.
    #[error("the cloud is one camera's view of a flat patch ({thickness:.3e} m thick over {width:.3e} m): one view cannot tell how deep the object is")]
    FlatPatch {
        /// The patch's smallest principal extent, m.
        thickness: f64,
        /// Its middle principal extent, m.
        width: f64,
    },
}

/// What a completion did, for `shape_ready` and the subspace decision.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct Completion {
    /// The completion method's name: `METHOD`.
    pub method: &'static str,
    /// The prior that decided the hidden side.
    pub prior: Prior,
    /// Observed points over all points of the completed surface (observed and filled in at the
    /// same density), a long object's reflection left out.
    pub observed_fraction: f64,
    /// Fraction of view-ray bins that held two surfaces (low: one side was seen).
    pub two_sided_fraction: f64,
    /// Points added to the surface (the hidden side and the side walls; for a long object, its
    /// reflection too).
    pub added_points: usize,
    /// Estimated depth of the object along the view, m.
    pub depth: f64,
    /// Wall-clock time the completion took, ms.
    pub ms: f64,
}

/// A completed view.
pub struct Completed {
    /// The closed surface: the observed points first, then the hidden side and the side walls.
    pub surface: Vec<Vector3<f64>>,
    /// The surface and points filling it along the view rays: what the inside test voxelizes,
    /// so that no gap in a sparse hidden side lets the outside in.
    pub solid: Vec<Vector3<f64>>,
    /// The object's estimated centre, through which the prior reflects what was seen.
    pub centre: Vector3<f64>,
    /// What the completion did.
    pub report: Completion,
}

/// The view's axes: `forward` from the viewpoint to the cloud's centroid.
struct ViewFrame {
    viewpoint: Vector3<f64>,
    forward: Vector3<f64>,
    right: Vector3<f64>,
    up: Vector3<f64>,
}

impl ViewFrame {
    /// None when the viewpoint is among the points (a cloud all around its frame's origin is
    /// not one camera's view).
    fn new(points: &[Vector3<f64>], viewpoint: &Vector3<f64>) -> Option<Self> {
        let centroid = points.iter().sum::<Vector3<f64>>() / points.len() as f64;
        let forward = (centroid - viewpoint).try_normalize(1e-12)?;
        // right x forward = -(forward x right), the same products: `up` as it was.
        let [right, down] = tangents(&forward);
        let up = -down;
        let frame = Self {
            viewpoint: *viewpoint,
            forward,
            right,
            up,
        };
        points.iter().all(|p| frame.depth(p) > 0.0).then_some(frame)
    }

    fn depth(&self, p: &Vector3<f64>) -> f64 {
        (p - self.viewpoint).dot(&self.forward)
    }

    /// Coordinates across the view, seen along `forward` (along `right` and `up`).
    fn across(&self, p: &Vector3<f64>) -> Vector2<f64> {
        let d = p - self.viewpoint;
        Vector2::new(d.dot(&self.right), d.dot(&self.up))
    }

    /// Image-plane coordinates (x / z, y / z).
    fn image(&self, p: &Vector3<f64>) -> Vector2<f64> {
        let d = p - self.viewpoint;
        let z = d.dot(&self.forward);
        Vector2::new(d.dot(&self.right) / z, d.dot(&self.up) / z)
    }
}

/// Bins of the image plane of about `pixel` (image units) each, holding point indices.
struct ImageBins {
    lo: Vector2<f64>,
    pixel: f64,
    dims: [usize; 2],
    cells: Vec<Vec<usize>>,
}

impl ImageBins {
    fn new(image: &[Vector2<f64>], pixel: f64) -> Self {
        let lo = image
            .iter()
            .fold(Vector2::repeat(f64::INFINITY), |a, p| a.inf(p));
        let hi = image
            .iter()
            .fold(Vector2::repeat(f64::NEG_INFINITY), |a, p| a.sup(p));
        // Clamped as floats: a degenerate spread (infinite, NaN) must not overflow the cast.
        let dims =
            [0, 1].map(|a| (((hi[a] - lo[a]) / pixel).floor() + 1.0).clamp(1.0, 1024.0) as usize);
        let mut bins = Self {
            lo,
            pixel,
            dims,
            cells: vec![Vec::new(); dims[0] * dims[1]],
        };
        for (i, p) in image.iter().enumerate() {
            let c = bins.cell(p);
            bins.cells[c].push(i);
        }
        bins
    }

    fn cell(&self, p: &Vector2<f64>) -> usize {
        let [i, j] = [0, 1]
            .map(|a| (((p[a] - self.lo[a]) / self.pixel).floor() as usize).min(self.dims[a] - 1));
        i + self.dims[0] * j
    }

    /// The cells around cell `c` (its eight neighbours within the grid).
    fn around(&self, c: usize) -> impl Iterator<Item = usize> + '_ {
        let (i, j) = ((c % self.dims[0]) as isize, (c / self.dims[0]) as isize);
        (-1..=1)
            .flat_map(move |di| (-1..=1).map(move |dj| (i + di, j + dj)))
            .filter(move |&(a, b)| (a, b) != (i, j))
            .filter(|&(a, b)| {
                a >= 0 && b >= 0 && (a as usize) < self.dims[0] && (b as usize) < self.dims[1]
            })
            .map(|(a, b)| a as usize + self.dims[0] * b as usize)
    }

    /// Whether the occupied cell `c` borders an empty cell or the edge.
    fn on_rim(&self, c: usize) -> bool {
        let (i, j) = (c % self.dims[0], c / self.dims[0]);
        let empty = |i: isize, j: isize| {
            i < 0
                || j < 0
                || i as usize >= self.dims[0]
                || j as usize >= self.dims[1]
                || self.cells[i as usize + self.dims[0] * j as usize].is_empty()
        };
        let (i, j) = (i as isize, j as isize);
        empty(i - 1, j) || empty(i + 1, j) || empty(i, j - 1) || empty(i, j + 1)
    }
}

/// The completed cloud when `points`, seen from `viewpoint`, are one side of an object; None
/// when they are not (two surfaces along the view rays, too few to tell, or the viewpoint among
/// them). `floor_z`: a support plane (z up) the hidden side may not go below.
pub fn complete_view(
    points: &[Vector3<f64>],
    viewpoint: &Vector3<f64>,
    floor_z: Option<f64>,
) -> Result<Option<Completed>, CompletionError> {
    if points.len() < EXAMINED_FROM {
        return Ok(None);
    }
    let started = std::time::Instant::now();
    let Some(view) = ViewFrame::new(points, viewpoint) else {
        return Ok(None);
    };
    let spacing = neighbour_distance(points, 6, 0.9).max(1e-9);
    let depths: Vec<f64> = points.iter().map(|p| view.depth(p)).collect();
    let image: Vec<Vector2<f64>> = points.iter().map(|p| view.image(p)).collect();
    let mean_depth = depths.iter().sum::<f64>() / depths.len() as f64;
    let bins = ImageBins::new(&image, 3.0 * spacing / mean_depth);
    let two_sided = two_sided_fraction(&bins, &depths, 4.0 * spacing);
    if two_sided >= TWO_SIDED_FRACTION {
        return Ok(None);
    }
    if points.len() < COMPLETED_FROM {
        return Err(CompletionError::TooFewPoints {
            count: points.len(),
        });
    }
    let (width, thickness) = patch_width_and_thickness(points);
    if thickness < FLAT_PATCH * width {
        return Err(CompletionError::FlatPatch { thickness, width });
    }
    // The rim is found on bins of about two pixels: coarser bins would reach far into the
    // patch where faces are foreshortened, and pull the centre towards the camera.
    let rim_bins = ImageBins::new(&image, 2.0 * image_pitch(&image));
    let rim = rim_points(&rim_bins, &depths);
    let outline = (&rim_bins, rim.as_slice());
    let (centre, mut prior) = estimated_centre(points, &depths, &image, &view, outline, spacing);
    let symmetric = prior.symmetric();
    // The reflection is followed pixel by pixel where the object is long, taken round across
    // its axis, or fitted (an ellipsoid, a box). Another compact object's is not: its bins'
    // mostly deepest reflected depths are kept, a generous fill that makes up for what the rim's
    // pixels leave out (and an animal is not symmetric; a box seen square to one face would
    // come out thin).
    let fine_pixel = symmetric.then_some(rim_bins.pixel);
    let reflection = Reflection::new(points, &image, &view, &centre, fine_pixel, bins);
    let depth = 2.0 * (view.depth(&centre) - depths.iter().cloned().fold(f64::INFINITY, f64::min));
    let mut mirrors = reflection.hidden_side(points, &depths, &image, &view, floor_z);
    let seen = (depths.as_slice(), image.as_slice());
    if !symmetric && midsurface::thin_limbs(&mut mirrors, points, seen, &view, outline) {
        prior = Prior::Limbs;
    }
    let mut surface = points.to_vec();
    surface.extend(mirrors.iter().flatten());
    for (c, cell) in rim_bins.cells.iter().enumerate() {
        if cell.is_empty() || !rim_bins.on_rim(c) {
            continue;
        }
        for &i in cell {
            if let Some(back) = mirrors[i] {
                surface.extend(segment(&points[i], &back, spacing));
            }
        }
    }
    // The fill only has to mark the voxels its rays cross: points half a voxel apart (at the
    // finest resolution the pipeline uses) do, and a finer fill only costs the inside test.
    let fill_step = spacing.max(longest_side(&surface) / FILL_STEPS_PER_SIDE);
    let mut solid = surface.clone();
    for (p, back) in points.iter().zip(&mirrors) {
        if let Some(back) = back {
            solid.extend(segment(p, back, fill_step));
        }
    }
    // Counted before a long object's reflection is added: that copies the hidden side's place.
    let observed_fraction = points.len() as f64 / surface.len() as f64;
    if symmetric {
        // A long object's completion is made symmetric about its centre, as the prior has it:
        // its ends are where the pixels are fewest and its hidden side least sure, and the
        // far end came out short where nothing was reflected into its outline. The bundled rod
        // scanned from `bench real`'s first side, dropped (`simulate --input`), went from an
        // error of 0.2300 % to 0.1398 %, its centre of mass from 2.74 to 0.77 cm off (printed).
        // A fitted ellipsoid's or box's centre is as sure: `bench views`' sphere went from a
        // mean overlap of 0.900 with the rim's centre and the coarse fill to 0.933 (printed);
        // without this union the bundled box's overlap fell in 11 of its 12 views, by up to
        // 0.111 (printed).
        // The solid begins with the surface: each point is reflected and carved once.
        let carving = Carving::new(&rim_bins, &depths, spacing);
        let kept: Vec<(usize, Vector3<f64>)> = solid
            .iter()
            .map(|p| 2.0 * centre - p)
            .enumerate()
            .filter(|(_, r)| carving.keeps(r, &view))
            .collect();
        let on_surface = surface.len();
        surface.extend(
            kept.iter()
                .filter(|(i, _)| *i < on_surface)
                .map(|(_, r)| *r),
        );
        solid.extend(kept.into_iter().map(|(_, r)| r));
    }
    let added_points = surface.len() - points.len();
    Ok(Some(Completed {
        report: Completion {
            method: METHOD,
            prior,
            observed_fraction,
            two_sided_fraction: two_sided,
            added_points,
            depth,
            ms: started.elapsed().as_secs_f64() * 1e3,
        },
        surface,
        solid,
        centre,
    }))
}

/// A scan's pixel pitch: the distance to the nearest neighbour in the image plane, at its 90th
/// percentile, which is a raster's pitch and a thinned raster's widest (its median is the
/// narrowest: most rim bins of a VGA scan thinned to the build cap came out empty, side walls
/// ran through the solid, and the bundled sphere's body held 0.65 of its volume, printed).
fn image_pitch(image: &[Vector2<f64>]) -> f64 {
    let flat: Vec<Vector3<f64>> = image.iter().map(|q| Vector3::new(q.x, q.y, 0.0)).collect();
    neighbour_distance(&flat, 1, 0.9).max(1e-12)
}

/// Fraction of occupied bins whose points, sorted by depth, leave a gap wider than `gap`:
/// a front and a back surface on the same rays.
fn two_sided_fraction(bins: &ImageBins, depths: &[f64], gap: f64) -> f64 {
    let (mut occupied, mut two) = (0usize, 0usize);
    let mut along = Vec::new();
    for cell in bins.cells.iter().filter(|c| !c.is_empty()) {
        occupied += 1;
        along.clear();
        along.extend(cell.iter().map(|&i| depths[i]));
        along.sort_by(f64::total_cmp);
        if along.windows(2).any(|w| w[1] - w[0] > gap) {
            two += 1;
        }
    }
    two as f64 / occupied.max(1) as f64
}

/// (middle, smallest) extent of the points along their principal axes: a patch is flat when
/// the smallest is small against the middle one (a rod's half is long, narrow and round).
fn patch_width_and_thickness(points: &[Vector3<f64>]) -> (f64, f64) {
    let [_, middle, smallest] = principal_extents(points);
    (middle, smallest)
}

/// The patch seen along the view: its coordinates across it and its principal axes there.
struct Outline {
    across: Vec<Vector2<f64>>,
    long: Vector2<f64>,
    short: Vector2<f64>,
    length: f64,
    breadth: f64,
    /// False where the band across its middle is deeper than a round object's (see
    /// `Strip::is_round`): not taken as long, however long.
    round: bool,
}

impl Outline {
    fn new(points: &[Vector3<f64>], view: &ViewFrame) -> Self {
        let across = across_view(points, view);
        let axes = principal_axes(&across);
        let spread = [0, 1].map(|a| extent(across.iter().map(|q| q.dot(&axes.column(a)))));
        let (long, short) = if spread[0] >= spread[1] {
            (0, 1)
        } else {
            (1, 0)
        };
        Self {
            long: axes.column(long).into_owned(),
            short: axes.column(short).into_owned(),
            length: spread[long],
            breadth: spread[short],
            round: true,
            across,
        }
    }

    /// Its long and short axes in space, each with half the outline's extent along it.
    fn axes(&self, view: &ViewFrame) -> [(Vector3<f64>, f64); 2] {
        let lift = |a: &Vector2<f64>| view.right * a.x + view.up * a.y;
        [
            (lift(&self.long), self.length / 2.0),
            (lift(&self.short), self.breadth / 2.0),
        ]
    }

    /// A long object (a rod, a bottle) is taken to be round across its axis.
    fn is_long(&self) -> bool {
        self.round && self.length >= LONG_OBJECT * self.breadth
    }
}

/// The least depth of the object's centre, read in `strip`, the band across it. A compact
/// object is at least half its breadth deep behind its nearest point, or behind the surface in
/// front of the centre if that is less (an animal seen from the side is shallower than it is
/// tall); no floor where nothing lies in front of the centre. A long object is round across its
/// axis: its axis lies half its width behind the surface in front of it, measured across the
/// axis, which along a ray tilted from the axis is that over the tilt's sine. The rim alone
/// would put a thin round object's centre in front of its axis, as no pixel falls exactly on
/// its outline.
fn depth_prior(
    outline: &Outline,
    depths: &[f64],
    strip: &Strip,
    long: Option<&LongAxis>,
    pitch: f64,
) -> f64 {
    let nearest = depths.iter().cloned().fold(f64::INFINITY, f64::min);
    let overall = nearest + outline.breadth / 2.0;
    let tilt = long.map_or(1.0, |l| l.tilt);
    let in_front = strip.in_front(outline);
    // Left out for a compact object, whose coarse fill makes up for the pixels' shortfall.
    let width = if long.is_some() {
        strip.outline_width(outline, pitch)
    } else {
        strip.width
    };
    let local = in_front + width / 2.0 / tilt;
    if !local.is_finite() {
        // Nothing in front of the centre: the camera sees through a hole there (a ring from
        // above), and the object's breadth says nothing of its depth. A ring seen from above
        // was completed 2.4 times its volume with the breadth's floor.
        f64::NEG_INFINITY
    } else if outline.is_long() {
        local
    } else {
        overall.min(local)
    }
}

/// The band of the patch across its long axis through the centre, where its width and the
/// surface in front of the centre are read.
struct Strip {
    /// The band's points.
    indices: Vec<usize>,
    /// Their depths, a long object's taken back along its axis to the centre's place: the
    /// surface of a tilted long object recedes along its axis, and the band's near end must not
    /// stand in for the surface in front of the centre.
    depths: Vec<f64>,
    /// The centre's place across the view.
    middle: Vector2<f64>,
    /// Half the band's width, across the view.
    band: f64,
    /// The band's extent across the long axis.
    width: f64,
}

impl Strip {
    fn new(
        outline: &Outline,
        depths: &[f64],
        view: &ViewFrame,
        centre: &Vector3<f64>,
        long: Option<&LongAxis>,
    ) -> Self {
        let middle = view.across(centre);
        let band = CENTRE_BAND * outline.length;
        let indices: Vec<usize> = (0..depths.len())
            .filter(|&i| (outline.across[i] - middle).dot(&outline.long).abs() <= band)
            .collect();
        let width = extent(
            indices
                .iter()
                .map(|&i| outline.across[i].dot(&outline.short)),
        );
        let (slope, along) = long.map_or((0.0, Vector2::zeros()), |l| {
            (l.depth_slope(), l.across_in(view))
        });
        let depths = indices
            .iter()
            .map(|&i| depths[i] - slope * (outline.across[i] - middle).dot(&along))
            .collect();
        Self {
            indices,
            depths,
            middle,
            band,
            width,
        }
    }

    /// The band's width as the outline's: pixels `pitch` apart (in image units) span a pitch
    /// less than the outline they sample, on average.
    fn outline_width(&self, outline: &Outline, pitch: f64) -> f64 {
        self.width + pitch * self.in_front(outline)
    }

    /// The least depth in the band's middle, across the long axis too: the surface in front of
    /// the centre (infinite where the band's middle is empty).
    fn in_front(&self, outline: &Outline) -> f64 {
        self.indices
            .iter()
            .zip(&self.depths)
            .filter(|(&i, _)| {
                (outline.across[i] - self.middle).dot(&outline.short).abs() <= self.band
            })
            .map(|(_, &d)| d)
            .fold(f64::INFINITY, f64::min)
    }

    /// Whether the band's depths span no more than `ROUND_ACROSS` times what a round object's
    /// would, seen tilted by `tilt`: from its ridge to its outline, half its width over the
    /// tilt. A ring seen almost edge-on is long too, but the band across its middle reaches
    /// from its near side to its far one: 3.831 and 3.853 times that in `bench views` (the torus
    /// from (1, 0.1, 0.2)), against 0.688 to 1.379 for the rods, capsules, ellipsoid, creature
    /// and torus it took as long otherwise (printed).
    fn is_round(&self, tilt: f64) -> bool {
        extent(self.depths.iter().copied()) <= ROUND_ACROSS * self.width / 2.0 / tilt
    }
}

/// The points' coordinates across the view (along `right` and `up`).
fn across_view(points: &[Vector3<f64>], view: &ViewFrame) -> Vec<Vector2<f64>> {
    points.iter().map(|p| view.across(p)).collect()
}

/// The principal axes of planar points, as the columns of a rotation.
fn principal_axes(points: &[Vector2<f64>]) -> Matrix2<f64> {
    let mean = points.iter().sum::<Vector2<f64>>() / points.len() as f64;
    let covariance = points
        .iter()
        .map(|q| (q - mean) * (q - mean).transpose())
        .sum::<Matrix2<f64>>();
    nalgebra::SymmetricEigen::new(covariance).eigenvectors
}

fn extent(values: impl Iterator<Item = f64>) -> f64 {
    let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| {
        (lo.min(x), hi.max(x))
    });
    hi - lo
}

/// The object's centre: the centroid of the patch's rim (the silhouette's generator, which a
/// centrally symmetric object's centre halves), a long object's moved along its axis to the
/// middle of its outline, then moved back along its ray to the depth floor of `depth_prior`
/// where it lies in front of it (a cap seen from its pole has its rim in front). A long object
/// whose surface across its middle fits a circle is then put on that circle's axis (see
/// `LongAxis::section`): the bundled rod scanned from `bench real`'s two sides had its centre
/// 1.6 and 3.4 mm off its axis, then 0.5 and 0.1 mm (printed); one whose surface there fits an
/// ellipse and no circle, on the ellipse's. A compact object that the visible half of an
/// ellipsoid describes is centred on it (`silhouette::ellipsoid_centre`), a box with two faces
/// in view on its box (`cuboid::box_centre`: its points within `BOX_TOLERANCE` point
/// spacings, `spacing`, of the box's faces), a long one too where no circle or ellipse fits
/// across its middle (taken round across its axis, a block would be as deep as it is broad);
/// another is at least midway between the nearest and the deepest point seen
/// (`seen_depths_middle`). Also the prior that decided.
/// `depths` and `image` are the points' depths and image coordinates in `view`; `outline` the
/// two-pixel bins and the rim found on them (`rim_points`).
fn estimated_centre(
    points: &[Vector3<f64>],
    depths: &[f64],
    image: &[Vector2<f64>],
    view: &ViewFrame,
    outline: (&ImageBins, &[usize]),
    spacing: f64,
) -> (Vector3<f64>, Prior) {
    let (bins, rim) = outline;
    let mut centroid = rim_centroid(points, rim);
    let mut outline = Outline::new(points, view);
    let mut long = outline
        .is_long()
        .then(|| LongAxis::new(points, view))
        .flatten();
    let mut round_strip = None;
    if let Some(axis) = &long {
        let moved = axis.to_outline_middle(points, view, &centroid);
        let strip = Strip::new(&outline, depths, view, &moved, Some(axis));
        if strip.is_round(axis.tilt) {
            centroid = moved;
            round_strip = Some(strip);
        } else {
            outline.round = false;
            long = None;
        }
    }
    let strip = round_strip.unwrap_or_else(|| Strip::new(&outline, depths, view, &centroid, None));
    if long.is_none() && outline.round {
        let axes = outline.axes(view);
        if let Some(centre) = silhouette::ellipsoid_centre(points, axes, &view.forward) {
            return (centre, Prior::Ellipsoid);
        }
        if let Some(centre) = cuboid::box_centre(points, BOX_TOLERANCE * spacing) {
            return (centre, Prior::Box);
        }
    }
    // The rim bins are two pixels wide.
    let pitch = bins.pixel / 2.0;
    let at_least = depth_prior(&outline, depths, &strip, long.as_ref(), pitch);
    // A long object's centre is on its axis (below); a long outline whose middle is deeper than
    // a round object's (a ring seen edge-on) has no one surface in front of its centre.
    let rim = view.depth(&centroid);
    let behind_rim = if long.is_none() && outline.round {
        let front = strip.in_front(&outline);
        silhouette::depth_behind_rim(image, depths, &view.image(&centroid), rim, front)
    } else {
        rim
    };
    let mut depth = behind_rim.max(at_least);
    if long.is_none() {
        depth = depth.max(seen_depths_middle(depths));
    }
    let centre = view.viewpoint + (centroid - view.viewpoint) * (depth / rim);
    if let Some(axis) = &long {
        let half_width = strip.outline_width(&outline, pitch) / 2.0;
        if let Some(on_axis) = axis.section(points, &strip, &centre, half_width, &view.forward) {
            return (on_axis, Prior::LongAxis);
        }
        if let Some(centre) = cuboid::box_centre(points, BOX_TOLERANCE * spacing) {
            return (centre, Prior::Box);
        }
    }
    let prior = if long.is_some() {
        Prior::Long
    } else {
        Prior::Compact
    };
    (centre, prior)
}

/// Midway between the nearest and the deepest point seen (at `OUTLINE_QUANTILE` and its
/// complement, so that a few stray pixels do not move it). A centrally symmetric object's depth
/// along the view spans as far behind its centre as in front, and every point seen lies within
/// that span: its centre is at least this deep. A box seen low, almost square to its long face,
/// shows its top face to the far edge, which the rim's centroid (its silhouette lies at the
/// near and far edges alike) does not weigh.
fn seen_depths_middle(depths: &[f64]) -> f64 {
    let (near, deep) = quantile_span(depths.iter().copied(), OUTLINE_QUANTILE);
    (near + deep) / 2.0
}

/// The values at quantile `q` and `1 - q` (the nearest ranks): how far a set of values
/// spans, a few strays at either end left out. Panics on no values.
pub(super) fn quantile_span(values: impl Iterator<Item = f64>, q: f64) -> (f64, f64) {
    let mut sorted: Vec<f64> = values.collect();
    sorted.sort_by(f64::total_cmp);
    let at = |q: f64| sorted[((sorted.len() - 1) as f64 * q).round() as usize];
    (at(q), at(1.0 - q))
}

/// A long object's axis (the points' longest principal axis) and how it lies in the view.
struct LongAxis {
    axis: Vector3<f64>,
    /// The axis's part across the view, normalized.
    across: Vector3<f64>,
    /// The sine of the angle between the axis and the view.
    tilt: f64,
    /// The cosine of that angle (signed: the axis's part along the view).
    along_view: f64,
}

impl LongAxis {
    /// None when the axis points nearly at the camera: its ends cannot be told apart then.
    fn new(points: &[Vector3<f64>], view: &ViewFrame) -> Option<Self> {
        let mean = points.iter().sum::<Vector3<f64>>() / points.len() as f64;
        let covariance = points
            .iter()
            .map(|p| (p - mean) * (p - mean).transpose())
            .sum::<Matrix3<f64>>();
        let eigen = nalgebra::SymmetricEigen::new(covariance);
        let axis = eigen
            .eigenvectors
            .column(eigen.eigenvalues.imax())
            .into_owned();
        let across = (axis - view.forward * axis.dot(&view.forward)).try_normalize(1e-9)?;
        let tilt = axis.dot(&across);
        (tilt >= MIN_AXIS_TILT).then_some(Self {
            axis,
            across,
            tilt,
            along_view: axis.dot(&view.forward),
        })
    }

    /// The axis's place fitted to the surface seen in `strip` across the object's middle (see
    /// `section::round_axis`; where that is no circle, `section::elliptic_axis`: the turned
    /// ellipsoid of `bench views`, taken as long from two sides, had been made 0.537 to 0.728 of
    /// its volume, round across its axis, and came to 0.999 to 1.023 with the ellipse, printed),
    /// as its point in the plane through `centre` across the axis; `forward` is the view's.
    fn section(
        &self,
        points: &[Vector3<f64>],
        strip: &Strip,
        centre: &Vector3<f64>,
        half_width: f64,
        forward: &Vector3<f64>,
    ) -> Option<Vector3<f64>> {
        let seen: Vec<Vector3<f64>> = strip.indices.iter().map(|&i| points[i]).collect();
        round_axis(&seen, &self.axis, centre, half_width)
            .or_else(|| elliptic_axis(&seen, &self.axis, centre, half_width, forward))
    }

    /// How much deeper the axis gets per unit it moves along `across`.
    fn depth_slope(&self) -> f64 {
        self.along_view / self.tilt
    }

    /// `across` in the view's (right, up) coordinates.
    fn across_in(&self, view: &ViewFrame) -> Vector2<f64> {
        Vector2::new(self.across.dot(&view.right), self.across.dot(&view.up))
    }

    /// `centre` moved along the axis to the middle of the patch's outline across the view: a
    /// centrally symmetric object's outline is symmetric about its centre, seen along any
    /// direction across the view. The rim's centroid leans towards where perspective puts more
    /// points, a long object's near end; moving along the object's own axis keeps it on that
    /// axis.
    fn to_outline_middle(
        &self,
        points: &[Vector3<f64>],
        view: &ViewFrame,
        centre: &Vector3<f64>,
    ) -> Vector3<f64> {
        let along = points
            .iter()
            .map(|p| (p - view.viewpoint).dot(&self.across));
        let (lo, hi) = quantile_span(along, OUTLINE_QUANTILE);
        let middle = (lo + hi) / 2.0;
        centre + self.axis * ((middle - (centre - view.viewpoint).dot(&self.across)) / self.tilt)
    }
}

/// The longest side of the points' bounding box.
fn longest_side(points: &[Vector3<f64>]) -> f64 {
    (0..3)
        .map(|a| extent(points.iter().map(|p| p[a])))
        .fold(0.0, f64::max)
}

/// Points from `front` to `back` (both excluded), `spacing` apart.
fn segment(
    front: &Vector3<f64>,
    back: &Vector3<f64>,
    spacing: f64,
) -> impl Iterator<Item = Vector3<f64>> {
    let steps = ((back - front).norm() / spacing).floor() as usize;
    let (front, back) = (*front, *back);
    (1..steps).map(move |k| front + (back - front) * (k as f64 / steps as f64))
}
