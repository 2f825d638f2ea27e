#!/usr/bin/env python3
"""MuJoCo peer for the soft-block benchmark.

Simulates an elastic cube (edge --size, centred on the origin in its rest
frame) built with MuJoCo's <flexcomp type="grid" dim="3">, and prints ONE JSON
object on stdout (everything else, MuJoCo warnings included, goes to stderr).

Written against MuJoCo 4.0.0 (pip).  Facts used below, and where they come
from (doc = the reStructuredText files shipped in the pip package under
site-packages/mujoco/doc/, also at mujoco.readthedocs.io):

* flexcomp `dof` accepts full, radial, trilinear, quadratic, 2d
  (doc/XMLreference.rst, "body/flexcomp" -> :at:`dof`).  trilinear = 2x2x2 = 8
  nodes (24 dofs), quadratic = 3x3x3 = 27 nodes (81 dofs) for cellcount 1 1 1;
  the mesh vertices are interpolated from the nodes.
* flexcomp `mass` = total mass, split over the generated bodies
  (doc: "body/flexcomp" -> :at:`mass`; "pinning some points does not affect
  the mass of the other bodies").  Checked by compiling: dof=full gives every
  body mass/N^3 (uniform per vertex, not volume-lumped), so with a face
  pinned the moving bodies carry only mass*(N-1)/N; trilinear/quadratic
  lump the mass onto the nodes (quadratic: Simpson weights) and, with pins,
  the moving nodes still sum to the full mass.
* 3D flex elasticity (<elasticity young poisson damping>) is Saint
  Venant-Kirchhoff: energy density mu tr(E^2) + lambda/2 tr(E)^2 with Green
  strain E and the standard Lame parameters, on piecewise linear tetrahedra
  (doc: "flex/elasticity"; 4.0.0 fixed an old factor 2 on lambda).  That is
  the dof=full path.  For trilinear/quadratic the source
  (src/engine/engine_passive.c, mj_flexPassiveInterp, read in a pre-4.0
  snapshot of the repository) applies a precomputed linear cell stiffness
  matrix in a per-cell corotated frame, i.e. corotational linear elasticity
  on one 8-node / 27-node hexahedral cell.  `damping` is Rayleigh's
  (stiffness-proportional) coefficient, units of time (doc:
  "flex/elasticity" -> :at:`damping`).
* radius: "It can be zero in 3D" (doc: "deformable/flex" -> :at:`radius`).
  With radius r > 0 the elements are inflated by r for collisions, so the
  vertices come to rest r above the floor; the default here is 0.
* Integrator: flex elasticity REQUIRES integrator="discrete" in 4.0 (it
  raises an error under implicit / implicitfast; Euler is explicit);
  doc/modeling.rst, "Deformables" tuning ("Integrator and solver") and the
  4.0.0 changelog.  Solver Newton (the default) is the one recommended there.
* <pin>: for interpolated flexes (trilinear/quadratic) pins refer to the
  interpolation NODES, and `grid`/`gridrange` use node grid coordinates
  (doc: "flexcomp/pin").  For dof=full on a grid they are vertex grid coords.
* <contact selfcollide="none" friction=...> (doc: "flex/contact").
* Body/vertex/node ordering: grid points and nodes are ordered x slowest,
  z fastest (index = (ix*ny + iy)*nz + iz).  Found by compiling the model and
  reading mj_saveLastXML output: dof=full creates bodies B_0..B_{N^3-1} at the
  grid points in that order; trilinear/quadratic create bodies B_ix_iy_iz.
  The script does not rely on this: it finds ids by matching positions (see
  find_corner_body) and asserts the vertex order against the grid.

Tilt (drop): the model itself is built untilted (so the flex reference
configuration, the node cage of trilinear/quadratic and the world-aligned
slide joints are those of the untilted block); the tilt is applied through the
initial qpos of the slide joints.  Both trilinear and quadratic interpolation
reproduce affine maps exactly, so the vertices land exactly on R_y(A)*rest,
which is asserted after mj_forward.  Both elastic models are rotation
invariant, so the tilted start is stress free.
"""

import argparse
import json
import math
import sys
import time

import numpy as np
import mujoco


def eprint(*a):
    print(*a, file=sys.stderr)


