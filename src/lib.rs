//! # raylab
//!
//! An extensible, plugin-based ray-tracing framework. This crate is the **core**: it defines the
//! traits every plugin implements ([`Intersectable`], [`Geometry`], [`LightSource`],
//! [`Integrator`]), the camera, the scene model and its file format, the plugin [`Registry`], the
//! parallel render loop, image output and the command-line interface. It knows nothing of any
//! particular shape, light or integrator: those are plugins (the built-in ones live in the
//! `raylab-plugins` crate and use only this public API).
//!
//! Conventions: right-handed coordinates, distances in scene units, angles in degrees in scene
//! files, colours as linear RGB. Geometry is computed in `f64`; the film stores `f32`.

pub mod accel;
pub mod aov;
pub mod bounds;
pub mod bvh;
pub mod camera;
pub mod cli;
pub mod color;
pub mod error;
#[cfg(feature = "exr")]
pub mod exr;
pub mod files;
pub mod film;
pub mod float;
pub mod geometry;
pub mod integrator;
pub mod light;
pub mod load;
pub mod material;
pub mod metrics;
pub mod output;
pub mod params;
pub mod ray;
pub mod reference;
pub mod registry;
pub mod render;
pub mod sampler;
pub mod scene;
pub mod scene_toml;
pub mod stats;
pub mod testing;
pub mod trace;
pub mod transform;

pub use glam;

pub use bounds::Aabb;
pub use camera::Camera;
pub use color::{Color, Encoding};
pub use error::{SceneError, Source};
pub use film::Film;
pub use geometry::{Geometry, Hit, Intersectable, face_forward};
pub use integrator::Integrator;
pub use light::{LightSample, LightSource};
pub use load::{LoadContext, LoadOptions};
pub use material::Material;
pub use params::{ParamKind, ParamSpec, Params};
pub use ray::{Ray, RayKind};
pub use registry::{PluginInfo, Registry};
pub use render::{RenderJob, RenderSettings};
pub use sampler::Sampler;
pub use scene::Scene;
pub use stats::RayStats;
pub use trace::TraceNode;
pub use transform::{Transform, Transformed};
