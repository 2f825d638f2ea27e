//! Which network DDS uses, and what the node says about it. Measured here: on a host where
//! only loopback is up, RustDDS and Fast DDS discover each other and Fast DDS's samples reach
//! the node, but the node's samples never reach Fast DDS readers (their acknowledgements never
//! come), with the node on 127.0.0.1 or not, with Fast DDS on UDPv4 only, and with multicast on
//! lo. The node cannot fix that from its side, so it says so at start, with what to do.

/// What to do on a loopback-only host: give it an interface that is not loopback.
const FIX: &str = "bring up an interface besides loopback, e.g. `ip link add physskin0 type \
     veth peer name physskin1 && ip addr add 10.213.0.1/24 dev physskin0 && ip link set \
     physskin0 up && ip link set physskin1 up && ip route add 224.0.0.0/4 dev physskin0` (as \
     tests/peers/private_net.sh does)";

/// What to tell the user when the host or the environment keep DDS on loopback (`asked`: the
/// node itself was told to keep to 127.0.0.1).
pub fn warnings(asked: bool) -> Vec<String> {
    let mut warnings = Vec::new();
    let env = |name: &str| std::env::var(name).unwrap_or_default();
    if env("ROS_LOCALHOST_ONLY") == "1" || env("ROS_AUTOMATIC_DISCOVERY_RANGE") == "LOCALHOST" {
        warnings.push(format!(
            "ROS_LOCALHOST_ONLY=1 or ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST is set: Fast DDS \
             peers started with it keep to loopback, where they discover this node but receive \
             none of its samples. Start them with ROS_AUTOMATIC_DISCOVERY_RANGE=SUBNET (and \
             ROS_LOCALHOST_ONLY unset) and keep traffic on this host with a private network \
             namespace, or {FIX}"
        ));
    }
    if !asked && interfaces_up_besides_loopback() == Some(0) {
        warnings.push(format!(
            "only loopback is up: Fast DDS peers will discover this node and send to it, but \
             will receive none of its samples (RustDDS and Fast DDS exchange no user data over \
             loopback alone); {FIX}"
        ));
    }
    warnings
}

/// How many interfaces other than loopback are up with an IPv4 address, in this process's
/// network namespace (getifaddrs: /sys may show another namespace's); None if it cannot tell.
fn interfaces_up_besides_loopback() -> Option<usize> {
    let mut list: *mut libc::ifaddrs = std::ptr::null_mut();
    // SAFETY: getifaddrs fills `list` with a linked list that we only read and then free once.
    if unsafe { libc::getifaddrs(&mut list) } != 0 {
        return None;
    }
    let mut count = 0;
    let mut at = list;
    while !at.is_null() {
        // SAFETY: `at` is a node of the list getifaddrs returned, not yet freed.
        let entry = unsafe { &*at };
        let flags = entry.ifa_flags;
        let up = flags & libc::IFF_UP as u32 != 0 && flags & libc::IFF_LOOPBACK as u32 == 0;
        // SAFETY: ifa_addr is null or points to a sockaddr of the entry.
        let ipv4 = !entry.ifa_addr.is_null()
            && unsafe { (*entry.ifa_addr).sa_family } == libc::AF_INET as libc::sa_family_t;
        if up && ipv4 {
            count += 1;
        }
        at = entry.ifa_next;
    }
    // SAFETY: `list` came from getifaddrs and is freed once.
    unsafe { libc::freeifaddrs(list) };
    Some(count)
}
