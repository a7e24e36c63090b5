//! The preview camera: auto-framed from the model bounds, viewed along the thin axis
//! of a planar model, else a three-quarter view, with a 30° perspective.
//!
//! - **Camera**: auto-framed from the model bounds. A model much thinner along one axis
//!   than the others (an L-system tree drawn in the y–z plane, a 2D curve in the x–y
//!   plane) is viewed straight along that axis; anything else gets a three-quarter
//!   view (25° azimuth, 15° elevation). A 30° perspective is placed to see the bounding
//!   sphere, then the projected extent of every vertex is fitted to the image with a
//!   5 % margin.

use super::ViewAngles;
use glam::Vec3;

/// The view for a model with bounds `lo..hi`: straight along an axis the model is flat
/// in (extent ≤ 15 % of the next larger one), else three-quarter.
pub(super) fn auto_view(lo: Vec3, hi: Vec3) -> ViewAngles {
    let e = (hi - lo).to_array();
    let mut idx = [0usize, 1, 2];
    idx.sort_by(|&a, &b| e[a].total_cmp(&e[b])); // stable: X before Y before Z on ties
    let (thin, mid) = (idx[0], idx[1]);
    let flat = e[mid] > 0.0 && e[thin] <= 0.15 * e[mid];
    let (azimuth_deg, elevation_deg) = match (flat, thin) {
        (true, 0) => (90.0, 0.0),  // y–z planar: look along −X
        (true, 2) => (0.0, 0.0),   // x–y planar: look along −Z
        (true, _) => (20.0, 65.0), // flat on the ground: look down
        _ => (25.0, 15.0),
    };
    ViewAngles { azimuth_deg, elevation_deg }
}

/// A perspective camera with an image-plane fit.
pub(super) struct Camera {
    pub(super) eye: Vec3,
    pub(super) right: Vec3,
    pub(super) up: Vec3,
    pub(super) fwd: Vec3,
}

impl Camera {
    pub(super) fn new(lo: Vec3, hi: Vec3, a: ViewAngles, fov_deg: f32) -> Camera {
        let centre = (lo + hi) * 0.5;
        let mut radius = (hi - lo).length() * 0.5;
        if !(radius > 0.0 && radius.is_finite()) {
            radius = 1.0;
        }
        let (az, el) = (a.azimuth_deg.to_radians(), a.elevation_deg.to_radians());
        let to_cam = Vec3::new(az.sin() * el.cos(), el.sin(), az.cos() * el.cos());
        let dist = radius / (fov_deg.to_radians() * 0.5).sin() * 1.05;
        let fwd = -to_cam;
        let right = fwd.cross(Vec3::Y).normalize_or(Vec3::X);
        let up = right.cross(fwd);
        Camera { eye: centre + to_cam * dist, right, up, fwd }
    }

    /// Image-plane coordinates (x/z, y/z) and 1/z of a world point.
    #[inline]
    pub(super) fn project(&self, p: Vec3) -> Vec3 {
        let d = p - self.eye;
        let iz = 1.0 / d.dot(self.fwd).max(1e-20);
        Vec3::new(d.dot(self.right) * iz, d.dot(self.up) * iz, iz)
    }
}
