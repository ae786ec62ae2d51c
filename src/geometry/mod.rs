//! The traits every shape implements: [`Intersectable`] (a ray can hit it) and [`Geometry`]
//! (it has a surface: bounds and the direction-aware normal). Shapes are pure geometry: the
//! loader attaches materials, as it attaches transforms.

pub mod differential;
pub mod hit;
pub mod samples;
pub mod sampling;
pub mod testing;
pub mod transform;

pub use differential::{Footprint, SurfaceDerivatives};
pub use hit::Hit;
pub use sampling::{SurfacePdf, SurfaceSample};

use crate::math::bounds::Aabb;
use crate::math::ray::Ray;
use glam::{DMat2, DVec2, DVec3};
use std::sync::Arc;

/// What a shape tells about its surface at a hit, computed once per hit by
/// [`Geometry::surface`]; normals face the side the ray came from. Texture coordinates are not
/// part of it: only textured materials ask for them ([`Geometry::uv`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Surface {
    /// Unit geometric normal on the side the ray came from (`n · dir ≤ 0`): the report's
    /// direction-aware normal. Sides and ray offsets use it.
    pub n: DVec3,
    /// Unit shading normal on the same side as `n` (the interpolated vertex normal of a smooth
    /// mesh; otherwise `n`). Lighting uses it.
    pub ns: DVec3,
    /// True when the ray arrived on the outward side (outside of a closed solid).
    pub front_face: bool,
    /// The hit point in the shape's own frame (before any transform), for solid textures.
    pub local: DVec3,
    /// Which of the object's materials applies (the triangle's material in a mesh; 0 otherwise).
    pub material: u32,
}

/// Anything a ray can hit: a shape, a mesh, an acceleration structure.
pub trait Intersectable: Send + Sync {
    /// The closest hit with `t_min < t < t_max`, if any. `ray.dir` is unit length; `t_max` may be
    /// infinite. Must not panic and must not return a non-finite `t` or point for finite input.
    fn intersect(&self, ray: &Ray, t_min: f64, t_max: f64) -> Option<Hit>;

    /// Whether anything is hit with `t_min < t < t_max` (a shadow ray). May stop at the first hit
    /// found; the default calls [`Intersectable::intersect`].
    fn occludes(&self, ray: &Ray, t_min: f64, t_max: f64) -> bool {
        self.intersect(ray, t_min, t_max).is_some()
    }

    /// [`Intersectable::occludes`] for a shadow ray that leaves this shape's primitive `prim`
    /// (the [`Hit::prim`] of the hit it was spawned from, its origin moved off that primitive
    /// onto the side the ray leaves towards by
    /// [`offset_ray_origin`](crate::math::float::offset_ray_origin)). A shape whose primitive
    /// `prim` is flat may leave it out: a ray leaving a plane, on either side, never meets that
    /// plane at `t > 0` (the tests of `occludes` reject such a hit too, by their bound on `t` and
    /// their on-surface slack; skipping it saves the test). The default tests everything.
    #[inline]
    fn occludes_leaving(&self, ray: &Ray, t_min: f64, t_max: f64, prim: u32) -> bool {
        let _ = prim;
        self.occludes(ray, t_min, t_max)
    }

    /// [`Intersectable::intersect`] written into `hit`: where `intersect(ray, t_min, t_max)` finds
    /// a hit, stores exactly that hit in `hit` and returns true; otherwise leaves `hit` alone and
    /// returns false. A list of objects keeps its closest hit so far in place this way (no `Hit`
    /// copied per object); a shape overrides it to write its hit there directly. The default
    /// calls `intersect`.
    #[inline]
    fn intersect_into(&self, ray: &Ray, t_min: f64, t_max: f64, hit: &mut Hit) -> bool {
        match self.intersect(ray, t_min, t_max) {
            Some(h) => {
                *hit = h;
                true
            }
            None => false,
        }
    }

    /// True when the whole shape is one flat primitive (a plane, a polygon, a triangle): a ray
    /// leaving it meets nothing of it, so [`Intersectable::intersect_leaving`] and
    /// [`Intersectable::occludes_leaving`] answer `None` and `false` whatever `prim`, and a list
    /// of objects does not ask them. False, the default, where the shape does not say.
    #[inline]
    fn is_flat(&self) -> bool {
        false
    }

    /// [`Intersectable::intersect`] for a ray that leaves this shape's primitive `prim` (spawned
    /// off a hit of it, as for [`Intersectable::occludes_leaving`]): a path's next ray. A shape
    /// whose primitive `prim` is flat may leave it out, as `occludes_leaving` does (a ray leaving
    /// a plane never meets it again at `t > 0`: `intersect` finds no such hit either), so the
    /// answer is `intersect`'s. The default tests everything.
    #[inline]
    fn intersect_leaving(&self, ray: &Ray, t_min: f64, t_max: f64, prim: u32) -> Option<Hit> {
        let _ = prim;
        self.intersect(ray, t_min, t_max)
    }