def parse_args():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--variant", required=True, choices=["full", "trilinear", "quadratic"])
    p.add_argument("--scenario", required=True, choices=["drop", "poke"])
    p.add_argument("--size", type=float, required=True)
    p.add_argument("--count", type=int, default=5)
    p.add_argument("--young", type=float, required=True)
    p.add_argument("--poisson", type=float, required=True)
    p.add_argument("--density", type=float, required=True)
    p.add_argument("--dt", type=float, required=True)
    p.add_argument("--substeps", type=int, default=1)
    p.add_argument("--steps", type=int, required=True)
    p.add_argument("--gravity-z", type=float, default=-9.81)
    p.add_argument("--tilt-deg", type=float, default=20.0)
    p.add_argument("--floor-z", type=float, default=None)
    p.add_argument("--force", type=str, default=None, help="fx,fy,fz in N (poke)")
    p.add_argument("--poke-at", type=str, default=None,
                   help="x,y,z: rest position of the poked vertex, a corner of the block (poke)")
    p.add_argument("--pin-x", type=float, default=None,
                   help="vertices with rest x <= this are pinned (poke)")
    p.add_argument("--poke-s", type=float, default=0.15)
    p.add_argument("--damping", type=float, default=0.0)
    p.add_argument("--friction", type=float, default=0.0,
                   help="sliding friction of the floor contact; 0 makes it frictionless (condim 1)")
    p.add_argument("--radius", type=float, default=0.0,
                   help="flex element radius (m); 0 (allowed for dim=3) makes the "
                        "vertices themselves touch the floor")
    p.add_argument("--dump-xml", action="store_true",
                   help="also write the generated MJCF to stderr")
    a = p.parse_args()
    if a.count < 2:
        p.error("--count must be >= 2")
    if a.substeps < 1:
        p.error("--substeps must be >= 1")
    if a.scenario == "drop" and a.floor_z is None:
        p.error("--floor-z is required for --scenario drop")
    if a.scenario == "poke":
        if a.force is None:
            p.error("--force fx,fy,fz is required for --scenario poke")
        try:
            f = [float(v) for v in a.force.split(",")]
        except ValueError:
            p.error("--force must be fx,fy,fz")
        if len(f) != 3:
            p.error("--force must be fx,fy,fz")
        a.force_vec = np.array(f)
        if a.poke_at is None or a.pin_x is None:
            p.error("--poke-at x,y,z and --pin-x X are required for --scenario poke")
        a.poke_point = np.array([float(v) for v in a.poke_at.split(",")])
    return a


def build_xml(a):
    """The MJCF for one case.  Everything is in SI units."""
    n = a.count
    h = a.size / (n - 1)
    mass = a.density * a.size ** 3
    timestep = a.dt / a.substeps
    radius = a.radius
    # flexcomp checks spacing >= 2*radius + margin
    if h < 2 * radius:
        radius = 0.25 * h

    pin = ""
    if a.scenario == "poke":
        # The layers of the grid (full: vertices; trilinear, quadratic: nodes)
        # with rest x <= --pin-x, the first at x = -S/2:
        #   full:      vertex grid N x N x N  -> gridrange "0 0 0  L N-1 N-1"
        #   trilinear: node grid 2 x 2 x 2    -> gridrange "0 0 0  L 1 1"
        #   quadratic: node grid 3 x 3 x 3    -> gridrange "0 0 0  L 2 2"
        # For trilinear/quadratic, fixing the ix=0 nodes fixes the whole x=-S/2
        # face exactly (the face's interpolation only involves those nodes).
        m = {"full": n - 1, "trilinear": 1, "quadratic": 2}[a.variant]
        layers = int(math.floor((a.pin_x + a.size / 2) / (a.size / m) + 1e-9))
        last = max(0, min(layers, m))
        pin = f'\n        <pin gridrange="0 0 0 {last} {m} {m}"/>'

    # condim 1: normal force only (frictionless); 3: sliding friction as well.
    if a.friction > 0:
        contact = f'condim="3" friction="{a.friction!r} 0.005 0.0001"'
    else:
        contact = 'condim="1"'
    floor = ""
    if a.scenario == "drop":
        # friction and condim combine by max between geom and flex: set both the same
        floor = (f'\n    <geom name="floor" type="plane" size="0 0 1" pos="0 0 {a.floor_z!r}"'
                 f' {contact}/>')

    return f"""<mujoco model="soft_block">
  <compiler angle="radian"/>
  <option timestep="{timestep!r}" gravity="0 0 {a.gravity_z!r}" integrator="discrete" solver="Newton"/>
  <worldbody>{floor}
    <flexcomp name="B" type="grid" dim="3" dof="{a.variant}" count="{n} {n} {n}"
              spacing="{h!r} {h!r} {h!r}" mass="{mass!r}" radius="{radius!r}">
        <elasticity young="{a.young!r}" poisson="{a.poisson!r}" damping="{a.damping!r}"/>
        <contact selfcollide="none" {contact}/>
        <edge equality="false"/>{pin}
    </flexcomp>
  </worldbody>
</mujoco>
"""


