//! Cameras, with Raytracer.jl's conventions (see SCENELANG.md).

use glam::DVec3;

use super::Transform;

/// How a camera's rays leave its screen: from one eye point, or all parallel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Projection {
    /// Eye at (−d, 0, 0) in camera space, screen at x = 0.
    Perspective {
        /// d, the eye's distance behind the screen in camera-space units: the larger, the
        /// narrower the field of view (see [`Camera::aperture_deg`]). Positive.
        screen_distance: f64,
    },
    /// Parallel rays along +x from the plane x = −1.
    Orthogonal,
}

/// A camera. In camera space it looks along +x with z up; `transform` places it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    /// Perspective or orthogonal, with the perspective's screen distance.
    pub projection: Projection,
    /// Screen width over height: the screen spans y ∈ [−a, a] and z ∈ [−1, 1] in camera
    /// space. Positive; it should match the image's, or pixels come out stretched.
    pub aspect_ratio: f64,
    /// Camera space to world.
    pub transform: Transform,
}

impl Default for Camera {
    fn default() -> Self {
        Self {
            projection: Projection::Perspective { screen_distance: 1.0 },
            aspect_ratio: 1.0,
            transform: Transform::IDENTITY,
        }
    }
}

/// A camera ray in world space: points `origin + t·dir` for `t ≥ 1` are seen (the segment
/// before the screen is not, as in Raytracer.jl). `dir` is not normalised.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraRay {
    /// Where the ray starts (t = 0): the eye for a perspective camera, a point on the
    /// plane x = −1 of camera space for an orthogonal one.
    pub origin: DVec3,
    /// The step from `origin` to the screen point (t = 1).
    pub dir: DVec3,
}

/// Where camera rays start, in their own parameter.
pub const CAMERA_RAY_TMIN: f64 = 1.0;

impl Camera {
    /// The ray through screen coordinates (u, v) ∈ \[0,1\]²: u = 0 is the left edge (+y),
    /// v = 0 the bottom (−z).
    ///
    /// ```
    /// use lumen::scene::Camera;
    /// use glam::DVec3;
    /// let r = Camera::default().ray(0.5, 0.5);
    /// assert_eq!(r.origin, DVec3::new(-1.0, 0.0, 0.0));
    /// assert_eq!(r.dir, DVec3::new(1.0, 0.0, 0.0));
    /// ```
    pub fn ray(&self, u: f64, v: f64) -> CameraRay {
        let (o, d) = match self.projection {
            Projection::Perspective { screen_distance: d } => {
                (DVec3::new(-d, 0.0, 0.0), DVec3::new(d, (1.0 - 2.0 * u) * self.aspect_ratio, 2.0 * v - 1.0))
            }
            Projection::Orthogonal => (DVec3::new(-1.0, (1.0 - 2.0 * u) * self.aspect_ratio, 2.0 * v - 1.0), DVec3::X),
        };
        CameraRay { origin: self.transform.point(o), dir: self.transform.vector(d) }
    }

    /// Raytracer.jl's `aperture_deg`: 2·atan2(d, a) in degrees (perspective only).
    pub fn aperture_deg(&self) -> Option<f64> {
        match self.projection {
            Projection::Perspective { screen_distance } => {
                Some(2.0 * screen_distance.atan2(self.aspect_ratio).to_degrees())
            }
            Projection::Orthogonal => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn corners_follow_the_spec() {
        let c = Camera { aspect_ratio: 2.0, ..Camera::default() };
        // u = 0 → +y side, v = 0 → −z.
        assert_eq!(c.ray(0.0, 0.0).dir, DVec3::new(1.0, 2.0, -1.0));
        assert_eq!(c.ray(1.0, 1.0).dir, DVec3::new(1.0, -2.0, 1.0));
        let o = Camera { projection: Projection::Orthogonal, aspect_ratio: 2.0, transform: Transform::IDENTITY };
        assert_eq!(o.ray(0.0, 1.0).origin, DVec3::new(-1.0, 2.0, 1.0));
        assert_eq!(Camera::default().aperture_deg(), Some(90.0));
    }
}
