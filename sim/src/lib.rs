//! Deterministic substation world implementing the driver traits of `msgs` (the default robot).
//!
//! | module | what |
//! |---|---|
//! | [`scene`], [`render`] | the substation geometry and the RGB-D renderer |
pub mod render;
pub mod scene;
