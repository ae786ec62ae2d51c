//! The pinhole (or thin-lens) camera of the report: eye point, `to` and `up` directions, and a
//! screen at a distance in front of the eye.

use crate::math::float::PARALLEL_TOLERANCE;
use crate::math::ray::Ray;
use crate::param::error::Result;
use crate::param::params::Params;
use crate::param::spec::{ParamDefault, ParamKind, ParamSpec};
use crate::param::value::{Node, Table};
use glam::{DVec2, DVec3};

/// A camera. `right = to × up`; `to`, `up` and `right` are unit and mutually orthogonal. Rays
/// leave the eye through points of a `screen_width × screen_height` rectangle centred at
/// `position + screen_distance · to` (scene units).
#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    /// The eye point (the report's P0).
    pub position: DVec3,
    /// Viewing direction (vTo), unit.
    pub to: DVec3,
    /// Up direction (vUp), unit, orthogonal to `to`.
    pub up: DVec3,
    /// `to × up` (vRight), unit.
    pub right: DVec3,
    /// Distance from the eye to the screen, scene units (> 0).
    pub screen_distance: f64,
    /// Screen width, scene units (> 0).
    pub screen_width: f64,
    /// Screen height, scene units (> 0).
    pub screen_height: f64,
    /// Lens radius for depth of field, scene units; 0 is a pinhole.
    pub aperture: f64,
    /// Distance along `to` of the plane in perfect focus, scene units (> 0).
    pub focus_distance: f64,
}

/// The camera's parameter table (`[camera]`). Two forms: the report's (`to`, `screen_*`) and
/// look-at (`look_at`, `fov`).
pub const CAMERA_PARAMS: &[ParamSpec] = &[
    ParamSpec::new("position", ParamKind::Vec3, ParamDefault::Vec3([0.0, 0.0, 0.0]), "eye point (P0)"),
    ParamSpec::new("up", ParamKind::Vec3, ParamDefault::Vec3([0.0, 1.0, 0.0]), "up direction (vUp); made orthogonal to the view direction"),
    ParamSpec::new("to", ParamKind::Vec3, ParamDefault::Optional, "report form: viewing direction (vTo)"),
    ParamSpec::new("screen_distance", ParamKind::Float, ParamDefault::Float(100.0), "report form: eye-to-screen distance, scene units"),
    ParamSpec::new("screen_width", ParamKind::Float, ParamDefault::Optional, "report form: screen width, scene units (required)"),
    ParamSpec::new("screen_height", ParamKind::Float, ParamDefault::Optional, "report form: screen height, scene units (required)"),
    ParamSpec::new("look_at", ParamKind::Vec3, ParamDefault::Optional, "look-at form: the point the camera looks at"),
    ParamSpec::new("fov", ParamKind::Float, ParamDefault::Float(45.0), "look-at form: vertical field of view, degrees, in (0, 180)"),
    ParamSpec::new("aperture", ParamKind::Float, ParamDefault::Float(0.0), "lens radius for depth of field, scene units (0 = pinhole)"),
    ParamSpec::new(
        "focus_distance",
        ParamKind::Float,
        ParamDefault::Optional,
        "distance of the plane in focus; default: the look_at point or the screen",
    ),
    ParamSpec::new(
        "fit",
        ParamKind::Bool,
        ParamDefault::Bool(false),
        "frame the scene: look at the centre of its bounded objects from just far enough to see them all, along look_at → position when both are given (else from the front, right and above); fov and up are kept (`--camera fit` on the command line)",
    ),
];

/// Default direction from a fitted camera's target toward its eye: in front (+z), a little to the
/// right and above, so a model's three sides show.
pub const FIT_DIRECTION: DVec3 = DVec3::new(0.35, 0.3, 1.0);
/// A fitted camera's distance beyond the one at which the bounding sphere touches the frame: a
/// margin around the model.
pub const FIT_MARGIN: f64 = 1.1;

