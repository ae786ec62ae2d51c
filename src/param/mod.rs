//! The parameter language every scene format and plugin speaks: the located value tree a format
//! produces, the parameter tables plugins declare and the reading of parameters against them,
//! errors that name file, line and column, TOML in and out, the sandbox every file read goes
//! through, the limits a scene may not exceed, and the fingerprints of what a load read.

pub mod description;
pub mod error;
pub mod files;
pub mod fingerprint;
pub mod limits;
pub mod params;
pub mod spec;
pub mod toml;
pub mod value;
