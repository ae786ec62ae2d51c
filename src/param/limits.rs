//! Upper bounds on what a scene may ask for, checked before anything is allocated, and the
//! memory estimates they are checked against.

/// Upper bounds checked before anything is allocated. Each can be raised from the command line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Limits {
    /// Largest image, in pixels (width × height).
    pub max_pixels: u64,
    /// Largest image side, in pixels.
    pub max_side: u32,
    /// Most samples per pixel.
    pub max_spp: u32,
    /// Deepest recursion an integrator may be asked for.
    pub max_depth: u32,
    /// Largest file a scene may make raylab read (meshes, included files), bytes.
    pub max_file_bytes: u64,
    /// Most triangles one mesh object may have (counted before its index and hierarchy are built;
    /// for glTF, from the accessors before their data is decoded).
    pub max_triangles: u64,
    /// Most memory the image may take, bytes: the film, the extra layers and the encoder's
    /// copies, estimated before rendering ([`crate::image::output::image_bytes`]).
    pub max_image_bytes: u64,
    /// Most rays a render may trace, enforced while it traces and checked before it starts
    /// ([`crate::render::budget`]); [`crate::RenderJob::max_rays`] carries it to the render loop.
    /// `raylab trace` of one pixel is not held to it (its explanation has its own bound,
    /// [`crate::render::trace::MAX_EXPLAINED_RAYS`]).
    pub max_rays: u64,
    /// Most memory the whole job may take, bytes, as estimated before each large allocation
    /// ([`LoadContext::charge`]): the parsed scene description, every object, every mesh with
    /// its hierarchy, glTF instances, and the image.
    pub max_memory: u64,
}

/// Default [`Limits::max_image_bytes`]: 4 GiB, which holds 4096 × 4096 as EXR with every layer
/// (the render's exact sums, the layers and the encoder's copies) and an 8K UHD frame as PNG; the
/// job as a whole stays within [`DEFAULT_MAX_MEMORY`], which the image is charged against too.
pub const DEFAULT_MAX_IMAGE_BYTES: u64 = 4 << 30;

/// Default work budget, rays. Every bundled and course
/// scene renders within it (`dozen` at 256 spp traces about 4.7·10⁸), while a scene whose rays
/// all split without pruning is stopped by the pilot before it starts ([`crate::render::budget`]).
pub const DEFAULT_MAX_RAYS: u64 = 100_000_000_000;

/// Default [`Limits::max_memory`]: 4.25 GiB of estimated memory, so that with one file read
/// whole beside it ([`DEFAULT_MAX_FILE_BYTES`]) a job stays under 5 GB.
pub const DEFAULT_MAX_MEMORY: u64 = 17 << 28;

/// Default [`Limits::max_file_bytes`]: 64 MiB, the largest single read, which is not part of
/// the memory estimate while it happens ([`DEFAULT_MAX_MEMORY`] + this < 5 GB), and the largest
/// input whose linear-time load stays within a minute (10⁶ spheres, 64 MB of TOML: about 20 s).
/// The 1.1 M-triangle bunny OBJ (42 MB) is within it.
pub const DEFAULT_MAX_FILE_BYTES: u64 = 1 << 26;

/// Estimated peak bytes of parsing TOML `text` into a description (the parser's tree and the
/// located [`Table`] it becomes), from one linear scan: per `=` (a key and its value) or `{`
/// [`TOML_BYTES_PER_KEY`], per `,` or `[` (an array element or a table header)
/// [`TOML_BYTES_PER_ITEM`], and [`TOML_BYTES_PER_BYTE`] per byte for the text and string copies.
pub fn toml_memory_estimate(text: &[u8]) -> u64 {
    let (mut keys, mut items) = (0u64, 0u64);
    for &b in text {
        match b {
            b'=' | b'{' => keys += 1,
            b',' | b'[' => items += 1,
            _ => {}
        }
    }
    keys * TOML_BYTES_PER_KEY + items * TOML_BYTES_PER_ITEM + text.len() as u64 * TOML_BYTES_PER_BYTE
}

/// Estimated bytes per TOML key while parsed (measured peak: about 370 for 2·10⁶ keys of one table).
pub const TOML_BYTES_PER_KEY: u64 = 512;
/// Estimated bytes per TOML array element or table header while parsed (measured peak: about 190
/// per element of an array of 10⁷ integers, 340 per empty `[[a]]` table).
pub const TOML_BYTES_PER_ITEM: u64 = 256;
/// Estimated bytes per byte of TOML text beyond its values: the text itself and string copies.
pub const TOML_BYTES_PER_BYTE: u64 = 3;

/// Estimated bytes one scene object takes once built, beyond what its plugin charges itself: its
/// geometry box, an optional transform wrapper, its name and its share of the scenes' hierarchies.
pub const OBJECT_BYTES: u64 = 400;

impl Default for Limits {
    fn default() -> Self {
        Limits {
            max_pixels: 1 << 26,
            max_side: 1 << 15,
            max_spp: 1 << 16,
            max_depth: 64,
            max_file_bytes: DEFAULT_MAX_FILE_BYTES,
            max_triangles: 1 << 26,
            max_image_bytes: DEFAULT_MAX_IMAGE_BYTES,
            max_rays: DEFAULT_MAX_RAYS,
            max_memory: DEFAULT_MAX_MEMORY,
        }
    }
}

impl Limits {
    /// No limits (every bound at its type's maximum).
    pub fn unlimited() -> Self {
        Limits {
            max_pixels: u64::MAX,
            max_side: u32::MAX,
            max_spp: u32::MAX,
            max_depth: u32::MAX,
            max_file_bytes: u64::MAX,
            max_triangles: u64::MAX,
            max_image_bytes: u64::MAX,
            max_rays: u64::MAX,
            max_memory: u64::MAX,
        }
    }
}
