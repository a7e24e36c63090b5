//! The orbit camera of the GPU renderer (issue 25 item 4; Skjermo2008 §4, Skjermo2008-spec §10):
//! `orbit:AZ,EL` around the model, placed and fitted exactly as the CPU preview
//! ([`sylva::preview`]) places and fits its camera, so a GPU picture and a CPU preview
//! of the same view have the same silhouette.
//!
//! - The eye looks at the centre of the framed box from azimuth AZ (about +Y; 0 looks
//!   from +Z, 90 from +X) and elevation EL, at the distance where a 30° cone sees the
//!   box's bounding sphere (× 1.05).
//! - The image plane coordinates `(x/z, y/z)` of the fitted points (every vertex of the
//!   model, or the eight corners of a given box) are centred and scaled to fill the image
//!   with a 5 % margin; the projection matrix carries that offset and scale, so it is an
//!   off-centre perspective rather than a plain field of view.

use glam::{Mat4, Vec2, Vec3, Vec4};

/// A view direction around the framed box, in degrees.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Orbit {
    /// Rotation of the camera about +Y; 0 looks from +Z towards −Z, 90 from +X.
    pub azimuth_deg: f32,
    /// Height of the camera above the horizontal, −89..=89.
    pub elevation_deg: f32,
}

impl Orbit {
    /// Parses `orbit:AZ,EL` (degrees; azimuth finite, elevation in −89..=89).
    pub fn parse(s: &str) -> Result<Orbit, String> {
        let usage = || format!("camera `{s}`: expected `orbit:AZ,EL` in degrees, e.g. `orbit:30,15`");
        let rest = s.trim().strip_prefix("orbit:").ok_or_else(usage)?;
        let (a, e) = rest.split_once(',').ok_or_else(usage)?;
        let (a, e): (f32, f32) =
            (a.trim().parse().map_err(|_| usage())?, e.trim().parse().map_err(|_| usage())?);
        if !a.is_finite() {
            return Err(format!("camera `{s}`: the azimuth must be a finite number of degrees"));
        }
        if !(-89.0..=89.0).contains(&e) {
            return Err(format!("camera `{s}`: the elevation {e}° must be in -89..=89"));
        }
        Ok(Orbit { azimuth_deg: a, elevation_deg: e })
    }

    /// The view the CPU preview chooses for a model with bounds `lo..hi` when given none:
    /// straight along an axis the model is flat in (extent ≤ 15 % of the next larger
    /// one), else three-quarter (25°, 15°).
    pub fn auto(lo: Vec3, hi: Vec3) -> Orbit {
        let e = (hi - lo).to_array();
        let mut idx = [0usize, 1, 2];
        idx.sort_by(|&a, &b| e[a].total_cmp(&e[b]));
        let (thin, mid) = (idx[0], idx[1]);
        let flat = e[mid] > 0.0 && e[thin] <= 0.15 * e[mid];
        let (azimuth_deg, elevation_deg) = match (flat, thin) {
            (true, 0) => (90.0, 0.0),
            (true, 2) => (0.0, 0.0),
            (true, _) => (20.0, 65.0),
            _ => (25.0, 15.0),
        };
        Orbit { azimuth_deg, elevation_deg }
    }

    /// The same angles as the CPU preview's [`sylva::preview::ViewAngles`].
    pub fn to_preview(self) -> sylva::preview::ViewAngles {
        sylva::preview::ViewAngles { azimuth_deg: self.azimuth_deg, elevation_deg: self.elevation_deg }
    }
}

/// A placed and fitted perspective camera.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    /// Eye position.
    pub eye: Vec3,
    /// Unit screen right.
    pub right: Vec3,
    /// Unit screen up.
    pub up: Vec3,
    /// Unit viewing direction.
    pub fwd: Vec3,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Centre of the fitted points on the image plane (`x/z`, `y/z`).
    pub mid: Vec2,
    /// Pixels per image-plane unit.
    pub scale: f32,
    /// Near plane distance along `fwd`.
    pub near: f32,
    /// Far plane distance along `fwd`.
    pub far: f32,
}