def grid_rest(n, size):
    """Expected rest positions, x slowest, z fastest, centred on the origin."""
    c = (np.arange(n) - 0.5 * (n - 1)) * (size / (n - 1))
    X, Y, Z = np.meshgrid(c, c, c, indexing="ij")
    return np.stack([X.ravel(), Y.ravel(), Z.ravel()], axis=1)


def rot_y(deg):
    t = math.radians(deg)
    c, s = math.cos(t), math.sin(t)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def flex_bodies(m, f):
    """Body ids that carry the flex's dofs (vertex bodies or node bodies)."""
    if m.flex_interp[f]:
        a, k = m.flex_nodeadr[f], m.flex_nodenum[f]
        ids = m.flex_nodebodyid[a:a + k]
    else:
        a, k = m.flex_vertadr[f], m.flex_vertnum[f]
        ids = m.flex_vertbodyid[a:a + k]
    return sorted({int(b) for b in ids if b > 0})


def find_corner_body(m, f, corner, rest):
    """Body id of the dof point sitting at `corner` (rest frame).

    dof=full: every unpinned vertex is its own body; the vertex index comes
    from matching the compiled rest positions, and its body is
    m.flex_vertbodyid[vertadr + i].
    trilinear/quadratic: the corner vertex coincides with a corner node of the
    interpolation cage (its interpolation weight is 1 there and 0 at all other
    nodes), so a force on that node is the same generalised force as a force
    on the vertex.  The node index comes from matching m.flex_node0 (Cartesian
    node positions in qpos0) and its body is m.flex_nodebodyid[nodeadr + i].
    """
    if m.flex_interp[f]:
        a, k = m.flex_nodeadr[f], m.flex_nodenum[f]
        d = np.linalg.norm(m.flex_node0[a:a + k] - corner, axis=1)
        i = int(np.argmin(d))
        assert d[i] < 1e-9, "no interpolation node at the poked corner"
        b = int(m.flex_nodebodyid[a + i])
    else:
        d = np.linalg.norm(rest - corner, axis=1)
        i = int(np.argmin(d))
        assert d[i] < 1e-9, "no vertex at the poked corner"
        b = int(m.flex_vertbodyid[m.flex_vertadr[f] + i])
    assert b > 0, "the poked corner is pinned / has no body"
    return b, i


def set_body_translation(m, qpos, body, delta):
    """Move a slide-jointed flex body by `delta` (world frame) through qpos.

    flexcomp gives each free vertex/node body 3 orthogonal slide joints
    (world axes here, since the parent is the world body); qpos of a slide
    is the displacement along its axis from the compiled position.
    """
    ja, jn = m.body_jntadr[body], m.body_jntnum[body]
    assert jn == 3, "expected 3 slide joints per flex body"
    for j in range(ja, ja + jn):
        assert m.jnt_type[j] == mujoco.mjtJoint.mjJNT_SLIDE
        qpos[m.jnt_qposadr[j]] = float(np.dot(delta, m.jnt_axis[j]))


