//! Named metals for `[[material]] metal = "…"`: complex indices of refraction per Rec.709
//! channel, reduced from measured spectral data by `tools/metals_rgb.py` (which documents the
//! sources and the fit: per channel, the η and k whose exact Fresnel curve best matches the
//! spectral reflectance seen through that channel under D65).

use glam::Vec3;

/// (name, η, k), relative to air.
const METALS: [(&str, [f32; 3], [f32; 3]); 4] = [
    ("gold", [0.0918, 0.4118, 1.8510], [14.2313, 2.3766, 1.9709]),
    ("silver", [0.1293, 0.1253, 0.1513], [4.1103, 3.3512, 2.4125]),
    ("copper", [0.1689, 0.9762, 1.2114], [3.6378, 2.6212, 2.3663]),
    (
        "aluminium",
        [1.4274, 0.9294, 0.5916],
        [7.7359, 6.6056, 5.3648],
    ),
];

/// The complex index (η, k) of a named metal; `aluminum` is accepted for `aluminium`.
pub fn named(name: &str) -> Option<(Vec3, Vec3)> {
    let name = if name == "aluminum" {
        "aluminium"
    } else {
        name
    };
    METALS
        .iter()
        .find(|(n, _, _)| *n == name)
        .map(|(_, eta, k)| (Vec3::from_array(*eta), Vec3::from_array(*k)))
}

/// The names `named` knows, for error messages.
pub fn names() -> impl Iterator<Item = &'static str> {
    METALS.iter().map(|(n, _, _)| *n)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::microfacet::fresnel_conductor;

    #[test]
    fn named_metals_have_their_colours_at_normal_incidence() {
        // Colours at 0° printed by tools/metals_rgb.py from the spectral data.
        for (name, f0) in [
            ("gold", [1.0, 0.7842, 0.3889]),
            ("silver", [0.9715, 0.9599, 0.9153]),
            ("copper", [0.9551, 0.6377, 0.5381]),
            ("aluminum", [0.9132, 0.9215, 0.9245]),
        ] {
            let (eta, k) = named(name).unwrap();
            let r = fresnel_conductor(1.0, eta, k);
            let error = (r - Vec3::from_array(f0)).abs().max_element();
            assert!(error < 0.01, "{name}: {r} against {f0:?}");
        }
        assert!(named("brass").is_none());
    }
}
