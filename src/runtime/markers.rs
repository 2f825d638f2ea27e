//! The deformed surface of each object as a visualization_msgs/Marker TRIANGLE_LIST, coloured
//! by its dominant handle: the input mesh's triangles, or for a cloud the boundary of the
//! solid the node built for it.

use nalgebra::Vector3;

use crate::msg::{ColorRGBA, Header, Marker, Point, Pose, Quaternion, Vector3 as RosVector3};
use crate::physics::Lifter;
use crate::pipeline::SoftBody;

/// Cells across the longest side of the surface drawn for a cloud: about a thousand triangles
/// for a compact object (a 2:1:1 box: 1,280), so a marker stays near 150 KB.
const CLOUD_SURFACE_CELLS: usize = 16;

/// The triangles drawn for one object and the colour of each vertex.
pub struct MarkerSurface {
    triangles: Vec<[u32; 3]>,
    /// Lifts the surface's vertices; None when they are the body's own points (a mesh).
    lifter: Option<Lifter>,
    colors: Vec<ColorRGBA>,
    /// The lifted vertices (x, y, z each), reused every frame.
    vertices: Vec<f32>,
}

impl MarkerSurface {
    /// The surface of `body`: `triangles` over its points (a mesh input), or, when there are
    /// none (a cloud), the boundary of its solid.
    pub fn of(body: &SoftBody, triangles: &[[u32; 3]]) -> Self {
        if !triangles.is_empty() {
            return Self {
                triangles: triangles.to_vec(),
                lifter: None,
                colors: dominant_colors(body.lifter()),
                vertices: Vec::new(),
            };
        }
        let (points, triangles) = body.voxel_surface(CLOUD_SURFACE_CELLS);
        let lifter = body.lifter_for(&points);
        Self {
            triangles,
            colors: dominant_colors(&lifter),
            vertices: vec![0.0; 3 * points.len()],
            lifter: Some(lifter),
        }
    }

    /// After `body` switched to another field (its refinement): a cloud's surface lifted by
    /// the new field, whose state the old field's weights would misread; the colours by the
    /// new field's handles.
    pub fn rebase(&mut self, body: &SoftBody) {
        match &self.lifter {
            Some(lifter) => {
                let lifter = body.lifter_for(&lifter.rest_points());
                self.colors = dominant_colors(&lifter);
                self.lifter = Some(lifter);
            }
            None => self.colors = dominant_colors(body.lifter()),
        }
    }

    /// The ADD marker of the body's current pose.
    pub fn marker(&mut self, body: &SoftBody, header: Header, ns: &str, id: u32) -> Marker {
        let vertices: &[f32] = match &self.lifter {
            Some(lifter) => {
                lifter.lift(body.state(), &mut self.vertices);
                &self.vertices
            }
            None => body.deformed(),
        };
        let corner = |v: u32| {
            let v = 3 * v as usize;
            Point {
                x: vertices[v] as f64,
                y: vertices[v + 1] as f64,
                z: vertices[v + 2] as f64,
            }
        };
        let mut marker = base(header, ns, id, Marker::ADD);
        marker.points = self
            .triangles
            .iter()
            .flatten()
            .map(|&v| corner(v))
            .collect();
        marker.colors = self
            .triangles
            .iter()
            .flatten()
            .map(|&v| self.colors[v as usize].clone())
            .collect();
        marker
    }
}

/// The DELETE marker of an object that went away.
pub fn delete_marker(header: Header, ns: &str, id: u32) -> Marker {
    base(header, ns, id, Marker::DELETE)
}

fn base(header: Header, ns: &str, id: u32, action: i32) -> Marker {
    Marker {
        header,
        ns: ns.into(),
        id: id as i32,
        r#type: Marker::TRIANGLE_LIST,
        action,
        pose: Pose {
            orientation: Quaternion {
                w: 1.0,
                ..Default::default()
            },
            ..Default::default()
        },
        scale: RosVector3 {
            x: 1.0,
            y: 1.0,
            z: 1.0,
        },
        color: ColorRGBA {
            r: 1.0,
            g: 1.0,
            b: 1.0,
            a: 1.0,
        },
        ..Default::default()
    }
}