def main():
    a = parse_args()
    # Route MuJoCo warnings to stderr (the default handler also appends to
    # MUJOCO_LOG.TXT in the working directory).  MuJoCo 4.0 warns "flex 'B' is
    # not rigid and has no equality constraints or passive forces" whenever the
    # elasticity damping is 0; its check ignores 3D elastic stiffness, so that
    # warning is harmless here.
    mujoco.set_mju_user_warning(lambda msg: eprint("MuJoCo warning:", msg))

    xml = build_xml(a)
    if a.dump_xml:
        eprint(xml)
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    f = 0
    assert m.nflex == 1
    nv_ = int(m.flex_vertnum[f])
    va = int(m.flex_vertadr[f])

    # --- rest configuration (qpos0 = untilted, centred) --------------------
    mujoco.mj_forward(m, d)
    rest = d.flexvert_xpos[va:va + nv_].copy()
    expect = grid_rest(a.count, a.size)
    assert rest.shape == expect.shape and np.max(np.abs(rest - expect)) < 1e-9, \
        "flex vertex order/positions differ from the x-slowest/z-fastest grid"

    # --- total mass -----------------------------------------------------------
    bodies = flex_bodies(m, f)
    body_mass = float(sum(m.body_mass[b] for b in bodies))
    total_mass = a.density * a.size ** 3

    # --- scenario set-up -------------------------------------------------------
    force_body = -1
    if a.scenario == "drop":
        R = rot_y(a.tilt_deg)
        qpos = m.qpos0.copy()
        if m.flex_interp[f]:
            na, nn = m.flex_nodeadr[f], m.flex_nodenum[f]
            for i in range(nn):
                b = int(m.flex_nodebodyid[na + i])
                p0 = m.flex_node0[na + i]
                set_body_translation(m, qpos, b, R @ p0 - p0)
        else:
            for i in range(nv_):
                b = int(m.flex_vertbodyid[va + i])
                assert b > 0
                p0 = rest[i]
                set_body_translation(m, qpos, b, R @ p0 - p0)
        d.qpos[:] = qpos
        d.qvel[:] = 0
        mujoco.mj_forward(m, d)
        x0 = d.flexvert_xpos[va:va + nv_]
        err = float(np.max(np.abs(x0 - rest @ R.T)))
        assert err < 1e-9, f"tilted start differs from R_y(A)*rest by {err}"
        eprint(f"[mujoco_block] tilt check max|x0 - R rest| = {err:.3e}")
    else:
        corner = a.poke_point
        force_body, idx = find_corner_body(m, f, corner, rest)
        pinned = np.where(rest[:, 0] <= a.pin_x)[0]
        eprint(f"[mujoco_block] poke: force on body {force_body} "
               f"('{m.body(force_body).name}', {'node' if m.flex_interp[f] else 'vertex'} {idx}); "
               f"{len(pinned)} vertices at x <= {a.pin_x}")
        mujoco.mj_forward(m, d)

    # --- simulate ----------------------------------------------------------------
    poke_steps = 0
    if a.scenario == "poke":
        # the force is set in xfrc_applied for the first round(poke_s/timestep)
        # MuJoCo steps (those starting at t < poke_s), then zeroed
        poke_steps = int(round(a.poke_s / m.opt.timestep))
    bad = (mujoco.mjtWarning.mjWARN_BADQACC, mujoco.mjtWarning.mjWARN_BADQPOS,
           mujoco.mjtWarning.mjWARN_BADQVEL)
    frames, step_s = [], []
    finite = True
    istep = 0
    for _ in range(a.steps):
        t0 = time.perf_counter()
        for _k in range(a.substeps):
            if force_body > 0:
                d.xfrc_applied[force_body, :3] = a.force_vec if istep < poke_steps else 0.0
            mujoco.mj_step(m, d)
            istep += 1
        t1 = time.perf_counter()
        # mj_step leaves flexvert_xpos at the positions of the *start* of the
        # last step; recompute them for the new qpos (outside the timing).
        mujoco.mj_kinematics(m, d)
        mujoco.mj_flex(m, d)
        x = d.flexvert_xpos[va:va + nv_]
        # MuJoCo resets mjData on a bad qacc/qpos/qvel (and warns); count that
        # as a blow-up as well, since the reset state would look finite.
        if not np.all(np.isfinite(x)) or any(d.warning[w].number > 0 for w in bad):
            finite = False
            eprint(f"[mujoco_block] diverged at frame {len(frames)}; stopping")
            break
        frames.append(x.ravel().tolist())
        step_s.append(t1 - t0)

    if m.opt.integrator == mujoco.mjtIntegrator.mjINT_DISCRETE:
        integ = "discrete"
    else:
        integ = mujoco.mjtIntegrator(m.opt.integrator).name

    eprint(json.dumps({"diag": {
        "flex_body_mass_sum": body_mass, "density_S3": total_mass,
        "nbody_flex": len(bodies), "nflexnode": int(m.flex_nodenum[f]),
        "ncon_end": int(d.ncon)}}))

    out = {
        "variant": a.variant,
        "scenario": a.scenario,
        "mujoco_version": mujoco.mj_versionString(),
        "nv": int(m.nv),
        "rest": rest.tolist(),
        "frames": frames,
        "step_s": step_s,
        "finite": bool(finite),
        "timestep": float(m.opt.timestep),
        "integrator": integ,
    }
    sys.stdout.write(json.dumps(out, allow_nan=False))
    sys.stdout.write("\n")


if __name__ == "__main__":
    main()
