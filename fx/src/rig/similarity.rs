//! Similarity transforms x ↦ t + s·R·x: the only transforms a portal may apply.
//!
//! Keeping rotation as a unit quaternion and the scale as one number makes every composition a
//! similarity by construction; re-normalising the quaternion after each product keeps a long chain
//! of teleports (a hall of mirrors) from drifting away from a rigid motion.

use glam::{DAffine3, DMat3, DMat4, DQuat, DVec3};

/// A rotation, a uniform scale and a translation, applied in that order.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Similarity {
    /// Unit quaternion.
    pub rotation: DQuat,
    /// Applied after rotation and scale.
    pub translation: DVec3,
    /// Uniform, strictly positive.
    pub scale: f64,
}

/// Why a matrix is not a proper similarity.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum SimilarityError {
    #[error("the transform has a non-finite entry")]
    NonFinite,
    #[error("the transform is singular (zero or near-zero scale)")]
    Singular,
    #[error("the transform mirrors space (negative determinant); teleports must keep handedness")]
    Reflection,
    #[error(
        "the transform is not a similarity (axis lengths differ by {0:.3e} relative, or axes are not orthogonal); \
         portals allow only rotation, translation and uniform scale"
    )]
    NotSimilarity(f64),
}

/// Relative tolerance within which a matrix counts as a similarity (input from other packages is
/// often written with 6–7 significant digits).
const SIMILARITY_TOLERANCE: f64 = 1e-5;

impl Similarity {
    /// The transform that changes nothing.
    pub const IDENTITY: Self = Self {
        rotation: DQuat::IDENTITY,
        translation: DVec3::ZERO,
        scale: 1.0,
    };

    /// Builds a similarity; the rotation is normalised.
    pub fn new(rotation: DQuat, translation: DVec3, scale: f64) -> Self {
        Self {
            rotation: rotation.normalize(),
            translation,
            scale,
        }
    }

    /// A pure translation.
    pub fn from_translation(translation: DVec3) -> Self {
        Self {
            translation,
            ..Self::IDENTITY
        }
    }

    /// Half a turn about local +Y: composes a *here* frame into the *there* frame of its partner.
    pub fn half_turn_y() -> Self {
        Self::new(
            DQuat::from_rotation_y(std::f64::consts::PI),
            DVec3::ZERO,
            1.0,
        )
    }

    /// Maps a point.
    #[inline]
    pub fn transform_point(&self, p: DVec3) -> DVec3 {
        self.translation + self.rotation * (p * self.scale)
    }

    /// Maps a displacement (scaled, not translated).
    #[inline]
    pub fn transform_vector(&self, v: DVec3) -> DVec3 {
        self.rotation * (v * self.scale)
    }

    /// Maps a direction (rotation only, so unit length is kept).
    #[inline]
    pub fn transform_direction(&self, d: DVec3) -> DVec3 {
        self.rotation * d
    }

    /// The inverse transform.
    pub fn inverse(&self) -> Self {
        let rotation = self.rotation.conjugate();
        let scale = 1.0 / self.scale;
        Self {
            rotation,
            translation: -(rotation * self.translation) * scale,
            scale,
        }
    }

    /// `self ∘ other`: applies `other` first.
    pub fn compose(&self, other: &Self) -> Self {
        Self {
            rotation: (self.rotation * other.rotation).normalize(),
            translation: self.transform_point(other.translation),
            scale: self.scale * other.scale,
        }
    }

    /// As an affine matrix.
    #[inline]
    pub fn to_affine(&self) -> DAffine3 {
        DAffine3::from_scale_rotation_translation(
            DVec3::splat(self.scale),
            self.rotation,
            self.translation,
        )
    }

    /// As a 4×4 matrix (column vectors).
    pub fn to_mat4(&self) -> DMat4 {
        DMat4::from(self.to_affine())
    }