/// The eye and target of a camera with vertical field of view `fov_deg`, for a `width × height`
/// image, that sees all of `bounds` along `direction` (from the target toward the eye; zero or
/// non-finite: [`FIT_DIRECTION`]): the bounding sphere fits the narrower of the two fields of view.
pub fn fit(bounds: &crate::math::bounds::Aabb, direction: DVec3, fov_deg: f64, width: u32, height: u32) -> (DVec3, DVec3) {
    let center = bounds.center();
    let radius = (bounds.extent().length() * 0.5).max(1e-6 * center.abs().max_element().max(1.0));
    let dir = direction.try_normalize().filter(|d| d.is_finite()).unwrap_or_else(|| FIT_DIRECTION.normalize());
    let half_v = (fov_deg.to_radians() * 0.5).clamp(1e-6, std::f64::consts::FRAC_PI_2 - 1e-6);
    let half_h = (half_v.tan() * f64::from(width.max(1)) / f64::from(height.max(1))).atan();
    let dist = radius / half_v.min(half_h).sin() * FIT_MARGIN;
    (center + dir * dist, center)
}

/// Keys of the look-at form; giving one of them replaces the report form, and vice versa.
const LOOK_AT_KEYS: &[&str] = &["look_at", "fov", "fit"];
/// Keys of the report form.
const REPORT_KEYS: &[&str] = &["to", "screen_distance", "screen_width", "screen_height"];

/// The `[camera]` table with command-line `overrides` applied over it. An override of one form's
/// key (look-at: `look_at`, `fov`; report: `to`, `screen_*`) drops the other form's keys from the
/// file, so `--camera look_at=[0,0,0]` works on a report-form camera.
pub fn apply_overrides(file: &Table, overrides: &[(String, Node)]) -> Table {
    let mut t = file.clone();
    let given = |keys: &[&str]| overrides.iter().any(|(k, _)| keys.contains(&k.as_str()));
    for (keys, other) in [(LOOK_AT_KEYS, REPORT_KEYS), (REPORT_KEYS, LOOK_AT_KEYS)] {
        if given(keys) && !given(other) {
            t.entries.retain(|e| !other.contains(&e.key.as_str()));
        }
    }
    for (k, v) in overrides {
        t.set(k, v.loc.clone(), v.clone());
    }
    t
}

/// How pixel coordinates map onto the camera's screen for one image size: the per-image
/// constants of [`Camera::ray_through`] ([`Camera::screen_map`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScreenMap {
    /// Pixel width and height on the screen, scene units.
    rx: f64,
    ry: f64,
    /// Half the image size, pixels.
    half_x: f64,
    half_y: f64,
    /// The screen's centre.
    pc: DVec3,
}

/// Why a camera could not be built.
#[derive(Clone, Debug, PartialEq)]
pub enum CameraError {
    /// `up` is zero or parallel to the viewing direction.
    UpParallelToView,
    /// The viewing direction is zero.
    NoViewDirection,
    /// A size or distance is not finite and positive.
    BadSize(&'static str),
}

impl std::fmt::Display for CameraError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            CameraError::UpParallelToView => write!(f, "`up` must not be zero or parallel to the viewing direction"),
            CameraError::NoViewDirection => write!(f, "the viewing direction is zero (to, or look_at − position)"),
            CameraError::BadSize(what) => write!(f, "`{what}` must be a finite number > 0"),
        }
    }
}

impl Camera {
    /// The report's camera: eye `position`, view direction `to`, `up` (made orthogonal to `to`),
    /// and the screen.
    pub fn report(
        position: DVec3,
        to: DVec3,
        up: DVec3,
        screen_distance: f64,
        screen_width: f64,
        screen_height: f64,
    ) -> Result<Camera, CameraError> {
        let to = to.try_normalize().filter(|t| t.is_finite()).ok_or(CameraError::NoViewDirection)?;
        // Gram–Schmidt; an `up` within ~1e-6 rad of `to` would orthogonalise to rounding noise.
        let perp = up - up.dot(to) * to;
        if !(perp.length() > PARALLEL_TOLERANCE * up.length()) {
            return Err(CameraError::UpParallelToView);
        }
        let up = perp.normalize();
        for (v, name) in [(screen_distance, "screen_distance"), (screen_width, "screen_width"), (screen_height, "screen_height")] {
            if !(v.is_finite() && v > 0.0) {
                return Err(CameraError::BadSize(name));
            }
        }
        let right = to.cross(up);
        Ok(Camera { position, to, up, right, screen_distance, screen_width, screen_height, aperture: 0.0, focus_distance: screen_distance })
    }