    /// The closest hits of the rays `rays[k]` of mask `live`, ray `k` in `(t_min, t_max[k])`:
    /// where `intersect(&rays[k], t_min, t_max[k])` returns a hit, sets `out[k]` to it, exactly;
    /// leaves the other lanes alone, and returns the mask of the lanes set. A shape that walks a
    /// packet of coherent rays (camera rays of a pixel block) together overrides it, and
    /// [`Intersectable::walks_packets`]; the default asks ray by ray.
    #[inline]
    fn intersect_packet(&self, rays: &[Ray; PACKET], live: u32, t_min: f64, t_max: &[f64; PACKET], out: &mut [Hit; PACKET]) -> u32 {
        let mut hits = 0;
        for (k, ray) in rays.iter().enumerate().filter(|(k, _)| live >> k & 1 != 0) {
            if let Some(h) = self.intersect(ray, t_min, t_max[k]) {
                out[k] = h;
                hits |= 1 << k;
            }
        }
        hits
    }

    /// Whether [`Intersectable::intersect_packet`] does less work than one ray at a time (a
    /// render loop then gathers camera rays into packets).
    fn walks_packets(&self) -> bool {
        false
    }

    /// Shadow rays of a packet: the mask of the lanes `k` of `live` for which
    /// `occludes_leaving(&rays[k], t_min, t_max[k], prims[k])` holds where bit `k` of `leaving`
    /// is set (the ray leaves this shape's primitive `prims[k]`), `occludes(&rays[k], t_min,
    /// t_max[k])` where it is not: exactly those answers. A shape that walks such a packet
    /// together (shadow rays of a block of camera hits toward one light) overrides it; the
    /// default asks ray by ray.
    #[inline]
    fn occludes_packet(
        &self,
        rays: &[Ray; PACKET],
        live: u32,
        t_min: f64,
        t_max: &[f64; PACKET],
        leaving: u32,
        prims: &[u32; PACKET],
    ) -> u32 {
        let mut blocked = 0;
        for (k, ray) in rays.iter().enumerate().filter(|(k, _)| live >> k & 1 != 0) {
            let hit = if leaving >> k & 1 != 0 {
                self.occludes_leaving(ray, t_min, t_max[k], prims[k])
            } else {
                self.occludes(ray, t_min, t_max[k])
            };
            blocked |= u32::from(hit) << k;
        }
        blocked
    }
}

/// Rays of a packet ([`Intersectable::intersect_packet`]): one per lane of an 8-wide node.
pub const PACKET: usize = 8;

/// A surface: what scene objects are made of. Pure geometry; the loader attaches materials
/// (and transforms) to make a scene object.
pub trait Geometry: Intersectable {
    /// Unit normal at `at` on the surface's outside: out of the solid for closed shapes; for open
    /// shapes, the side the shape's parameters define (e.g. a triangle's winding).
    fn outward_normal(&self, at: &Hit) -> DVec3;

    /// Unit normal at `at` on the side that direction `dir` comes from (`n · dir ≤ 0`): the
    /// report's direction-aware `getNormal(point, direction)`. Shading uses only this side, so no
    /// `abs()` and no "is it flat?" checks are needed anywhere.
    fn normal(&self, at: &Hit, dir: DVec3) -> DVec3 {
        face_forward(self.outward_normal(at), dir)
    }

    /// Everything shading needs at `at`, seen along `dir`, computed once: both normals facing
    /// `dir`'s side, the side hit, the point in the shape's frame and the material slot. The
    /// default has the geometric normal as shading normal and slot 0; shapes with vertex normals
    /// or several materials override it.
    #[inline]
    fn surface(&self, at: &Hit, dir: DVec3) -> Surface {
        let outward = self.outward_normal(at);
        let front_face = outward.dot(dir) < 0.0;
        let n = if front_face { outward } else { -outward };
        Surface { n, ns: n, front_face, local: at.point, material: 0 }
    }

    /// Texture coordinates at `at` (conventionally `[0, 1]²` over the surface, `v` up: an image's
    /// bottom row at `v = 0`). Asked for only where a textured material is hit, so a shape may
    /// compute them here rather than in `intersect`. The default is `Hit::uv`.
    #[inline]
    fn uv(&self, at: &Hit) -> DVec2 {
        at.uv
    }

