#!/usr/bin/env python3
"""MuJoCo's soft block for `bench track`: the truth a camera watches, made by an engine
physskin did not write.

A 0.24 x 0.16 x 0.12 m block (MuJoCo's <flexcomp type="grid" dim="3">, piecewise linear
tetrahedra, Saint Venant-Kirchhoff) rests on a floor with friction; kinematic paddles (mocap
boxes, which the camera sees and the node does not model) push it along the floor, squeeze
it from both sides, or it is dropped tilted. Prints ONE JSON object on stdout: the flex's
boundary triangles, its vertices at every output step (the rate --dt, MuJoCo stepping
--substeps times within each), and each paddle's eight corners at every output step.
Everything else (MuJoCo's warnings) goes to stderr.

Written against MuJoCo 4.0 (pip `mujoco-core`). Facts used, from the docs shipped in the
package (site-packages/mujoco/doc): 3D flex elasticity needs integrator="discrete"
(changelog 4.0); `flex_shell` holds a 3D flex's boundary faces as vertex triples
(APIreference, mjModel); MJCF angles are degrees unless <compiler angle="radian"/>; mocap
bodies move only where mjData.mocap_pos / mocap_quat put them; contact friction between a
flex and a geom is the larger of the two (so the floor and the flex are given the same).
"""

import argparse
import json
import math
import sys

import numpy as np
import mujoco

SIZE = (0.24, 0.16, 0.12)
COUNT = (9, 7, 5)
# A paddle: half sizes along (push, across, up), m.
PADDLE = (0.01, 0.05, 0.04)


def parse_args():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--scenario", required=True, choices=["pushed", "squeezed", "dropped"])
    p.add_argument("--seconds", type=float, required=True)
    p.add_argument("--dt", type=float, required=True, help="output step, s")
    p.add_argument("--substeps", type=int, default=8)
    p.add_argument("--young", type=float, required=True)
    p.add_argument("--poisson", type=float, required=True)
    p.add_argument("--density", type=float, required=True)
    p.add_argument("--friction", type=float, required=True)
    p.add_argument("--damping", type=float, default=0.005,
                   help="Rayleigh (stiffness-proportional) damping of the flex, s")
    return p.parse_args()


def paddles(scenario):
    """Each paddle: (rest centre, unit push direction). The pushed block's paddle starts
    2 cm off its +x face; the squeezing pair 1 cm off the long faces."""
    sx, sy, sz = SIZE
    if scenario == "pushed":
        return [(np.array([sx / 2 + 0.02 + PADDLE[0], 0.02, 0.05]), np.array([-1.0, 0.0, 0.0]))]
    if scenario == "squeezed":
        return [(np.array([0.0, s * (sy / 2 + 0.01 + PADDLE[0]), sz / 2]),
                 np.array([0.0, -s, 0.0])) for s in (1.0, -1.0)]
    return []


def travel(scenario, t):
    """How far each paddle has moved along its push direction at time t, m."""
    ramp = lambda a, b: min(max((t - a) / (b - a), 0.0), 1.0)
    if scenario == "pushed":
        # In for 1 s at 12 cm/s (2 cm to reach the block, 10 cm of push), back out after.
        return 0.12 * ramp(0.3, 1.3) - 0.12 * ramp(1.5, 2.0)
    if scenario == "squeezed":
        # 1 cm to reach the face, then 2.5 cm into it, held, and back.
        return 0.035 * ramp(0.3, 0.8) - 0.035 * ramp(1.3, 1.8)
    return 0.0


