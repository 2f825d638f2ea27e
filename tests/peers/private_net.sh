#!/usr/bin/env bash
# Runs a command in a private network namespace: nothing it sends can leave this machine.
# Usage: unshare -n tests/peers/private_net.sh COMMAND...
# Besides lo, the namespace gets a veth pair with a private address, as most hosts have an
# interface besides loopback (tests/loopback.rs runs with lo alone). The pair's other end is in
# the same namespace, so it too is closed.
set -euo pipefail
ip link set lo up
ip link add physskin0 type veth peer name physskin1
ip addr add 10.213.0.1/24 dev physskin0
ip link set physskin0 up
ip link set physskin1 up
ip route add 224.0.0.0/4 dev physskin0
exec "$@"
