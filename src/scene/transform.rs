//! Affine transformations that place unit shapes, CSG nodes and cameras in the world.

use glam::{DMat4, DVec3, DVec4};

use super::SceneError;

/// An affine transformation kept together with its inverse, so that rays are moved into
/// object space and normals out of it without inverting anything per ray.
///
/// ```
/// use lumen::scene::Transform;
/// use glam::DVec3;
/// let t = Transform::translation(DVec3::new(1.0, 2.0, 3.0)) * Transform::scaling(DVec3::splat(2.0));
/// assert_eq!(t.point(DVec3::ONE), DVec3::new(3.0, 4.0, 5.0));
/// assert!((t.inverse().point(DVec3::new(3.0, 4.0, 5.0)) - DVec3::ONE).length() < 1e-12);
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Transform {
    m: DMat4,
    inv: DMat4,
}

impl Default for Transform {
    fn default() -> Self {
        Self::IDENTITY
    }
}

impl Transform {
    /// The transformation that moves nothing: object space is the parent's.
    pub const IDENTITY: Self = Self { m: DMat4::IDENTITY, inv: DMat4::IDENTITY };

    /// Builds a transformation from a matrix, computing the inverse. Fails on non-finite
    /// entries, a singular matrix, or a non-affine last row.
    pub fn from_matrix(m: DMat4) -> Result<Self, SceneError> {
        if !m.is_finite() {
            return Err(SceneError::NonFiniteTransform);
        }
        if m.row(3) != DVec4::new(0.0, 0.0, 0.0, 1.0) {
            return Err(SceneError::NotAffine);
        }
        let det = m.determinant();
        // Relative test: compare with the scale of the linear part so tiny but regular
        // scalings (1e-4 scenes) stay valid.
        let scale = m.x_axis.truncate().length() * m.y_axis.truncate().length() * m.z_axis.truncate().length();
        if det == 0.0 || !det.is_finite() || scale == 0.0 || (det.abs() / scale) < 1e-12 {
            return Err(SceneError::SingularTransform);
        }
        let inv = m.inverse();
        if !inv.is_finite() {
            return Err(SceneError::SingularTransform);
        }
        Ok(Self { m, inv })
    }

    /// Row-major 4×4 matrix, as SceneLang's `Transformation([...])` writes it.
    pub fn from_rows(rows: [f64; 16]) -> Result<Self, SceneError> {
        Self::from_matrix(DMat4::from_cols_array(&rows).transpose())
    }

    /// Translation by `v` (SceneLang's `TRANSLATE`); the inverse is the translation by −v.
    pub fn translation(v: DVec3) -> Self {
        Self { m: DMat4::from_translation(v), inv: DMat4::from_translation(-v) }
    }

    /// Non-uniform scaling; fails if any factor is zero or non-finite.
    pub fn try_scaling(s: DVec3) -> Result<Self, SceneError> {
        if !s.is_finite() {
            return Err(SceneError::NonFiniteTransform);
        }
        if s.x == 0.0 || s.y == 0.0 || s.z == 0.0 {
            return Err(SceneError::SingularTransform);
        }
        Ok(Self { m: DMat4::from_scale(s), inv: DMat4::from_scale(s.recip()) })
    }

    /// Scaling by finite, non-zero factors (panics otherwise; use [`Self::try_scaling`] for
    /// user input).
    pub fn scaling(s: DVec3) -> Self {
        Self::try_scaling(s).expect("scaling factors must be finite and non-zero")
    }

    /// Rotation about +x by `deg` **degrees** (right-handed), like SceneLang's `ROTATE`:
    /// the angle APIs that scenes and people call take degrees; radians stay internal
    /// (docs/DESIGN.md, "Conventions").
    pub fn rotation_x(deg: f64) -> Self {
        Self::rotation(DMat4::from_rotation_x(deg.to_radians()))
    }
    /// Rotation about +y by `deg` degrees (right-handed).
    pub fn rotation_y(deg: f64) -> Self {
        Self::rotation(DMat4::from_rotation_y(deg.to_radians()))
    }
    /// Rotation about +z by `deg` degrees (right-handed).
    pub fn rotation_z(deg: f64) -> Self {
        Self::rotation(DMat4::from_rotation_z(deg.to_radians()))
    }
    fn rotation(m: DMat4) -> Self {
        Self { m, inv: m.transpose() }
    }

    /// The forward matrix M, the one [`Self::point`] applies (column-major, as glam stores it).
    pub fn matrix(&self) -> DMat4 {
        self.m
    }
    /// M⁻¹, stored alongside M rather than computed per call.
    pub fn inverse_matrix(&self) -> DMat4 {
        self.inv
    }
    /// The inverse transformation: the two stored matrices swapped, nothing computed.
    pub fn inverse(&self) -> Self {
        Self { m: self.inv, inv: self.m }
    }
    /// Whether M is exactly the identity (no tolerance).
    pub fn is_identity(&self) -> bool {
        self.m == DMat4::IDENTITY
    }

