//! The one seeded random generator of the tests (xorshift64*), for tests that draw their
//! cases: the same cases on every run, no dependency.
#![allow(dead_code)]

use glam::DVec3;

pub struct Rng(pub u64);

impl Rng {
    /// A generator from `seed`; 0 (which xorshift never leaves) is taken as 1.
    pub fn new(seed: u64) -> Rng {
        Rng(seed.max(1))
    }

    pub fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    /// Uniform in [0, 1).
    pub fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform in [lo, hi).
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }

    /// Uniform in the box [lo, hi) (x, y, z drawn in that order).
    pub fn point(&mut self, lo: DVec3, hi: DVec3) -> DVec3 {
        DVec3::new(
            self.range(lo.x, hi.x),
            self.range(lo.y, hi.y),
            self.range(lo.z, hi.z),
        )
    }

    /// A random unit vector: points of the cube [-1, 1)³ drawn until one lies in the shell
    /// 0.1 ≤ |v| ≤ 1, normalised.
    pub fn direction(&mut self) -> DVec3 {
        loop {
            let v = self.point(DVec3::splat(-1.0), DVec3::splat(1.0));
            if (0.01..=1.0).contains(&v.length_squared()) {
                return v.normalize();
            }
        }
    }

    /// `xs` in a random order (Fisher–Yates from the last place).
    pub fn shuffle<T>(&mut self, xs: &mut [T]) {
        for i in (1..xs.len()).rev() {
            xs.swap(i, (self.next() % (i as u64 + 1)) as usize);
        }
    }

    /// One of `xs`.
    pub fn pick<T: Copy>(&mut self, xs: &[T]) -> T {
        xs[(self.next() % xs.len() as u64) as usize]
    }
}