    /// A look-at camera with vertical field of view `fov_deg` for an image of `width × height`
    /// pixels (square pixels). The screen is placed at the focus distance (the look-at point).
    pub fn look_at(position: DVec3, target: DVec3, up: DVec3, fov_deg: f64, width: u32, height: u32) -> Result<Camera, CameraError> {
        if !(fov_deg > 0.0 && fov_deg < 180.0) {
            return Err(CameraError::BadSize("fov"));
        }
        let dist = (target - position).length();
        if !(dist > 0.0 && dist.is_finite()) {
            return Err(CameraError::NoViewDirection);
        }
        let h = 2.0 * dist * (fov_deg.to_radians() * 0.5).tan();
        let w = h * width.max(1) as f64 / height.max(1) as f64;
        Camera::report(position, target - position, up, dist, w, h)
    }

    /// Reads `[camera]` for an image of `width × height` pixels.
    pub fn from_params(p: &mut Params, width: u32, height: u32) -> Result<Camera> {
        // `fit` is applied by the loader (it needs the scene's objects) before this is called.
        p.bool("fit")?;
        let position = p.vec3("position")?;
        let up = p.vec3("up")?;
        let cam = if let Some(target) = p.vec3_opt("look_at")? {
            let fov = p.float("fov")?;
            Camera::look_at(position, target, up, fov, width, height)
        } else if let Some(to) = p.vec3_opt("to")? {
            let dist = p.float("screen_distance")?;
            let (Some(w), Some(h)) = (p.float_opt("screen_width")?, p.float_opt("screen_height")?) else {
                return Err(p.error("the report-form camera needs `screen_width` and `screen_height`"));
            };
            Camera::report(position, to, up, dist, w, h)
        } else {
            p.check_unknown()?;
            return Err(p.error("the camera needs `to` (report form) or `look_at` (look-at form)"));
        };
        // Each error at the parameter that causes it.
        let view = if p.has("look_at") { "look_at" } else { "to" };
        let mut cam = cam.map_err(|e| match e {
            CameraError::BadSize("fov") => p.error_at("fov", "expected a field of view in (0, 180) degrees"),
            CameraError::BadSize(name) => p.error_at(name, "expected a finite number > 0"),
            CameraError::UpParallelToView if p.has("up") => p.error_at("up", e),
            CameraError::NoViewDirection => p.error_at(view, e),
            e => p.error(e.to_string()),
        })?;
        cam.aperture = p.non_negative("aperture")?;
        if let Some(f) = p.float_opt("focus_distance")? {
            if !(f > 0.0) {
                return Err(p.error_at("focus_distance", "expected a number > 0"));
            }
            cam.focus_distance = f;
        }
        Ok(cam)
    }

    /// The report's `constructRayThroughPixel`: the ray from the eye through the centre of pixel
    /// (`x`, `y`) of an `nx × ny` image (x right, y down, from 0):
    /// `P = Pc + [((x − Nx/2)·Rx + Rx/2)·vRight − ((y − Ny/2)·Ry + Ry/2)·vUp]`.
    pub fn construct_ray_through_pixel(&self, nx: u32, ny: u32, x: f64, y: f64) -> Ray {
        self.ray_through(nx, ny, DVec2::new(x + 0.5, y + 0.5), DVec2::splat(0.5))
    }