    /// Applies M to a point: the linear part, then the translation.
    pub fn point(&self, p: DVec3) -> DVec3 {
        self.m.transform_point3(p)
    }
    /// Applies M's linear part to a direction or offset (no translation; the result is not
    /// normalised, so scaling changes its length).
    pub fn vector(&self, v: DVec3) -> DVec3 {
        self.m.transform_vector3(v)
    }
    /// Transforms a normal with the inverse transpose (not normalised).
    pub fn normal(&self, n: DVec3) -> DVec3 {
        self.inv.transpose().transform_vector3(n)
    }
    /// The scale factor s when the transformation is a similarity (s times a rotation or
    /// reflection, then a translation), to within `1e-9` relative in every entry of MᵀM =
    /// s²·I; `None` otherwise. A unit sphere placed by a similarity is round, of radius s,
    /// which lets the GPU test it in the world (`gpu::features::FeatureSet::round_spheres`).
    ///
    /// ```
    /// use lumen::scene::Transform;
    /// use glam::DVec3;
    /// let t = Transform::translation(DVec3::X) * Transform::rotation_z(30.0) * Transform::scaling(DVec3::splat(-2.0));
    /// assert!((t.similarity_scale().unwrap() - 2.0).abs() < 1e-12);
    /// assert_eq!(Transform::scaling(DVec3::new(1.0, 1.0, 2.0)).similarity_scale(), None);
    /// ```
    pub fn similarity_scale(&self) -> Option<f64> {
        let cols = [self.m.x_axis.truncate(), self.m.y_axis.truncate(), self.m.z_axis.truncate()];
        let s2 = cols.iter().map(|c| c.length_squared()).sum::<f64>() / 3.0;
        let round = (0..3).all(|i| {
            (i..3).all(|j| {
                let want = if i == j { s2 } else { 0.0 };
                (cols[i].dot(cols[j]) - want).abs() <= 1e-9 * s2
            })
        });
        (round && s2.is_finite() && s2 > 0.0).then(|| s2.sqrt())
    }
}

impl std::ops::Mul for Transform {
    type Output = Transform;
    /// `a * b` applies `b` first, then `a` (matrix product).
    fn mul(self, o: Transform) -> Transform {
        Transform { m: self.m * o.m, inv: o.inv * self.inv }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Rotations, reflections, uniform scales and translations in any order keep a
    /// similarity; a shear or an unequal scale does not, however small, beyond 1e-9.
    #[test]
    fn similarity_scale_is_the_uniform_scale_of_a_similarity() {
        let turn = Transform::rotation_x(17.0) * Transform::rotation_y(-40.0) * Transform::rotation_z(123.0);
        for s in [1e-12, 0.3, 1.0, 7.5, 1e12] {
            let t = Transform::translation(DVec3::new(5.0, -2.0, 1e3))
                * turn
                * Transform::scaling(DVec3::new(-s, s, s))
                * Transform::rotation_z(9.0);
            let k = t.similarity_scale().unwrap_or_else(|| panic!("scale {s}"));
            assert!((k / s - 1.0).abs() < 1e-12, "{k} vs {s}");
        }
        assert_eq!(Transform::IDENTITY.similarity_scale(), Some(1.0));
        let shear =
            Transform::from_rows([1.0, 1e-6, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0]);
        assert_eq!((turn * shear.unwrap()).similarity_scale(), None);
        let squashed = Transform::scaling(DVec3::new(2.0, 2.0, 2.0 * (1.0 + 1e-8)));
        assert_eq!((turn * squashed).similarity_scale(), None);
        // Rounding far below the tolerance is still a similarity.
        let nearly = Transform::scaling(DVec3::new(2.0, 2.0, 2.0 * (1.0 + 1e-12)));
        assert!(nearly.similarity_scale().is_some());
    }

    #[test]
    fn rotation_is_right_handed_in_degrees() {
        let r = Transform::rotation_z(90.0);
        assert!((r.point(DVec3::X) - DVec3::Y).length() < 1e-12);
        let r = Transform::rotation_x(90.0);
        assert!((r.point(DVec3::Y) - DVec3::Z).length() < 1e-12);
        let r = Transform::rotation_y(90.0);
        assert!((r.point(DVec3::Z) - DVec3::X).length() < 1e-12);
    }

    #[test]
    fn product_inverse_is_consistent() {
        let t = Transform::translation(DVec3::new(1.0, -2.0, 3.0))
            * Transform::rotation_x(30.0)
            * Transform::scaling(DVec3::new(2.0, 0.5, 3.0));
        assert!((t.matrix() * t.inverse_matrix()).abs_diff_eq(DMat4::IDENTITY, 1e-9));
        let n = t.normal(DVec3::Z);
        // The normal stays perpendicular to transformed tangent vectors.
        assert!(n.dot(t.vector(DVec3::X)).abs() < 1e-12);
        assert!(n.dot(t.vector(DVec3::Y)).abs() < 1e-12);
    }

    #[test]
    fn singular_and_non_finite_are_errors() {
        assert_eq!(Transform::try_scaling(DVec3::new(1.0, 0.0, 1.0)), Err(SceneError::SingularTransform));
        assert_eq!(Transform::try_scaling(DVec3::new(f64::NAN, 1.0, 1.0)), Err(SceneError::NonFiniteTransform));
        let mut rows = [0.0; 16];
        rows[15] = 1.0;
        assert_eq!(Transform::from_rows(rows), Err(SceneError::SingularTransform));
        let rows = [1., 0., 0., 5., 0., 1., 0., 6., 0., 0., 1., 7., 0., 0., 0., 1.];
        assert_eq!(Transform::from_rows(rows).unwrap().point(DVec3::ZERO), DVec3::new(5.0, 6.0, 7.0));
        assert!(Transform::try_scaling(DVec3::splat(1e-4)).is_ok());
    }
}
