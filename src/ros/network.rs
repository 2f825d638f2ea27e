//! Which network DDS uses. On a host where only loopback is up (a container or a robot with
//! its network down), RustDDS and Fast DDS discover each other but exchange no sample unless
//! the node keeps to 127.0.0.1; the node then does so, and says why.

/// The choice, with what to tell the user.
pub struct NetworkChoice {
    pub loopback_only: bool,
    pub warnings: Vec<String>,
}

/// Loopback only when asked, when the environment asks ROS 2 for localhost-only discovery,
/// or when no other interface is up.
pub fn choose(asked: bool) -> NetworkChoice {
    let mut warnings = Vec::new();
    let env = |name: &str| std::env::var(name).unwrap_or_default();
    let localhost_env =
        env("ROS_LOCALHOST_ONLY") == "1" || env("ROS_AUTOMATIC_DISCOVERY_RANGE") == "LOCALHOST";
    let others = interfaces_up_besides_loopback();
    if localhost_env && !asked {
        warnings.push(
            "ROS_LOCALHOST_ONLY=1 or ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST is set: DDS keeps to \
             127.0.0.1. Fast DDS peers started with it use shared memory and loopback; if no \
             sample arrives, start the peers without it (ROS_AUTOMATIC_DISCOVERY_RANGE=SUBNET)"
                .into(),
        );
    }
    let only_loopback = others.is_some_and(|n| n == 0);
    if only_loopback && !asked && !localhost_env {
        warnings.push(
            "no network interface but loopback is up: DDS keeps to 127.0.0.1 so that peers on \
             this host receive samples (with loopback alone, Fast DDS announces locators the \
             node cannot reach otherwise); bring an interface up to talk to other hosts"
                .into(),
        );
    }
    NetworkChoice {
        loopback_only: asked || localhost_env || only_loopback,
        warnings,
    }
}

/// How many interfaces other than loopback are up; None when /sys cannot tell.
fn interfaces_up_besides_loopback() -> Option<usize> {
    let entries = std::fs::read_dir("/sys/class/net").ok()?;
    let up = entries
        .filter_map(Result::ok)
        .filter(|e| e.file_name() != "lo")
        .filter(|e| {
            let flags = std::fs::read_to_string(e.path().join("flags")).unwrap_or_default();
            let flags = u32::from_str_radix(flags.trim().trim_start_matches("0x"), 16).unwrap_or(0);
            // IFF_UP and not IFF_LOOPBACK.
            flags & 0x1 != 0 && flags & 0x8 == 0
        })
        .count();
    Some(up)
}
