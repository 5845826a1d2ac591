//! Helpers shared by the unit tests.

/// Uniform samples in [0, 1) from a xorshift generator started at `seed` (not 0): the same
/// draws on every run, no dependency.
pub(crate) fn uniform(mut seed: u64) -> impl FnMut() -> f64 {
    assert_ne!(seed, 0, "a xorshift state of 0 stays 0");
    move || {
        seed ^= seed >> 12;
        seed ^= seed << 25;
        seed ^= seed >> 27;
        (seed.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// The plane z = 0 with ∇f = +z.
pub(crate) struct Plane;

impl crate::surface::Surface for Plane {
    fn value_gradient(&mut self, p: glam::DVec3) -> crate::surface::ValueGrad {
        crate::surface::ValueGrad {
            value: p.z,
            gradient: glam::DVec3::Z,
        }
    }
}