    /// A second set of texture coordinates at `at` (a glTF mesh's `TEXCOORD_1`) and its
    /// derivatives along the first set ([`Geometry::uv`]): `∂uv₁/∂uv`, columns `∂uv₁/∂u`,
    /// `∂uv₁/∂v` (what carries a footprint over to it). `None`, the default, for shapes with one
    /// set: textures laid over the second set read the first ([`crate::scene::texture::Coords::Uv1`]).
    /// Asked for only where a textured material is hit.
    fn uv1(&self, at: &Hit) -> Option<(DVec2, DMat2)> {
        let _ = at;
        None
    }

    /// How the point and the outward normal move with the texture coordinates at `at`
    /// ([`SurfaceDerivatives`]), in the frame `at` is in. Asked for only where a texture is
    /// filtered over a pixel's footprint or a ray differential is carried through a mirror; `None`
    /// (the default): unknown, and textures over uv are then looked up at a point.
    fn derivatives(&self, at: &Hit) -> Option<SurfaceDerivatives> {
        let _ = at;
        None
    }
    /// The texture [`Footprint`] at `at` of a pixel whose hit moves by `dpdx`, `dpdy` on the
    /// tangent plane from one pixel to the next. The default solves [`Geometry::derivatives`]
    /// for the uv change (zero without them) and takes the shape's frame as the world's; a
    /// wrapper that moves the shape carries the moves into its frame first.
    fn footprint(&self, at: &Hit, dpdx: DVec3, dpdy: DVec3) -> Footprint {
        match self.derivatives(at) {
            Some(d) => d.footprint(dpdx, dpdy),
            None => Footprint { dlocal_dx: dpdx, dlocal_dy: dpdy, ..Footprint::POINT },
        }
        .finite()
    }
    /// The derivatives `[∂p/∂u, ∂p/∂v]` of the surface point along the texture coordinates at
    /// `at` ([`Geometry::uv`]), in the hit's frame: the tangent frame of normal and bump maps
    /// ([`crate::scene::normal_map`]). Asked for only where a normal-mapped material is hit.
    /// `None`, the default, for shapes without them (their normal is not tilted).
    fn tangents(&self, at: &Hit) -> Option<[DVec3; 2]> {
        let _ = at;
        None
    }

    /// A box containing the whole shape, or `None` for unbounded shapes (planes, infinite tubes).
    fn bounds(&self) -> Option<Aabb>;

    /// True when the surface encloses a volume (sphere, capped cylinder, closed mesh). Refraction
    /// bends rays only at such surfaces; open surfaces transmit as thin sheets.
    fn is_closed(&self) -> bool {
        false
    }

    /// The surface's area, scene units², for shapes that offer [`Geometry::sample_surface`]
    /// (`None`, the default, for those that do not). Integrators weigh emitters by it (power).
    fn area(&self) -> Option<f64> {
        None
    }

    /// A point on the surface for `u` uniform in `[0, 1)²`, chosen to light `reference` (an
    /// emitting surface sampled as a light): uniform by area, or better by the solid angle the
    /// surface covers as seen from `reference` (a sphere's cone). `None`, the default, for shapes
    /// that offer no sampling (rays still find them) and where no point can be chosen. Shapes
    /// that sample must answer [`Geometry::area`] and [`Geometry::surface_pdf`] consistently.
    fn sample_surface(&self, reference: DVec3, u: DVec2) -> Option<SurfaceSample> {
        let _ = (reference, u);
        None
    }

    /// The density with which [`Geometry::sample_surface`]`(reference, u)` chooses the point of
    /// `at`, a hit of a ray from `reference` (the first along it), in the measure the samples
    /// come in. `Area(0)`, the default, for shapes that offer no sampling.
    fn surface_pdf(&self, reference: DVec3, at: &Hit) -> SurfacePdf {
        let _ = (reference, at);
        SurfacePdf::Area(0.0)
    }

    /// True when the surface lies on the boundary of one convex body, with that body's outward
    /// normals (a convex solid, a flat shape, a patch of either such as a bowl): a segment to one
    /// of its points from a point that point's outward side faces stays on that side of the
    /// point's tangent plane, so it meets the surface nowhere else, and a shadow ray toward a
    /// sampled point of an emitter need not test the emitter itself. False, the default, where
    /// the shape does not know (its shadow rays test it, as every other shape).
    fn is_convex(&self) -> bool {
        false
    }

    /// The plane the whole surface lies in, where it is flat: a point of it and the unit outward
    /// normal every point of the surface has ([`Geometry::outward_normal`], bit for bit). Every
    /// point of the surface lies within [`PLANE_TOLERANCE`] of its magnitude (largest coordinate
    /// of its bounds) from that plane. `None`, the default: curved, or not known. Emitters
    /// read it to know, before a point is drawn, that every point of a one-sided emitter faces
    /// away from a shaded point ([`crate::scene::emitters::Emitters::dark_from`]).
    fn plane(&self) -> Option<(DVec3, DVec3)> {
        None
    }
}

