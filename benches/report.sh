#!/usr/bin/env bash
# Regenerates the result files the README and docs quote, then renders their tables
# (benches/render.py) and checks every quoted figure against its file (tests/doc_figures.rs).
# Prose that quotes a figure which changed must then be edited by hand: the check names it.
#
# What runs (2 cores; the latency bench needs root for `unshare -n` and pip for rclpy):
#   demo               demo --json                            (the README's main command)
#   simulate(-eigen)   simulate --json [--field eigen]        (one rod against the FEM)
#   contact            bench contact                          (resting balls, the grasp)
#   stress             bench stress                           (numerical stress table)
#   real               bench real                             (camera scans against the FEM)
#   views              bench views                            (camera scans' completed volumes)
#   sim-solver-quick   bench sim --quick, 16 handles, 1024 cubature points
#   latency            benches/latency.sh                     (node latency and jitter)
#   latency-refine-off benches/latency.sh, --refine off       (the same, no refinement thread)
#   latency-shards     benches/latency.sh, --shards           (the same beside a second instance)
#   replay             bench replay                           (replay speed, recording's cost)
#   replay-stream      replay bags/stream.mcap                (a 3.5 s camera stream, one build)
#   replay-minute      replay a minute of bench track's poked ball (written first, 2 minutes)
#   transport          bench transport, private namespace     (iceoryx2 against DDS)
#   scene              bench scene                            (only what a scene needs)
#   sim-bulk           bench sim, plate and rod, 16 handles, both bulk terms (6 min)
#   sim-bulk-quick     bench sim --quick, 16 handles, 3 scenarios, both bulk terms (1 min)
#   eval               eval                                   (the learned field on 15 shapes, 4 min)
#   basis              bench basis                            (error against time to a basis, 4 shapes)
#   peer               bench peer                             (the soft block in MuJoCo and physskin)
#   track              bench track                            (a stream tracked, 3 minutes)
#   track-mujoco       bench track, MuJoCo's sequences        (MuJoCo's soft block tracked, 2 minutes)
#   track-steep        bench track --view 0.5,0.3,1, all nine (the camera steeper above, tracked, 4 minutes)
#   track-seeds        bench track --seeds 7,8,9, all nine    (each row's spread over three noise draws, 7 minutes)
#   stream-cpu         benches/stream_cpu.sh                  (the node's CPU share on a stream)
#   sim-targets        bench sim, rod and plate, 16 handles, 1024 points (about 5 minutes)
#   sim-creature       bench sim, creature, 16 handles, 1024 points (about 40 minutes, mostly FEM)
#   sim                the full `bench sim` (about 70 minutes; docs/benchmarks.md quotes it)
#   fem                bench fem                              (the FEM reference's convergence, 35 minutes)
#   fem-fitted         bench fem --fitted, plate and rod      (the same on volume-true meshes, 3 minutes)
#   fem-quadratic      bench fem --fitted --quadratic, plate and rod (quadratic tetrahedra, 3 minutes)
#   sim-quadratic-quick bench sim --quick against quadratic tetrahedra, 16 handles, quasi-Newton (15 minutes)
#   sim-quadratic-handles bench sim --quick --quadratic, hanging, 4 to 32 handles (12 minutes, mostly the creature's FEM)
#   sim-quadratic-poisson the plate and rod of sim-quadratic-handles at Poisson's ratio 0.3 (1 minute)
#   sim-statics        bench sim, plate and rod hanging, quasi-Newton (static error, about 5 minutes)
#   sim-statics-quick  bench sim --quick, hanging, quasi-Newton (the creature's static error on a small mesh)
# `readme` stands for every file README.md quotes, the full `bench sim` last: one run of
# `benches/report.sh readme` (about 95 minutes) puts the README's figures at one commit.
# Usage: benches/report.sh [NAME...]   (default: all but the three sim runs)
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --locked
bin=target/release/physskin
# MuJoCo from pip, in the venv tests/peer.rs and tests/tracking.rs make too.
mujoco_venv() {
    [ -x target/mujoco-venv/bin/python ] || python3 -m venv target/mujoco-venv
    target/mujoco-venv/bin/python -c 'import mujoco' 2>/dev/null \
        || target/mujoco-venv/bin/pip install -q mujoco-core numpy
}

