//! Maps keyed by the bit patterns of f64 coordinates: how the writers share the vertices of
//! meshes in one file, and how the joins (`pipeline::crease_net::merge`, `pipeline::pieces`) find
//! the bit-identical vertices of shared polygons.

/// A fast hash for keys made of f64 bit patterns (SipHash's resistance to chosen keys is not
/// needed here, and it took a sixth of the time of writing an OBJ). Lookup only: no output
/// depends on a map's iteration order.
#[derive(Clone, Copy, Default)]
pub struct BitsHash;

impl std::hash::BuildHasher for BitsHash {
    type Hasher = BitsHasher;
    fn build_hasher(&self) -> BitsHasher {
        BitsHasher(0)
    }
}

/// Multiply-rotate mixing of 64-bit words (the FxHash scheme), finished with MurmurHash3's
/// avalanche: coordinates on dyadic grids (0.5, 0.25, …) have all-zero low bits, which a bare
/// multiply would leave zero and so crowd into one bucket.
pub struct BitsHasher(u64);

impl std::hash::Hasher for BitsHasher {
    fn write(&mut self, bytes: &[u8]) {
        for chunk in bytes.chunks(8) {
            let mut word = [0u8; 8];
            word[..chunk.len()].copy_from_slice(chunk);
            self.write_u64(u64::from_le_bytes(word));
        }
    }

    fn write_u64(&mut self, x: u64) {
        self.0 = (self.0.rotate_left(5) ^ x).wrapping_mul(0x51_7c_c1_b7_27_22_0a_95);
    }

    fn finish(&self) -> u64 {
        let mut h = self.0;
        h ^= h >> 33;
        h = h.wrapping_mul(0xff51_afd7_ed55_8ccd);
        h ^= h >> 33;
        h = h.wrapping_mul(0xc4ce_b9fe_1a85_ec53);
        h ^ (h >> 33)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn positions_on_a_dyadic_grid_hash_apart() {
        use std::hash::BuildHasher;
        // Coordinates with all-zero low mantissa bits must still spread over the low bits,
        // which pick a hash table's bucket.
        let low_bits: std::collections::BTreeSet<u64> = (0..64)
            .map(|i| {
                let v = [f64::from(i) * 0.5, 0.25, -1.0].map(f64::to_bits);
                BitsHash.hash_one(v) & 0xff
            })
            .collect();
        assert!(low_bits.len() > 40, "{}", low_bits.len());
    }
}