    /// Recovers a similarity from an affine matrix, or says why it is not one.
    pub fn from_affine(m: &DAffine3) -> Result<Self, SimilarityError> {
        let lin = m.matrix3;
        if !lin.is_finite() || !m.translation.is_finite() {
            return Err(SimilarityError::NonFinite);
        }
        let lengths = DVec3::new(
            lin.x_axis.length(),
            lin.y_axis.length(),
            lin.z_axis.length(),
        );
        let scale = (lengths.x * lengths.y * lengths.z).cbrt();
        if scale < 1e-12 || scale < 1e-9 * lengths.max_element() {
            return Err(SimilarityError::Singular);
        }
        if lin.determinant() < 0.0 {
            return Err(SimilarityError::Reflection);
        }
        // A similarity has MᵀM = s²·I; measure the largest deviation relative to s².
        let gram = lin.transpose() * lin;
        let deviation = (gram - DMat3::from_diagonal(DVec3::splat(scale * scale)))
            .to_cols_array()
            .iter()
            .fold(0.0f64, |acc, v| acc.max(v.abs()))
            / (scale * scale);
        if deviation > SIMILARITY_TOLERANCE {
            return Err(SimilarityError::NotSimilarity(deviation));
        }
        let rotation = DQuat::from_mat3(&(lin * (1.0 / scale))).normalize();
        Ok(Self {
            rotation,
            translation: m.translation,
            scale,
        })
    }

    /// Blends two similarities: slerp for rotation, lerp for translation, geometric for scale.
    pub fn interpolate(&self, other: &Self, w: f64) -> Self {
        Self {
            rotation: self.rotation.slerp(other.rotation, w).normalize(),
            translation: self.translation.lerp(other.translation, w),
            scale: self.scale * (other.scale / self.scale).powf(w),
        }
    }

    /// Largest difference from `other` in how they map points within `radius` of the origin.
    pub fn distance(&self, other: &Self, radius: f64) -> f64 {
        let probes = [DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z];
        probes
            .iter()
            .map(|p| {
                (self.transform_point(*p * radius) - other.transform_point(*p * radius)).length()
            })
            .fold(0.0, f64::max)
    }
}

impl Default for Similarity {
    fn default() -> Self {
        Self::IDENTITY
    }
}

impl std::ops::Mul for Similarity {
    type Output = Similarity;
    fn mul(self, rhs: Similarity) -> Similarity {
        self.compose(&rhs)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inverse_round_trips() {
        let s = Similarity::new(
            DQuat::from_euler(glam::EulerRot::ZYX, 0.3, -1.2, 2.0),
            DVec3::new(3.0, -4.0, 5.0),
            2.5,
        );
        let id = s * s.inverse();
        assert!(id.distance(&Similarity::IDENTITY, 10.0) < 1e-12);
    }

    #[test]
    fn from_affine_accepts_similarities_and_rejects_the_rest() {
        let s = Similarity::new(DQuat::from_rotation_x(0.7), DVec3::new(1.0, 2.0, 3.0), 0.5);
        let back = Similarity::from_affine(&s.to_affine()).unwrap();
        assert!(back.distance(&s, 1.0) < 1e-12);

        let stretched = DAffine3::from_scale(DVec3::new(1.0, 2.0, 1.0));
        assert!(matches!(
            Similarity::from_affine(&stretched),
            Err(SimilarityError::NotSimilarity(_))
        ));
        let mirror = DAffine3::from_scale(DVec3::new(-1.0, 1.0, 1.0));
        assert_eq!(
            Similarity::from_affine(&mirror),
            Err(SimilarityError::Reflection)
        );
        let flat = DAffine3::from_scale(DVec3::new(1.0, 0.0, 1.0));
        assert_eq!(
            Similarity::from_affine(&flat),
            Err(SimilarityError::Singular)
        );
        let shear = DAffine3::from_mat3(DMat3::from_cols(
            DVec3::X,
            DVec3::new(0.3, 1.0, 0.0),
            DVec3::Z,
        ));
        assert!(Similarity::from_affine(&shear).is_err());
    }
}