    /// The ray through continuous image position `film` (pixel (x, y) covers [x, x+1) × [y, y+1))
    /// of an `nx × ny` image. `lens` ∈ [0, 1)² picks the point on the lens (ignored for a pinhole).
    #[inline]
    pub fn ray_through(&self, nx: u32, ny: u32, film: DVec2, lens: DVec2) -> Ray {
        self.ray_in(&self.screen_map(nx, ny), film, lens)
    }

    /// What [`Camera::ray_through`] needs of an `nx × ny` image that is the same for every pixel:
    /// computed once per image (or tile) for [`Camera::ray_in`].
    #[inline]
    pub fn screen_map(&self, nx: u32, ny: u32) -> ScreenMap {
        ScreenMap {
            rx: self.screen_width / nx as f64,
            ry: self.screen_height / ny as f64,
            half_x: nx as f64 / 2.0,
            half_y: ny as f64 / 2.0,
            pc: self.position + self.screen_distance * self.to,
        }
    }

    /// [`Camera::ray_through`] with the image's [`ScreenMap`] (from this camera) given: the same
    /// ray, bit for bit.
    /// Always inlined (a pinhole's ray is a few products); the lens is out of line.
    #[inline(always)]
    pub fn ray_in(&self, screen: &ScreenMap, film: DVec2, lens: DVec2) -> Ray {
        let ScreenMap { rx, ry, half_x, half_y, pc } = *screen;
        let p = pc + ((film.x - half_x) * rx) * self.right - ((film.y - half_y) * ry) * self.up;
        let dir = p - self.position;
        if self.aperture <= 0.0 {
            return Ray::new(self.position, dir);
        }
        self.lens_ray(dir, lens)
    }

    /// The ray from lens point `lens` (unit square) through the point in focus along `dir`.
    #[inline(never)]
    fn lens_ray(&self, dir: DVec3, lens: DVec2) -> Ray {
        let dir = dir.normalize();
        let focus = self.position + dir * (self.focus_distance / dir.dot(self.to));
        let d = crate::math::sampler::concentric_disc(lens) * self.aperture;
        let origin = self.position + d.x * self.right + d.y * self.up;
        Ray::new(origin, focus - origin)
    }