impl Camera {
    /// The camera of the CPU preview for the box `lo..hi` seen from `orbit` with a
    /// vertical field of view `fov_deg`, fitted to `fit` (the points whose projections
    /// fill a `width × height` image with a 5 % margin). `depth` is a box the near and
    /// far planes must enclose (the framed box, a forest, grown for swaying crowns).
    pub fn new(
        (lo, hi): (Vec3, Vec3),
        orbit: Orbit,
        fov_deg: f32,
        (width, height): (u32, u32),
        fit: impl IntoIterator<Item = Vec3>,
        depth: (Vec3, Vec3),
    ) -> Camera {
        let centre = (lo + hi) * 0.5;
        let mut radius = (hi - lo).length() * 0.5;
        if !(radius > 0.0 && radius.is_finite()) {
            radius = 1.0;
        }
        let (az, el) = (orbit.azimuth_deg.to_radians(), orbit.elevation_deg.to_radians());
        let to_cam = Vec3::new(az.sin() * el.cos(), el.sin(), az.cos() * el.cos());
        let dist = radius / (fov_deg.to_radians() * 0.5).sin() * 1.05;
        let fwd = -to_cam;
        let right = fwd.cross(Vec3::Y).normalize_or(Vec3::X);
        let up = right.cross(fwd);
        let eye = centre + to_cam * dist;
        let mut cam =
            Camera { eye, right, up, fwd, width, height, mid: Vec2::ZERO, scale: 1.0, near: 0.01, far: 1.0 };
        let (mut a, mut b) = (Vec2::splat(f32::INFINITY), Vec2::splat(f32::NEG_INFINITY));
        for p in fit {
            let q = cam.image_plane(p);
            a = a.min(q);
            b = b.max(q);
        }
        if a.is_finite() && b.is_finite() {
            let (wf, hf) = (width as f32, height as f32);
            let span = b - a;
            let sx = if span.x > 0.0 { wf * 0.9 / span.x } else { f32::INFINITY };
            let sy = if span.y > 0.0 { hf * 0.9 / span.y } else { f32::INFINITY };
            let s = sx.min(sy);
            cam.scale = if s.is_finite() { s } else { 1.0 };
            cam.mid = (a + b) * 0.5;
        }
        // Near and far: the depth box's corners, with room, never behind the eye.
        let (mut zmin, mut zmax) = (f32::INFINITY, f32::NEG_INFINITY);
        for k in 0..8 {
            let c = Vec3::select(glam::BVec3::new(k & 1 != 0, k & 2 != 0, k & 4 != 0), depth.1, depth.0);
            let z = (c - eye).dot(fwd);
            zmin = zmin.min(z);
            zmax = zmax.max(z);
        }
        if !(zmin.is_finite() && zmax.is_finite()) {
            (zmin, zmax) = (dist - radius, dist + radius);
        }
        let room = (zmax - zmin).max(radius) * 0.25;
        cam.far = (zmax + room).max(dist * 1e-3 + 1e-3);
        cam.near = (zmin - room).max(cam.far * 1e-5).max(1e-4);
        cam
    }

    /// Image-plane coordinates `(x/z, y/z)` of a world point.
    pub fn image_plane(&self, p: Vec3) -> Vec2 {
        let d = p - self.eye;
        let iz = 1.0 / d.dot(self.fwd).max(1e-20);
        Vec2::new(d.dot(self.right) * iz, d.dot(self.up) * iz)
    }

    /// Depth of a world point along the viewing direction.
    pub fn depth(&self, p: Vec3) -> f32 {
        (p - self.eye).dot(self.fwd)
    }

    /// Pixel position (x right, y down, pixel centres at +0.5) of a world point.
    pub fn pixel(&self, p: Vec3) -> Vec2 {
        let q = self.image_plane(p);
        Vec2::new(
            self.width as f32 * 0.5 + (q.x - self.mid.x) * self.scale,
            self.height as f32 * 0.5 - (q.y - self.mid.y) * self.scale,
        )
    }

