//! Materials: how surfaces scatter light, registered by name for `[materials.NAME] type = "…"`
//! and inline material tables. Each maps itself onto the report's coefficients (what `phong`
//! reads) and may bring its own BSDF for the path tracer.
//!
//! - [`phong`]: the coefficients themselves (the default), and the BSDF the path tracer reads
//!   them through.
//! - [`pbr`]: glTF 2.0's metallic-roughness material, the specification's BRDF.

pub mod pbr;
pub mod phong;

use raylab::Registry;

/// Registers every material type.
pub fn register(r: &mut Registry) {
    r.add_material(phong::INFO, phong::build);
    r.add_material(pbr::INFO, pbr::build);
}
