//! What an index is built as ([`AccelChoice`] and its thresholds) and what building it cost
//! ([`BuildStats`]), with the two constants that keep the hierarchy's `f32` traversal
//! conservative (see [`super::bvh`]): shared by the index front (`bvh.rs`) and the 8-wide
//! hierarchy (`wide.rs`).

use std::time::Duration;

/// Which spatial index to use: chosen per scene and per mesh by [`AccelChoice::use_bvh`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum AccelChoice {
    /// A hierarchy when there are enough primitives to pay for it, a list otherwise.
    #[default]
    Auto,
    /// Always a flat list.
    List,
    /// Always a hierarchy (an error at load time when raylab is built without `bvh`).
    Bvh,
}

impl AccelChoice {
    /// Parses `"auto"`, `"list"` or `"bvh"`.
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "auto" => Some(AccelChoice::Auto),
            "list" => Some(AccelChoice::List),
            "bvh" => Some(AccelChoice::Bvh),
            _ => None,
        }
    }

    /// Whether `count` primitives get a hierarchy. `Auto` builds one from `threshold` primitives
    /// on, and only when raylab is built with the `bvh` feature.
    pub fn use_bvh(self, count: usize, threshold: usize) -> bool {
        BVH_AVAILABLE
            && match self {
                AccelChoice::Auto => count >= threshold,
                AccelChoice::List => false,
                AccelChoice::Bvh => count >= 2,
            }
    }
}

/// True when raylab is built with the `bvh` feature.
pub const BVH_AVAILABLE: bool = cfg!(feature = "bvh");

/// Fewest bounded scene objects for which `auto` builds a scene-level hierarchy. Below it a list
/// with a box test per object is as fast, within measurement noise; from about eight objects on
/// the hierarchy wins (measured: docs/performance.md, "Speed of meshes and BVHs").
pub const SCENE_BVH_THRESHOLD: usize = 8;

/// Fewest triangles for which `auto` builds a mesh hierarchy.
pub const MESH_BVH_THRESHOLD: usize = 16;

/// Padding of every primitive box, relative to the magnitude of the root box (its largest
/// coordinate plus its diagonal). It exceeds the `f32` rounding error of the origin and
/// direction of a ray near the box (2⁻²⁴ each), of the quantised slab test (≈ 4·2⁻²⁴) and of
/// the quantisation itself, so the traversal never culls a box the exact ray meets.
pub const BOX_PADDING: f64 = 1.0 / (1u64 << 18) as f64;

/// Largest reciprocal of a direction component used by the `f32` slab test. A component
/// smaller than its inverse is treated as that small: the resulting displacement of the ray is
/// far below [`BOX_PADDING`] of anything the ray can reach.
#[cfg(feature = "bvh")]
pub(crate) const MAX_INV_DIR: f32 = 1e15;

/// What building an index cost, for the render summary and `raylab bench`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BuildStats {
    /// Hierarchies built (0 for a list).
    pub hierarchies: u32,
    /// Primitives indexed by hierarchies.
    pub primitives: u64,
    /// Hierarchy nodes.
    pub nodes: u64,
    /// Bytes of the hierarchies' nodes.
    pub bytes: u64,
    /// Wall time of building.
    pub time: Duration,
}

impl std::ops::AddAssign for BuildStats {
    fn add_assign(&mut self, o: BuildStats) {
        self.hierarchies += o.hierarchies;
        self.primitives += o.primitives;
        self.nodes += o.nodes;
        self.bytes += o.bytes;
        self.time += o.time;
    }
}