    /// Height in pixels of a sphere of `radius` at `centre` (its projected diameter).
    pub fn projected_height(&self, centre: Vec3, radius: f32) -> f32 {
        2.0 * radius * self.scale / self.depth(centre).max(1e-6)
    }

    /// `tan` of half the effective vertical field of view (after the fit).
    pub fn tan_half_fov(&self) -> f32 {
        0.5 * self.height as f32 / self.scale
    }

    /// World → clip space (wgpu's depth range 0..1, y up).
    pub fn view_proj(&self) -> Mat4 {
        let view = Mat4::from_cols(
            Vec4::new(self.right.x, self.up.x, self.fwd.x, 0.0),
            Vec4::new(self.right.y, self.up.y, self.fwd.y, 0.0),
            Vec4::new(self.right.z, self.up.z, self.fwd.z, 0.0),
            Vec4::new(-self.right.dot(self.eye), -self.up.dot(self.eye), -self.fwd.dot(self.eye), 1.0),
        );
        let kx = 2.0 * self.scale / self.width as f32;
        let ky = 2.0 * self.scale / self.height as f32;
        let (n, f) = (self.near, self.far);
        let a = f / (f - n);
        let proj = Mat4::from_cols(
            Vec4::new(kx, 0.0, 0.0, 0.0),
            Vec4::new(0.0, ky, 0.0, 0.0),
            Vec4::new(-kx * self.mid.x, -ky * self.mid.y, a, 1.0),
            Vec4::new(0.0, 0.0, -a * n, 0.0),
        );
        proj * view
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn orbit_strings_parse_or_say_why_not() {
        assert_eq!(Orbit::parse("orbit:30,15").unwrap(), Orbit { azimuth_deg: 30.0, elevation_deg: 15.0 });
        assert_eq!(Orbit::parse(" orbit:-45, 0.5 ").unwrap().elevation_deg, 0.5);
        for bad in ["30,15", "orbit:30", "orbit:a,b", "orbit:30,95", "orbit:inf,0", "orbit:NaN,1"] {
            assert!(Orbit::parse(bad).unwrap_err().contains("camera"), "{bad}");
        }
    }

    #[test]
    fn the_projection_matrix_agrees_with_the_pixel_mapping() {
        let (lo, hi) = (Vec3::new(-1.0, 0.0, -0.5), Vec3::new(1.0, 3.0, 0.5));
        let corners: Vec<Vec3> = (0..8)
            .map(|k| Vec3::select(glam::BVec3::new(k & 1 != 0, k & 2 != 0, k & 4 != 0), hi, lo))
            .collect();
        let cam = Camera::new(
            (lo, hi),
            Orbit { azimuth_deg: 30.0, elevation_deg: 15.0 },
            30.0,
            (640, 480),
            corners.clone(),
            (lo, hi),
        );
        let vp = cam.view_proj();
        let (mut xmin, mut xmax, mut ymin, mut ymax) = (f32::MAX, f32::MIN, f32::MAX, f32::MIN);
        for c in corners {
            let clip = vp * c.extend(1.0);
            let ndc = clip.truncate() / clip.w;
            assert!((0.0..=1.0).contains(&ndc.z), "depth {} inside 0..1", ndc.z);
            let px = Vec2::new((ndc.x + 1.0) * 320.0, (1.0 - ndc.y) * 240.0);
            assert!(px.distance(cam.pixel(c)) < 1e-2, "{px} vs {}", cam.pixel(c));
            (xmin, xmax, ymin, ymax) = (xmin.min(px.x), xmax.max(px.x), ymin.min(px.y), ymax.max(px.y));
        }
        // The box fills the image with a 5 % margin along its tighter axis.
        let fill_x = (xmax - xmin) / 640.0;
        let fill_y = (ymax - ymin) / 480.0;
        assert!((fill_x.max(fill_y) - 0.9).abs() < 1e-3, "{fill_x} {fill_y}");
    }
}
