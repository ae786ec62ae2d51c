//! From a scene file to a render job: the plugin registry, the load context with its limits and
//! sandbox, the scene's texture library, and the loader that turns a parsed scene (any registered
//! format) into a [`crate::render::RenderJob`].

pub mod context;
pub mod loader;
pub mod mesh;
pub mod registry;
pub mod textures;
