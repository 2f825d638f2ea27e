//! The ROS command line: what rcl takes between `--ros-args` and `--` (or the end), in the form
//! launch_ros writes for a Node action (`-r __node:=NAME -r __ns:=/NS --params-file F
//! -p NAME:=VALUE -r FROM:=TO --log-level LEVEL`).

use std::path::PathBuf;

use crate::runtime::names::{NameError, Remap};

/// Why the ROS arguments were refused.
#[derive(Debug, thiserror::Error)]
pub enum RosArgsError {
    /// The flag named needs a value and none followed.
    #[error("--ros-args: `{0}` needs a value")]
    MissingValue(String),
    /// An argument rcl does not know.
    #[error("--ros-args: unknown ROS argument `{0}`")]
    Unknown(String),
    /// A `-p` value that is not NAME:=VALUE.
    #[error("--ros-args: `-p {0}` is not NAME:=VALUE")]
    Param(String),
    /// A log level that is none of the five.
    #[error("--ros-args: log level `{0}` is none of debug, info, warn, error, fatal")]
    LogLevel(String),
    /// A remapping rule or a name in it was refused.
    #[error("--ros-args: {0}")]
    Name(#[from] NameError),
}

/// Severity of a log line, with rcl's numbers (rcl_interfaces/msg/Log).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum LogLevel {
    /// rcl's DEBUG (10).
    Debug = 10,
    /// rcl's INFO (20).
    Info = 20,
    /// rcl's WARN (30).
    Warn = 30,
    /// rcl's ERROR (40).
    Error = 40,
    /// rcl's FATAL (50).
    Fatal = 50,
}

impl LogLevel {
    /// The `log` facade's filter for this level (it has no fatal: fatal keeps errors).
    pub fn filter(self) -> log::LevelFilter {
        match self {
            Self::Debug => log::LevelFilter::Debug,
            Self::Info => log::LevelFilter::Info,
            Self::Warn => log::LevelFilter::Warn,
            Self::Error | Self::Fatal => log::LevelFilter::Error,
        }
    }

    /// Parses a level name in any case (`warning` also means warn).
    pub fn parse(text: &str) -> Result<Self, RosArgsError> {
        Ok(match text.to_ascii_lowercase().as_str() {
            "debug" => Self::Debug,
            "info" => Self::Info,
            "warn" | "warning" => Self::Warn,
            "error" => Self::Error,
            "fatal" => Self::Fatal,
            _ => return Err(RosArgsError::LogLevel(text.into())),
        })
    }
}

/// Everything the `--ros-args` sections of a command line said.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RosArgs {
    /// `-r [node:]FROM:=TO` rules, in order, `__node` and `__ns` included.
    pub remaps: Vec<Remap>,
    /// `-p NAME:=VALUE`, VALUE as YAML text, in order (a later one wins).
    pub params: Vec<(String, String)>,
    /// `--params-file`, in order (a later file wins).
    pub params_files: Vec<PathBuf>,
    /// `--log-level LEVEL` or `--log-level NAME:=LEVEL` (the node's logger name or any).
    pub log_level: Option<LogLevel>,
    /// `--disable-rosout-logs`.
    pub rosout_disabled: bool,
    /// Accepted and without effect here (enclaves, log configuration files), for a warning.
    pub ignored: Vec<String>,
}

/// Splits a command line into the program's own arguments and its ROS arguments. Several
/// `--ros-args` sections may appear; each runs to `--` or to the end.
pub fn split_ros_args(argv: &[String]) -> Result<(Vec<String>, RosArgs), RosArgsError> {
    let mut own = Vec::new();
    let mut ros = RosArgs::default();
    let mut i = 0;
    while i < argv.len() {
        if argv[i] != "--ros-args" {
            own.push(argv[i].clone());
            i += 1;
            continue;
        }
        i += 1;
        while i < argv.len() && argv[i] != "--" {
            if argv[i] != "--ros-args" {
                i = ros.take(argv, i)?;
            } else {
                i += 1;
            }
        }
        i += 1; // the closing `--`
    }
    Ok((own, ros))
}