/// How far, relative to a flat surface's magnitude, its points may lie from the plane it reports
/// ([`Geometry::plane`]): a polygon's vertices are coplanar within 10⁻⁹ of its size, rounding is
/// near 10⁻¹⁶; readers allow 10⁻⁶.
pub const PLANE_TOLERANCE: f64 = 1e-6;

/// `n` flipped, if needed, to face against `dir` (`result · dir ≤ 0`).
#[inline]
pub fn face_forward(n: DVec3, dir: DVec3) -> DVec3 {
    if n.dot(dir) > 0.0 { -n } else { n }
}

macro_rules! forward_impls {
    ($($ptr:ident),*) => {$(
        impl<T: Intersectable + ?Sized> Intersectable for $ptr<T> {
            #[inline]
            fn intersect(&self, ray: &Ray, t_min: f64, t_max: f64) -> Option<Hit> {
                (**self).intersect(ray, t_min, t_max)
            }
            #[inline]
            fn occludes(&self, ray: &Ray, t_min: f64, t_max: f64) -> bool {
                (**self).occludes(ray, t_min, t_max)
            }
            #[inline]
            fn occludes_leaving(&self, ray: &Ray, t_min: f64, t_max: f64, prim: u32) -> bool {
                (**self).occludes_leaving(ray, t_min, t_max, prim)
            }
            #[inline]
            fn intersect_leaving(&self, ray: &Ray, t_min: f64, t_max: f64, prim: u32) -> Option<Hit> {
                (**self).intersect_leaving(ray, t_min, t_max, prim)
            }
            #[inline]
            fn intersect_into(&self, ray: &Ray, t_min: f64, t_max: f64, hit: &mut Hit) -> bool {
                (**self).intersect_into(ray, t_min, t_max, hit)
            }
            #[inline]
            fn is_flat(&self) -> bool {
                (**self).is_flat()
            }
            #[inline]
            fn intersect_packet(
                &self,
                rays: &[Ray; PACKET],
                live: u32,
                t_min: f64,
                t_max: &[f64; PACKET],
                out: &mut [Hit; PACKET],
            ) -> u32 {
                (**self).intersect_packet(rays, live, t_min, t_max, out)
            }
            fn walks_packets(&self) -> bool {
                (**self).walks_packets()
            }
            #[inline]
            fn occludes_packet(
                &self,
                rays: &[Ray; PACKET],
                live: u32,
                t_min: f64,
                t_max: &[f64; PACKET],
                leaving: u32,
                prims: &[u32; PACKET],
            ) -> u32 {
                (**self).occludes_packet(rays, live, t_min, t_max, leaving, prims)
            }
        }
        impl<T: Geometry + ?Sized> Geometry for $ptr<T> {
            fn outward_normal(&self, at: &Hit) -> DVec3 {
                (**self).outward_normal(at)
            }
            fn normal(&self, at: &Hit, dir: DVec3) -> DVec3 {
                (**self).normal(at, dir)
            }
            #[inline]
            fn surface(&self, at: &Hit, dir: DVec3) -> Surface {
                (**self).surface(at, dir)
            }
            #[inline]
            fn uv(&self, at: &Hit) -> DVec2 {
                (**self).uv(at)
            }
            fn uv1(&self, at: &Hit) -> Option<(DVec2, DMat2)> {
                (**self).uv1(at)
            }
            fn derivatives(&self, at: &Hit) -> Option<SurfaceDerivatives> {
                (**self).derivatives(at)
            }
            fn footprint(&self, at: &Hit, dpdx: DVec3, dpdy: DVec3) -> Footprint {
                (**self).footprint(at, dpdx, dpdy)
            }
            fn tangents(&self, at: &Hit) -> Option<[DVec3; 2]> {
                (**self).tangents(at)
            }
            fn bounds(&self) -> Option<Aabb> {
                (**self).bounds()
            }
            fn is_closed(&self) -> bool {
                (**self).is_closed()
            }
            fn area(&self) -> Option<f64> {
                (**self).area()
            }
            fn sample_surface(&self, reference: DVec3, u: DVec2) -> Option<SurfaceSample> {
                (**self).sample_surface(reference, u)
            }
            fn surface_pdf(&self, reference: DVec3, at: &Hit) -> SurfacePdf {
                (**self).surface_pdf(reference, at)
            }
            fn is_convex(&self) -> bool {
                (**self).is_convex()
            }
            fn plane(&self) -> Option<(DVec3, DVec3)> {
                (**self).plane()
            }
        }
    )*};
}
forward_impls!(Box, Arc);
