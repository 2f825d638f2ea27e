//! One log for the whole program: the `log` facade's records from physskin go to stderr and,
//! while a node runs, to /rosout (rcl_interfaces/msg/Log). The status topic carries the same
//! events (see `Outputs::report`). `--log-level` sets the level of all three.

use std::sync::RwLock;

use ros2_client::{NodeLoggingHandle, RosoutRaw};

/// Where records go besides stderr while a node runs: its /rosout handle and logger name.
static ROSOUT: RwLock<Option<(NodeLoggingHandle, String)>> = RwLock::new(None);

struct Logger;

static LOGGER: Logger = Logger;

impl log::Log for Logger {
    /// physskin's own records only: the DDS and shared-memory layers log their internals
    /// through the same facade, and those are not the user's business.
    fn enabled(&self, metadata: &log::Metadata) -> bool {
        metadata.target().starts_with("physskin") && metadata.level() <= log::max_level()
    }

    fn log(&self, record: &log::Record) {
        if !self.enabled(record.metadata()) {
            return;
        }
        let level = record.level().as_str().to_ascii_lowercase();
        let line = record.args().to_string();
        eprintln!("[physskin] {level}: {line}");
        let Ok(rosout) = ROSOUT.read() else { return };
        if let Some((handle, name)) = rosout.as_ref() {
            use ros2_client::ros2::LogLevel as Rcl;
            let rcl = match record.level() {
                log::Level::Error => Rcl::Error,
                log::Level::Warn => Rcl::Warn,
                log::Level::Info => Rcl::Info,
                log::Level::Debug | log::Level::Trace => Rcl::Debug,
            };
            let now = ros2_client::ros2::Timestamp::now();
            let file = record.file().unwrap_or("");
            let function = record.module_path().unwrap_or("");
            let at = record.line().unwrap_or(0);
            handle.rosout_raw(now, rcl, name, &line, file, function, at);
        }
    }

    fn flush(&self) {}
}

/// Installs the logger (once per process; later calls only change the level).
pub fn install_logger(level: log::LevelFilter) {
    let _ = log::set_logger(&LOGGER);
    log::set_max_level(level);
}

/// Records also go to /rosout through `handle`, as the logger `name`, until [`detach_rosout`].
pub(crate) fn attach_rosout(handle: NodeLoggingHandle, name: String) {
    if let Ok(mut rosout) = ROSOUT.write() {
        *rosout = Some((handle, name));
    }
}

/// Records stop going to /rosout (the node is stopping).
pub(crate) fn detach_rosout() {
    if let Ok(mut rosout) = ROSOUT.write() {
        *rosout = None;
    }
}