/// Per point, the colour of its largest non-rigid handle (the rigid handle w0 is 1 everywhere).
fn dominant_colors(lifter: &Lifter) -> Vec<ColorRGBA> {
    let handles = lifter.handles();
    (0..lifter.len())
        .map(|p| {
            let dominant = (1..handles.max(2))
                .filter(|&h| h < handles)
                .max_by(|&a, &b| {
                    lifter
                        .weight(p, a)
                        .abs()
                        .total_cmp(&lifter.weight(p, b).abs())
                })
                .unwrap_or(0);
            palette(dominant, handles)
        })
        .collect()
}

/// Evenly spaced hues, one per handle.
fn palette(handle: usize, handles: usize) -> ColorRGBA {
    let hue = handle as f32 / handles.max(1) as f32 * 6.0;
    let rgb = Vector3::new(
        (hue - 3.0).abs() - 1.0,
        2.0 - (hue - 2.0).abs(),
        2.0 - (hue - 4.0).abs(),
    )
    .map(|c| c.clamp(0.0, 1.0) * 0.8 + 0.2);
    ColorRGBA {
        r: rgb.x,
        g: rgb.y,
        b: rgb.z,
        a: 1.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Shape, VoxelGrid};

    /// After its body switches to the refined field, a cloud's surface is lifted by that
    /// field: its marker matches the solid's surface lifted afresh, where the surface made
    /// before the switch would read the new state with the old field's weights.
    #[test]
    fn a_cloud_surface_follows_its_body_to_the_refined_field() {
        use crate::pipeline::{BodyOptions, Support};
        use crate::skinning::{NeuralModel, RefineBudget, RefineOptions};
        let shape = crate::geometry::bundled("rod").unwrap();
        let options = BodyOptions {
            support: Support::Free,
            refine: RefineBudget::Off,
            ..BodyOptions::default()
        };
        let model = std::sync::Arc::new(NeuralModel::bundled().unwrap());
        let mut body = SoftBody::build(&model, &shape, &shape.positions, &options).unwrap();
        assert!(body.pin(&Vector3::new(-0.6, 0.0, 0.0), 0.1) > 0);
        for _ in 0..10 {
            body.step();
        }
        let (mut surface, mut stale) =
            (MarkerSurface::of(&body, &[]), MarkerSurface::of(&body, &[]));
        let prepared = body
            .basis_plan()
            .refined(&RefineOptions::default())
            .unwrap();
        body.switch_to(prepared).unwrap();
        surface.rebase(&body);
        body.step();
        let vertices = |s: &mut MarkerSurface| -> Vec<f64> {
            let marker = s.marker(&body, Header::default(), "rod", 1);
            marker.points.iter().flat_map(|p| [p.x, p.y, p.z]).collect()
        };
        let (now, before) = (vertices(&mut surface), vertices(&mut stale));
        let mut expected = MarkerSurface::of(&body, &[]);
        let expected = vertices(&mut expected);
        let off = |a: &[f64], b: &[f64]| {
            a.iter()
                .zip(b)
                .map(|(x, y)| (x - y).abs())
                .fold(0.0, f64::max)
        };
        assert!(
            off(&now, &expected) < 1e-6,
            "rebased surface off by {}",
            off(&now, &expected)
        );
        assert!(
            off(&before, &expected) > 1e-3,
            "the surface made before the switch is off by {}",
            off(&before, &expected)
        );
    }

    #[test]
    fn the_voxel_boundary_is_closed_and_faces_out() {
        let shape: Shape = crate::geometry::box_mesh(Vector3::new(0.2, 0.1, 0.1));
        let grid = VoxelGrid::from_shape(&shape, 16, None).resample(8);
        let (points, triangles) = grid.boundary_mesh();
        // Closed: every edge is shared by exactly two triangles, in opposite directions.
        let mut edges = std::collections::HashMap::new();
        for t in &triangles {
            for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
                *edges.entry((a, b)).or_insert(0) += 1;
            }
        }
        assert!(edges
            .iter()
            .all(|(&(a, b), &n)| n == 1 && edges.get(&(b, a)) == Some(&1)));
        // Outward: the signed volume is the solid's.
        let volume: f64 = triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|v| points[v as usize]);
                a.dot(&b.cross(&c)) / 6.0
            })
            .sum();
        let solid = grid.solid_count() as f64 * grid.cell.powi(3);
        assert!(
            (volume - solid).abs() < 1e-9 * solid.max(1.0),
            "{volume} vs {solid}"
        );
    }
}
