//! Deterministic substation world implementing the driver traits of `msgs` (the default robot).
