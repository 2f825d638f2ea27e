//! `bench track`'s sequences: the FEM's ball poked, rolled and dropped, its block squeezed,
//! poked out of view and left at rest, and MuJoCo's block pushed, squeezed, dropped and pushed
//! while hidden.

use nalgebra::Vector3;

use crate::geometry::{box_mesh, sdf_mesh, Shape};
use crate::physics::Poke;

/// One sequence: what makes its truth, and when the camera is blocked.
pub(super) struct Sequence {
    pub(super) name: &'static str,
    pub(super) source: Source,
    /// No frames in [start, end) s.
    pub(super) blocked: Option<(f64, f64)>,
}

/// What runs a sequence's truth.
pub(super) enum Source {
    /// The full-space FEM, the object `lifted` m above the floor, with forces the node never
    /// hears of.
    Fem {
        shape: Shape,
        lifted: f64,
        pokes: Vec<Poke>,
    },
    /// MuJoCo's soft block in one of `benches/peers/mujoco_track.py`'s scenarios.
    Mujoco(&'static str),
}

/// The pokes' push along -x, N. The floor holds with the node's friction (0.5): the block
/// (4.6 kg) slides only under a push past half its weight; the ball rocks under 2 N and rolls
/// away under 8 N, a roll its round surface does not show (see docs/limits.md).
const BALL_POKE_N: f64 = 2.0;
const BALL_ROLL_N: f64 = 8.0;
/// The block's poke slides it about 9 cm against Coulomb friction; 40 N threw it 0.37 m.
const BLOCK_POKE_N: f64 = 30.0;
/// Each hand's squeeze, N, spread over 3 x 3 points this far apart, m.
const SQUEEZE_N: f64 = 150.0;
const SQUEEZE_SPACING: f64 = 0.03;

/// The six FEM sequences, each `seconds` long, and with `mujoco` MuJoCo's four.
pub(super) fn sequences(seconds: f64, mujoco: bool) -> Vec<Sequence> {
    let ball = || {
        let mut shape = sdf_mesh(&|p: &Vector3<f64>| p.norm() - 0.1, 0.12, 28);
        shape.positions.iter_mut().for_each(|p| p.z += 0.1);
        shape
    };
    let mut block = box_mesh(Vector3::new(0.24, 0.16, 0.12));
    block.positions.iter_mut().for_each(|p| p.z += 0.06);
    let poke = |start: f64, point: Vector3<f64>, push: f64| Poke {
        // The side the camera sees, pushed in and toward the back.
        point,
        force: Vector3::new(-1.0, -0.35, -0.35) * push,
        start,
        end: start + 0.4,
    };
    // Two hands, one on each long side: a patch of 3 x 3 points each (a point alone only
    // dents the FEM's nearest vertex).
    let squeeze = |y: f64| -> Vec<Poke> {
        let patch = [-1.0, 0.0, 1.0];
        let (start, end) = (0.3, 0.3 + 0.8f64.min(seconds - 0.6));
        patch
            .iter()
            .flat_map(|&a| patch.iter().map(move |&b| (a, b)))
            .map(|(a, b)| Poke {
                point: Vector3::new(SQUEEZE_SPACING * a, y, 0.06 + SQUEEZE_SPACING * b),
                force: Vector3::new(0.0, -y.signum() * SQUEEZE_N / 9.0, 0.0),
                start,
                end,
            })
            .collect()
    };
    let mut list = vec![
        Sequence {
            name: "ball poked",
            source: Source::Fem {
                shape: ball(),
                lifted: 0.0,
                pokes: vec![poke(0.3, Vector3::new(0.07, 0.04, 0.15), BALL_POKE_N)],
            },
            blocked: None,
        },
        Sequence {
            name: "block squeezed",
            source: Source::Fem {
                shape: block.clone(),
                lifted: 0.0,
                pokes: [squeeze(0.08), squeeze(-0.08)].concat(),
            },
            blocked: None,
        },
        Sequence {
            name: "ball dropped",
            source: Source::Fem {
                shape: ball(),
                lifted: 0.12,
                pokes: vec![],
            },
            blocked: None,
        },
        // Pushed, then out of view for 0.5 s while it slides on.
        Sequence {
            name: "block poked, view blocked",
            source: Source::Fem {
                shape: block.clone(),
                lifted: 0.0,
                pokes: vec![poke(0.2, Vector3::new(0.12, 0.03, 0.09), BLOCK_POKE_N)],
            },
            blocked: Some((0.7, 1.2)),
        },
        Sequence {
            name: "ball rolled",
            source: Source::Fem {
                shape: ball(),
                lifted: 0.0,
                pokes: vec![poke(0.3, Vector3::new(0.07, 0.04, 0.15), BALL_ROLL_N)],
            },
            blocked: None,
        },
        // Nothing touches it: what a tracker does to an object the camera sees at rest is its
        // own error (uncorrected, the body stays exactly where its first frame put it).
        Sequence {
            name: "block at rest",
            source: Source::Fem {
                shape: block,
                lifted: 0.0,
                pokes: vec![],
            },
            blocked: None,
        },
    ];
    if mujoco {
        list.extend(mujoco_sequences());
    }
    list
}

/// MuJoCo's block pushed along the floor, squeezed, dropped, and pushed while the view is
/// blocked for 0.5 s as it slides.
fn mujoco_sequences() -> Vec<Sequence> {
    let sequence = |name, scenario, blocked| Sequence {
        name,
        source: Source::Mujoco(scenario),
        blocked,
    };
    vec![
        sequence("mujoco block pushed", "pushed", None),
        sequence("mujoco block squeezed", "squeezed", None),
        sequence("mujoco block dropped", "dropped", None),
        sequence(
            "mujoco block pushed while hidden",
            "pushed",
            Some((0.7, 1.2)),
        ),
    ]
}
