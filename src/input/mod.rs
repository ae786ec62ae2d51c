//! From a scene file to a render job: the plugin registry, the located value tree every scene
//! format produces, the parameter tables plugins declare, the loader with its limits, and the
//! sandbox every file read goes through.

pub mod context;
pub mod description;
pub mod error;
pub mod files;
pub mod fingerprint;
pub mod limits;
pub mod load;
pub mod params;
pub mod registry;
pub mod spec;
pub mod textures;
pub mod toml;
pub mod value;
