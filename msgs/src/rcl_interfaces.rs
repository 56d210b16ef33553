//! `rcl_interfaces`: Log (`/rosout`).

use serde::{Deserialize, Serialize};

use crate::builtin_interfaces::Time;
use crate::schema::{LOG, impl_ros_message};

/// `rcl_interfaces/msg/Log`: one log line on `/rosout`.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Log {
    /// When the line was logged (robot clock).
    pub stamp: Time,
    /// Severity: [`Log::DEBUG`] .. [`Log::FATAL`].
    pub level: u8,
    /// Logger name (the stage or driver).
    pub name: String,
    /// The message.
    pub msg: String,
    /// Source file.
    pub file: String,
    /// Source function.
    pub function: String,
    /// Source line.
    pub line: u32,
}
impl_ros_message!(Log, "rcl_interfaces", "Log", LOG);

impl Log {
    /// `byte DEBUG=10`.
    pub const DEBUG: u8 = 10;
    /// `byte INFO=20`.
    pub const INFO: u8 = 20;
    /// `byte WARN=30`.
    pub const WARN: u8 = 30;
    /// `byte ERROR=40`.
    pub const ERROR: u8 = 40;
    /// `byte FATAL=50`.
    pub const FATAL: u8 = 50;

    /// A `/rosout` line from the node (stage, driver) `name`, stamped `stamp`, without a
    /// source location ([`Log::in_file`] adds one).
    #[must_use]
    pub fn line(name: &str, stamp: Time, level: u8, text: impl Into<String>) -> Self {
        Self {
            stamp,
            level,
            name: name.to_owned(),
            msg: text.into(),
            file: String::new(),
            function: String::new(),
            line: 0,
        }
    }

    /// The same line with its source file recorded.
    #[must_use]
    pub fn in_file(mut self, file: &str) -> Self {
        self.file = file.to_owned();
        self
    }
}