def build_xml(a, pads):
    sx, sy, sz = SIZE
    nx, ny, nz = COUNT
    spacing = " ".join(repr(s / (n - 1)) for s, n in zip(SIZE, COUNT))
    lift, tilt = (0.12, 20.0) if a.scenario == "dropped" else (0.0, 0.0)
    mass = a.density * sx * sy * sz
    friction = f'condim="3" friction="{a.friction!r} 0.005 0.0001"'
    bodies = []
    for k, (centre, push) in enumerate(pads):
        # The paddle's thin side along the push: yaw it so its x axis is the push direction.
        yaw = math.degrees(math.atan2(push[1], push[0]))
        pos = " ".join(repr(float(c)) for c in centre)
        size = " ".join(repr(h) for h in PADDLE)
        bodies.append(f'<body mocap="true" name="paddle{k}" pos="{pos}" euler="0 0 {yaw!r}">'
                      f'<geom type="box" size="{size}" {friction}/></body>')
    return f"""<mujoco model="tracked_block">
  <option timestep="{a.dt / a.substeps!r}" gravity="0 0 -9.81" integrator="discrete" solver="Newton"/>
  <worldbody>
    <geom name="floor" type="plane" size="0 0 1" {friction}/>
    <body name="start" pos="0 0 {sz / 2 + lift + 0.0005!r}" euler="0 {tilt!r} 0">
      <flexcomp name="B" type="grid" dim="3" count="{nx} {ny} {nz}" spacing="{spacing}"
                mass="{mass!r}" radius="0.001">
        <elasticity young="{a.young!r}" poisson="{a.poisson!r}" damping="{a.damping!r}"/>
        <contact selfcollide="none" {friction}/>
        <edge equality="false"/>
      </flexcomp>
    </body>
    {"".join(bodies)}
  </worldbody>
</mujoco>
"""


def corners(d, body):
    """A box body's eight corners in the world, corner c at the signs of its bits (x, y, z),
    as physskin's `box_mesh` numbers them."""
    signs = np.array([[1 if c & b else -1 for b in (1, 2, 4)] for c in range(8)])
    local = signs * np.array(PADDLE)
    rot = d.xmat[body].reshape(3, 3)
    return (local @ rot.T + d.xpos[body]).tolist()


def main():
    a = parse_args()
    mujoco.set_mju_user_warning(lambda msg: print("MuJoCo warning:", msg, file=sys.stderr))
    pads = paddles(a.scenario)
    m = mujoco.MjModel.from_xml_string(build_xml(a, pads))
    d = mujoco.MjData(m)
    assert m.nflex == 1
    va, nv = int(m.flex_vertadr[0]), int(m.flex_vertnum[0])
    sa, ns = int(m.flex_shelldataadr[0]), int(m.flex_shellnum[0])
    shell = m.flex_shell[sa:sa + 3 * ns].reshape(-1, 3).tolist()
    paddle_bodies = [m.body(f"paddle{k}").id for k in range(len(pads))]
    mujoco.mj_forward(m, d)
    positions, occluders = [], []
    steps = int(round(a.seconds / a.dt))
    bad = (mujoco.mjtWarning.mjWARN_BADQACC, mujoco.mjtWarning.mjWARN_BADQPOS,
           mujoco.mjtWarning.mjWARN_BADQVEL)
    for step in range(steps + 1):
        if step > 0:
            for _ in range(a.substeps):
                for body, (centre, push) in zip(paddle_bodies, pads):
                    d.mocap_pos[m.body_mocapid[body]] = centre + push * travel(a.scenario, d.time)
                mujoco.mj_step(m, d)
        # mj_step leaves the vertices where the last step began: place them for the new qpos.
        mujoco.mj_kinematics(m, d)
        mujoco.mj_flex(m, d)
        x = d.flexvert_xpos[va:va + nv]
        if not np.all(np.isfinite(x)) or any(d.warning[w].number > 0 for w in bad):
            sys.exit(f"MuJoCo diverged at step {step} of the {a.scenario} block")
        positions.append(x.tolist())
        occluders.append([corners(d, b) for b in paddle_bodies])
    out = {
        "mujoco_version": mujoco.mj_versionString(),
        "scenario": a.scenario,
        "surface": shell,
        "positions": positions,
        "occluders": occluders,
    }
    sys.stdout.write(json.dumps(out, allow_nan=False))
    sys.stdout.write("\n")


if __name__ == "__main__":
    main()