    /// The inverse of [`Camera::ray_through`] through the lens centre: the continuous image
    /// position of an `nx × ny` image where `point` appears, or `None` when it is not in front of
    /// the eye (on or behind the plane through the eye facing `to`). For a thin lens this is where
    /// the point appears in focus.
    pub fn project(&self, nx: u32, ny: u32, point: DVec3) -> Option<DVec2> {
        let d = point - self.position;
        let depth = d.dot(self.to);
        if !(depth > 0.0) {
            return None;
        }
        // Onto the screen plane, then into pixels (y down).
        let s = self.screen_distance / depth;
        let (u, v) = (d.dot(self.right) * s, d.dot(self.up) * s);
        let (rx, ry) = (self.screen_width / nx as f64, self.screen_height / ny as f64);
        let film = DVec2::new(u / rx + nx as f64 / 2.0, ny as f64 / 2.0 - v / ry);
        film.is_finite().then_some(film)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The report's formula, written out independently.
    fn report_formula(c: &Camera, nx: u32, ny: u32, x: f64, y: f64) -> DVec3 {
        let pc = c.position + c.screen_distance * c.to;
        let rx = c.screen_width / nx as f64;
        let ry = c.screen_height / ny as f64;
        let p = pc + (((x - nx as f64 / 2.0) * rx + rx / 2.0) * c.right - ((y - ny as f64 / 2.0) * ry + ry / 2.0) * c.up);
        (p - c.position).normalize()
    }

    #[test]
    fn rays_match_the_report_at_corners_and_centre_for_odd_and_even_sizes() {
        let cam = Camera::report(DVec3::new(1.0, 2.0, 3.0), DVec3::new(0.0, 0.0, -1.0), DVec3::Y, 100.0, 300.0, 200.0).unwrap();
        for (nx, ny) in [(3, 3), (4, 4), (800, 600), (801, 599), (1, 1)] {
            for (x, y) in [(0, 0), (nx - 1, 0), (0, ny - 1), (nx - 1, ny - 1), (nx / 2, ny / 2)] {
                let r = cam.construct_ray_through_pixel(nx, ny, x as f64, y as f64);
                let e = report_formula(&cam, nx, ny, x as f64, y as f64);
                assert!((r.dir - e).length() < 1e-12, "{nx}x{ny} ({x},{y}): {} vs {}", r.dir, e);
                assert_eq!(r.origin, cam.position);
            }
        }
    }

    #[test]
    fn odd_resolution_centre_pixel_looks_straight_ahead() {
        let cam = Camera::report(DVec3::ZERO, DVec3::new(0.0, 0.0, -1.0), DVec3::Y, 100.0, 150.0, 150.0).unwrap();
        let r = cam.construct_ray_through_pixel(3, 3, 1.0, 1.0);
        assert!((r.dir - DVec3::new(0.0, 0.0, -1.0)).length() < 1e-15);
        // Top-left pixel of 3×3: x toward −right, y toward +up.
        let tl = cam.construct_ray_through_pixel(3, 3, 0.0, 0.0);
        assert!(tl.dir.x < 0.0 && tl.dir.y > 0.0);
        assert_eq!(cam.right, DVec3::X);
    }

    #[test]
    fn bad_cameras_are_rejected() {
        assert_eq!(Camera::report(DVec3::ZERO, DVec3::Y, DVec3::Y, 1.0, 1.0, 1.0), Err(CameraError::UpParallelToView));
        assert_eq!(Camera::report(DVec3::ZERO, DVec3::ZERO, DVec3::Y, 1.0, 1.0, 1.0), Err(CameraError::NoViewDirection));
        assert!(Camera::report(DVec3::ZERO, DVec3::Z, DVec3::Y, 0.0, 1.0, 1.0).is_err());
        assert!(Camera::look_at(DVec3::ZERO, DVec3::ZERO, DVec3::Y, 45.0, 4, 3).is_err());
        assert!(Camera::look_at(DVec3::ZERO, DVec3::Z, DVec3::Y, 180.0, 4, 3).is_err());
    }

    #[test]
    fn overrides_replace_keys_and_switch_forms() {
        let src = crate::param::error::Source::new("t", "x");
        let loc = crate::param::error::Loc::new(&src, 0..1);
        let node = |v: f64| Node { value: crate::param::value::Value::Float(v), loc: loc.clone() };
        let mut file = Table::default();
        for (k, v) in [("to", 1.0), ("screen_width", 2.0), ("fov", 3.0), ("position", 4.0)] {
            file.set(k, loc.clone(), node(v));
        }
        let keys = |t: &Table| t.entries.iter().map(|e| e.key.as_str()).collect::<Vec<_>>().join(" ");
        let t = apply_overrides(&file, &[("look_at".into(), node(9.0))]);
        assert_eq!(keys(&t), "fov position look_at", "report-form keys dropped");
        let t = apply_overrides(&file, &[("screen_width".into(), node(9.0))]);
        assert_eq!(keys(&t), "to screen_width position", "look-at keys dropped");
        assert!(matches!(t.get("screen_width").unwrap().value, crate::param::value::Value::Float(9.0)));
        let t = apply_overrides(&file, &[("position".into(), node(9.0))]);
        assert_eq!(keys(&t), "to screen_width fov position", "a shared key changes nothing else");
    }

    #[test]
    fn look_at_covers_the_field_of_view() {
        let cam = Camera::look_at(DVec3::ZERO, DVec3::new(0.0, 0.0, -10.0), DVec3::Y, 90.0, 200, 100).unwrap();
        let top = cam.ray_through(200, 100, DVec2::new(100.0, 0.0), DVec2::ZERO);
        assert!((top.dir.y / -top.dir.z - 1.0).abs() < 1e-12, "top edge at 45°");
        let right = cam.ray_through(200, 100, DVec2::new(200.0, 50.0), DVec2::ZERO);
        assert!((right.dir.x / -right.dir.z - 2.0).abs() < 1e-12, "aspect 2:1");
    }

    #[test]
    fn project_inverts_ray_through() {
        let mut cam = Camera::look_at(DVec3::new(1.0, 2.0, 3.0), DVec3::new(-2.0, 0.5, -7.0), DVec3::Y, 50.0, 320, 200).unwrap();
        for film in [DVec2::new(0.0, 0.0), DVec2::new(160.0, 100.0), DVec2::new(319.25, 7.5), DVec2::new(12.5, 199.0)] {
            let r = cam.ray_through(320, 200, film, DVec2::ZERO);
            for t in [0.5, 3.0, 1e3] {
                let back = cam.project(320, 200, r.at(t)).unwrap();
                assert!((back - film).length() < 1e-9, "{film} at t {t}: {back}");
            }
        }
        assert_eq!(cam.project(320, 200, cam.position - cam.to), None, "behind the eye");
        assert_eq!(cam.project(320, 200, cam.position), None, "at the eye");
        // A thin lens: points on the focus plane project where every lens ray through them starts.
        cam.aperture = 0.3;
        let film = DVec2::new(40.5, 60.5);
        let r = cam.ray_through(320, 200, film, DVec2::new(0.8, 0.1));
        let on_focus = r.at((cam.focus_distance - (r.origin - cam.position).dot(cam.to)) / r.dir.dot(cam.to));
        assert!((cam.project(320, 200, on_focus).unwrap() - film).length() < 1e-9);
    }

    #[test]
    fn thin_lens_rays_converge_on_the_focus_plane() {
        let mut cam = Camera::look_at(DVec3::ZERO, DVec3::new(0.0, 0.0, -10.0), DVec3::Y, 40.0, 64, 64).unwrap();
        cam.aperture = 0.5;
        let film = DVec2::new(10.5, 20.5);
        let a = cam.ray_through(64, 64, film, DVec2::new(0.1, 0.2));
        let b = cam.ray_through(64, 64, film, DVec2::new(0.9, 0.7));
        let pa = a.at((10.0 - 0.0) / -a.dir.z * 1.0 + 0.0);
        let hit_a = a.origin + a.dir * ((-10.0 - a.origin.z) / a.dir.z);
        let hit_b = b.origin + b.dir * ((-10.0 - b.origin.z) / b.dir.z);
        assert!((hit_a - hit_b).length() < 1e-9, "{pa}");
        assert_ne!(a.origin, b.origin);
    }

    /// Lens sampling: the rays start uniformly over the lens disc (density `1 / π aperture²`),
    /// whatever the pixel; a test of the right density on the wrong disc fails.
    #[test]
    fn lens_points_pass_the_chi2_test() {
        use crate::testing::chi2::{Chi2Test, Rect};
        let mut cam = Camera::look_at(DVec3::new(1.0, 2.0, 3.0), DVec3::new(0.0, 0.5, -10.0), DVec3::Y, 40.0, 64, 48).unwrap();
        cam.aperture = 0.25;
        let test = Chi2Test::new(Rect { min: DVec2::splat(-1.0), max: DVec2::ONE }).res(40, 40).tests(3);
        let disc = |p: DVec2| if p.length_squared() <= 1.0 { 1.0 / std::f64::consts::PI } else { 0.0 };
        for film in [DVec2::new(32.0, 24.0), DVec2::new(0.5, 47.5)] {
            test.run(
                |u| {
                    let o = cam.ray_through(64, 48, film, u.next_2d()).origin - cam.position;
                    Some(DVec2::new(o.dot(cam.right), o.dot(cam.up)) / cam.aperture)
                },
                disc,
            )
            .assert_passes(&format!("lens, pixel {film}"));
        }
        test.run(|u| Some(2.0 * u.next_2d() - DVec2::ONE), disc).assert_fails("the square for the disc");
    }
}
