//! A stable 64-bit hash (FNV-1a) for scene identity and checksums.

/// FNV-1a, 64 bit: a stable hash (unlike std's randomised one) for scene identity and checksums.
#[derive(Clone, Copy, Debug)]
pub struct Fnv1a64(u64);

impl Default for Fnv1a64 {
    fn default() -> Self {
        Fnv1a64(0xcbf2_9ce4_8422_2325)
    }
}

impl Fnv1a64 {
    /// A fresh hasher at the FNV offset basis.
    pub fn new() -> Self {
        Self::default()
    }
    /// Feed bytes.
    pub fn write(&mut self, bytes: &[u8]) {
        let mut h = self.0;
        for &b in bytes {
            h ^= b as u64;
            h = h.wrapping_mul(0x0000_0100_0000_01b3);
        }
        self.0 = h;
    }
    /// Feed a length-prefixed byte string (so that concatenations cannot collide).
    pub fn write_field(&mut self, bytes: &[u8]) {
        self.write(&(bytes.len() as u64).to_le_bytes());
        self.write(bytes);
    }
    /// The hash so far.
    pub fn finish(&self) -> u64 {
        self.0
    }
}

/// A number in [0, 1) fixed by a point, a direction and a `salt`: their bits through SplitMix64's
/// finaliser (blend choices and mask tests, which must not draw from a path's random numbers).
#[inline]
pub fn hash_unit(p: glam::Vec3, d: glam::Vec3, salt: u64) -> f32 {
    let mut h = 0x9e37_79b9_7f4a_7c15u64 ^ salt;
    for x in [p.x, p.y, p.z, d.x, d.y, d.z] {
        h = (h ^ x.to_bits() as u64).wrapping_add(0x9e37_79b9_7f4a_7c15);
        h = (h ^ (h >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        h = (h ^ (h >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        h ^= h >> 31;
    }
    (h >> 40) as f32 / (1u64 << 24) as f32
}
