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
pub mod cli;
pub mod geometry;
pub mod image;
pub mod load;
pub mod math;
pub mod param;
pub mod render;
pub mod scene;
pub mod testing;
#[cfg(feature = "view")]
pub mod view;

pub use glam;

pub use geometry::transform::{Transform, Transformed};
pub use geometry::{Geometry, Hit, Intersectable, face_forward};
pub use load::context::{LoadContext, LoadOptions};
pub use load::registry::{PluginInfo, Registry};
pub use math::bounds::Aabb;
pub use math::color::{Color, Encoding};
pub use math::ray::{Ray, RayKind};
pub use math::sampler::Sampler;
pub use param::error::{SceneError, Source};
pub use param::params::Params;
pub use param::spec::{ParamKind, ParamSpec};
pub use render::film::Film;
pub use render::integrator::Integrator;
pub use render::stats::RayStats;
pub use render::trace::TraceNode;
pub use render::{RenderJob, RenderSettings};
pub use scene::Scene;
pub use scene::camera::Camera;
pub use scene::light::{LightPdf, LightSample, LightSource};
pub use scene::material::Material;