impl RosArgs {
    /// Takes the argument at `i` (and its value); returns the index after them.
    fn take(&mut self, argv: &[String], i: usize) -> Result<usize, RosArgsError> {
        let flag = argv[i].as_str();
        let value = || {
            argv.get(i + 1)
                .filter(|v| *v != "--")
                .cloned()
                .ok_or_else(|| RosArgsError::MissingValue(flag.into()))
        };
        match flag {
            "-r" | "--remap" => self.remaps.push(Remap::parse(&value()?)?),
            "-p" | "--param" => {
                let v = value()?;
                let (name, yaml) = v
                    .split_once(":=")
                    .filter(|(n, _)| !n.is_empty())
                    .ok_or_else(|| RosArgsError::Param(v.clone()))?;
                self.params.push((name.into(), yaml.into()));
            }
            "--params-file" => self.params_files.push(value()?.into()),
            "--log-level" => {
                let v = value()?;
                // `NAME:=LEVEL` sets one logger's level; this node has one logger.
                let level = v.rsplit_once(":=").map_or(v.as_str(), |(_, l)| l);
                self.log_level = Some(LogLevel::parse(level)?);
            }
            "-e" | "--enclave" | "--log-config-file" | "--log-file-name" => {
                self.ignored.push(format!("{flag} {}", value()?));
            }
            "--disable-rosout-logs" => self.rosout_disabled = true,
            "--enable-rosout-logs" => self.rosout_disabled = false,
            "--enable-stdout-logs"
            | "--disable-stdout-logs"
            | "--enable-external-lib-logs"
            | "--disable-external-lib-logs" => self.ignored.push(flag.into()),
            other => return Err(RosArgsError::Unknown(other.into())),
        }
        let takes_value = !flag.starts_with("--enable") && !flag.starts_with("--disable");
        Ok(i + if takes_value { 2 } else { 1 })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn argv(text: &str) -> Vec<String> {
        text.split_whitespace().map(String::from).collect()
    }

    #[test]
    fn launch_ros_argv_is_taken_apart() {
        let line = "physskin node --record x.mcap --ros-args -r __node:=skin -r __ns:=/cell \
                    --params-file /tmp/launch_params_1 --params-file cfg.yaml -p rate_hz:=30.0 \
                    -r ~/points:=/camera/points --log-level warn";
        let (own, ros) = split_ros_args(&argv(line)).unwrap();
        assert_eq!(own, argv("physskin node --record x.mcap"));
        assert_eq!(ros.remaps.len(), 3);
        assert_eq!(ros.remaps[2].from, "~/points");
        assert_eq!(ros.remaps[2].to, "/camera/points");
        assert_eq!(
            ros.params_files,
            vec![PathBuf::from("/tmp/launch_params_1"), "cfg.yaml".into()]
        );
        assert_eq!(ros.params, vec![("rate_hz".into(), "30.0".into())]);
        assert_eq!(ros.log_level, Some(LogLevel::Warn));
    }

    #[test]
    fn sections_end_at_a_double_dash_and_may_repeat() {
        let line = "node --ros-args -p a:=1 -- --json --ros-args --log-level skin:=DEBUG";
        let (own, ros) = split_ros_args(&argv(line)).unwrap();
        assert_eq!(own, argv("node --json"));
        assert_eq!(ros.params, vec![("a".into(), "1".into())]);
        assert_eq!(ros.log_level, Some(LogLevel::Debug));
    }

    #[test]
    fn mistakes_name_the_argument() {
        let e = split_ros_args(&argv("node --ros-args --bogus")).unwrap_err();
        assert!(e.to_string().contains("--bogus"), "{e}");
        let e = split_ros_args(&argv("node --ros-args -p")).unwrap_err();
        assert!(e.to_string().contains("-p"), "{e}");
        let e = split_ros_args(&argv("node --ros-args -p rate_hz=3")).unwrap_err();
        assert!(e.to_string().contains("rate_hz=3"), "{e}");
        let e = split_ros_args(&argv("node --ros-args --log-level loud")).unwrap_err();
        assert!(e.to_string().contains("loud"), "{e}");
    }
}