names=("$@")
[ ${#names[@]} -eq 0 ] && names=(demo simulate simulate-eigen contact stress real views sim-solver-quick latency latency-refine-off replay replay-stream replay-minute transport scene eval basis peer track track-mujoco stream-cpu)
if [ "${names[*]}" = readme ]; then
    names=(demo contact views real latency scene peer eval track stream-cpu sim)
fi
for name in "${names[@]}"; do
    started=$(date +%s)
    case $name in
        demo) benches/record.sh demo $bin demo --json ;;
        simulate) benches/record.sh simulate $bin simulate --json ;;
        simulate-eigen) benches/record.sh simulate-eigen $bin simulate --field eigen --json ;;
        contact) benches/record.sh contact $bin bench contact --json ;;
        stress) benches/record.sh stress $bin bench stress --json ;;
        real) benches/record.sh real $bin bench real --json ;;
        views) benches/record.sh views $bin bench views --json ;;
        sim-bulk)
            benches/record.sh sim-bulk $bin bench sim --shape plate,rod --handles 16 \
                --cubature 256,1024 --solver quasi-newton --bulk points,regions --json \
                --plot target/bench/sim-bulk.svg ;;
        sim-bulk-quick)
            benches/record.sh sim-bulk-quick $bin bench sim --quick --scenario hanging,drop,poke \
                --handles 16 --cubature 256,1024 --solver quasi-newton --bulk points,regions \
                --json --plot target/bench/sim-bulk-quick.svg ;;
        sim-solver-quick)
            benches/record.sh sim-solver-quick $bin bench sim --quick --json \
                --scenario hanging,drop,poke --handles 16 --cubature 1024 \
                --plot target/bench/sim-solver.svg ;;
        latency) bash benches/latency.sh ;;
        latency-refine-off) bash benches/latency.sh latency-refine-off --refine off ;;
        latency-shards) bash benches/latency.sh latency-shards --shards ;;
        replay) benches/record.sh replay $bin bench replay --json ;;
        replay-stream)
            benches/record.sh replay-stream $bin replay bags/stream.mcap \
                --params config/stream.yaml --json ;;
        replay-minute)
            # Not bundled (about 50 MB): the bench writes it from its FEM truth, then it replays.
            mkdir -p target/bench
            $bin bench track --sequence "ball poked" --modes tracked --seconds 60 \
                --write-stream target/bench/minute.mcap --plot target/bench/minute.svg >/dev/null
            benches/record.sh replay-minute $bin replay target/bench/minute.mcap \
                --params config/stream.yaml --json ;;
        transport)
            benches/record.sh transport unshare -n tests/peers/private_net.sh \
                $bin bench transport --json ;;
        scene) benches/record.sh scene $bin bench scene --json ;;
        eval) benches/record.sh eval $bin eval --json ;;
        basis)
            benches/record.sh basis $bin bench basis --json --plot docs/images/basis.svg ;;
        peer)
            mujoco_venv
            benches/record.sh peer $bin bench peer --json \
                --python target/mujoco-venv/bin/python --plot docs/images/peer.svg ;;
        track)
            benches/record.sh track $bin bench track --json --plot docs/images/track.svg ;;
        track-mujoco)
            mujoco_venv
            benches/record.sh track-mujoco $bin bench track --json --sequence mujoco \
                --python target/mujoco-venv/bin/python --plot docs/images/track-mujoco.svg ;;
        track-steep)
            mujoco_venv
            benches/record.sh track-steep $bin bench track --json --modes uncorrected,tracked \
                --view 0.5,0.3,1 --python target/mujoco-venv/bin/python --plot /tmp/track-steep.svg ;;
        track-seeds)
            mujoco_venv
            benches/record.sh track-seeds $bin bench track --json --modes uncorrected,tracked \
                --seeds 7,8,9 --python target/mujoco-venv/bin/python --plot /tmp/track-seeds.svg ;;
        stream-cpu) bash benches/stream_cpu.sh ;;
        sim-targets)
            benches/record.sh sim-targets $bin bench sim --shape rod,plate --handles 16 \
                --cubature 1024 --json --plot /tmp/sim-targets.svg ;;
        sim-creature)
            benches/record.sh sim-creature $bin bench sim --shape creature --handles 16 \
                --cubature 1024 --json --plot /tmp/sim-creature.svg ;;
        sim) benches/record.sh sim $bin bench sim --json --plot benches/results/sim.svg ;;
        fem) benches/record.sh fem $bin bench fem --json ;;
        fem-fitted) benches/record.sh fem-fitted $bin bench fem --shapes plate,rod --fitted --json ;;
        fem-quadratic) benches/record.sh fem-quadratic $bin bench fem --shapes plate,rod --fitted --quadratic --json ;;
        sim-quadratic-quick)
            benches/record.sh sim-quadratic-quick $bin bench sim --quick --handles 16 \
                --solver quasi-newton --quadratic --json --plot /tmp/sim-quadratic-quick.svg ;;
        sim-quadratic-handles)
            benches/record.sh sim-quadratic-handles $bin bench sim --quick --quadratic \
                --scenario hanging --handles 4,8,16,32 --cubature 256,1024 \
                --solver quasi-newton --json --plot docs/images/sim-quadratic.svg ;;
        sim-quadratic-poisson)
            benches/record.sh sim-quadratic-poisson $bin bench sim --quick --quadratic \
                --poisson 0.3 --shape plate,rod --scenario hanging --handles 4,8,16,32 \
                --cubature 256,1024 --solver quasi-newton --json \
                --plot /tmp/sim-quadratic-poisson.svg ;;
        sim-statics)
            benches/record.sh sim-statics $bin bench sim --shape plate,rod --scenario hanging \
                --handles 4,16 --cubature 256,1024 --solver quasi-newton --json \
                --plot /tmp/sim-statics.svg ;;
        sim-statics-quick)
            benches/record.sh sim-statics-quick $bin bench sim --quick --scenario hanging \
                --solver quasi-newton --json --plot /tmp/sim-statics-quick.svg ;;
        *) echo "unknown result: $name" >&2; exit 2 ;;
    esac
    echo "$name: $(( $(date +%s) - started )) s" >&2
done
python3 benches/render.py
cargo test --release --locked --test doc_figures
