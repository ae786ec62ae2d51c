//! A 128-bit fingerprint of what decides a render's pixels: the scene file, every file it reads,
//! and the settings after command-line overrides. Parts of one frame rendered on many machines
//! must share it before they are merged; a checkpoint is resumed only under it. Not a
//! cryptographic hash: it tells renders apart, it does not resist forgery.

/// An order-independent accumulator of hashed parts (files may be read in any order).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Fingerprint(u128);

const K0: u64 = 0x9E37_79B9_7F4A_7C15;
const K1: u64 = 0xC2B2_AE3D_27D4_EB4F;

fn mix(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// 128 bits of hash of `bytes` under a `kind` tag (two independent 64-bit lanes, 8 bytes a step).
pub fn hash(kind: &str, bytes: &[u8]) -> u128 {
    let (mut a, mut b) = (mix(K0 ^ kind.len() as u64), mix(K1 ^ bytes.len() as u64));
    for (i, part) in kind.as_bytes().chunks(8).chain(bytes.chunks(8)).enumerate() {
        let mut w = [0u8; 8];
        w[..part.len()].copy_from_slice(part);
        let w = u64::from_le_bytes(w) ^ (i as u64).wrapping_mul(K1);
        a = mix(a ^ w).wrapping_add(K0);
        b = mix(b.rotate_left(29) ^ w.wrapping_mul(K0)).wrapping_add(K1);
    }
    (u128::from(mix(a ^ b.rotate_left(17))) << 64) | u128::from(mix(b ^ a.rotate_left(41)))
}

impl Fingerprint {
    /// Adds a part (order does not matter).
    pub fn add(&mut self, kind: &str, bytes: &[u8]) {
        self.0 = self.0.wrapping_add(hash(kind, bytes));
    }

    /// The fingerprint as 32 hex digits.
    pub fn hex(&self) -> String {
        format!("{:032x}", self.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parts_change_it_and_order_does_not() {
        let (mut a, mut b) = (Fingerprint::default(), Fingerprint::default());
        a.add("file", b"one");
        a.add("file", b"two");
        b.add("file", b"two");
        b.add("file", b"one");
        assert_eq!(a, b);
        let mut c = a;
        c.add("setting", b"");
        assert_ne!(a, c);
        assert_ne!(hash("x", b"ab"), hash("x", b"ba"));
        assert_ne!(hash("x", b"a"), hash("xa", b""));
        assert_eq!(a.hex().len(), 32);
    }
}
