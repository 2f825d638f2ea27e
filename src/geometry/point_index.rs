//! A uniform hash grid over points for nearest-neighbour queries.

use std::collections::HashMap;

use nalgebra::Vector3;

pub struct PointIndex<'a> {
    points: &'a [Vector3<f64>],
    cell: f64,
    buckets: HashMap<[i64; 3], Vec<u32>>,
}

impl<'a> PointIndex<'a> {
    /// `cell` is best near the typical neighbour spacing.
    pub fn new(points: &'a [Vector3<f64>], cell: f64) -> Self {
        let mut buckets: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
        for (i, p) in points.iter().enumerate() {
            buckets.entry(key(p, cell)).or_default().push(i as u32);
        }
        Self {
            points,
            cell,
            buckets,
        }
    }

    /// For points spread over a surface: a cell holding a handful of points.
    pub fn for_surface(points: &'a [Vector3<f64>]) -> Self {
        let (mut lo, mut hi) = (points[0], points[0]);
        for p in points {
            lo = lo.inf(p);
            hi = hi.sup(p);
        }
        let diagonal = (hi - lo).norm().max(1e-12);
        Self::new(
            points,
            2.0 * diagonal / (points.len() as f64).sqrt().max(1.0),
        )
    }

    /// Indices of the `k` nearest points to `query` (fewer if there are fewer points), nearest
    /// first, skipping `exclude`.
    pub fn nearest(&self, query: &Vector3<f64>, k: usize, exclude: Option<usize>) -> Vec<usize> {
        let center = key(query, self.cell);
        let wanted = k.min(self.points.len() - usize::from(exclude.is_some()));
        if wanted == 0 {
            return Vec::new();
        }
        let mut found: Vec<(f64, usize)> = Vec::new();
        for ring in 0i64.. {
            for dz in -ring..=ring {
                for dy in -ring..=ring {
                    for dx in -ring..=ring {
                        if dx.abs().max(dy.abs()).max(dz.abs()) != ring {
                            continue;
                        }
                        let cell = [center[0] + dx, center[1] + dy, center[2] + dz];
                        for &i in self.buckets.get(&cell).into_iter().flatten() {
                            let i = i as usize;
                            if Some(i) != exclude {
                                found.push(((self.points[i] - query).norm_squared(), i));
                            }
                        }
                    }
                }
            }
            // Every point not yet seen is farther than `ring` whole cells away.
            let reach = ring as f64 * self.cell;
            if found.len() >= wanted {
                found.sort_by(|a, b| a.0.total_cmp(&b.0));
                if found[wanted - 1].0.sqrt() <= reach {
                    break;
                }
            }
            if ring as usize > 2 * self.buckets.len() + 2 {
                break;
            }
        }
        found.sort_by(|a, b| a.0.total_cmp(&b.0));
        found.into_iter().take(wanted).map(|(_, i)| i).collect()
    }
}

fn key(p: &Vector3<f64>, cell: f64) -> [i64; 3] {
    [0, 1, 2].map(|a| (p[a] / cell).floor() as i64)
}
