//! A 128-bit fingerprint of what decides a render's pixels: the scene file, every file it reads,
//! and the settings after command-line overrides that differ from their defaults
//! ([`differing_fields`]: a new setting left at its default changes no fingerprint, so it does not
//! make every recorded image stale). Parts of one frame rendered on many machines must share it
//! before they are merged; a checkpoint is resumed only under it. Not a cryptographic hash: it
//! tells renders apart, it does not resist forgery. Large files are hashed in blocks on every
//! core (a 42 MB mesh in a few milliseconds).

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

/// Bytes hashed as one block: the blocks of a large file are hashed in parallel, then folded in
/// order (the blocks depend on the length alone, so the hash does not depend on the threads).
const BLOCK_BYTES: usize = 1 << 20;

/// 128 bits of hash of `bytes` under a `kind` tag: the tag and the hashes of the blocks of
/// `bytes` ([`block`]) folded in order by two independent 64-bit lanes.
pub fn hash(kind: &str, bytes: &[u8]) -> u128 {
    use rayon::prelude::*;
    let blocks: Vec<u128> = if bytes.len() > BLOCK_BYTES { bytes.par_chunks(BLOCK_BYTES).map(block).collect() } else { vec![block(bytes)] };
    let (mut a, mut b) = (mix(K0 ^ kind.len() as u64), mix(K1 ^ bytes.len() as u64));
    let words = kind.as_bytes().chunks(8).map(|part| {
        let mut w = [0u8; 8];
        w[..part.len()].copy_from_slice(part);
        u64::from_le_bytes(w)
    });
    let words = words.chain(blocks.iter().flat_map(|&h| [h as u64, (h >> 64) as u64]));
    for (i, w) in words.enumerate() {
        let w = w ^ (i as u64).wrapping_mul(K1);
        a = mix(a ^ w).wrapping_add(K0);
        b = mix(b.rotate_left(29) ^ w.wrapping_mul(K0)).wrapping_add(K1);
    }
    (u128::from(mix(a ^ b.rotate_left(17))) << 64) | u128::from(mix(b ^ a.rotate_left(41)))
}

/// 128 bits of hash of a block of bytes: four independent lanes of xxHash64's round over 32
/// bytes a step (the last step padded with zeros: [`hash`] adds the length), then mixed into two
/// words that each depend on every lane.
fn block(bytes: &[u8]) -> u128 {
    const P1: u64 = 0x9E37_79B1_85EB_CA87;
    const P2: u64 = 0xC2B2_AE3D_27D4_EB4F;
    let round = |lane: u64, w: u64| lane.wrapping_add(w.wrapping_mul(P2)).rotate_left(31).wrapping_mul(P1);
    let mut lanes = [P1.wrapping_add(P2), P2, 0, P1.wrapping_neg()];
    let step = |lanes: &mut [u64; 4], stripe: &[u8]| {
        for (lane, w) in lanes.iter_mut().zip(stripe.chunks_exact(8)) {
            *lane = round(*lane, u64::from_le_bytes(w.try_into().unwrap_or_default()));
        }
    };
    let stripes = bytes.chunks_exact(32);
    let tail = stripes.remainder();
    for stripe in stripes {
        step(&mut lanes, stripe);
    }
    if !tail.is_empty() {
        let mut last = [0u8; 32];
        last[..tail.len()].copy_from_slice(tail);
        step(&mut lanes, &last);
    }
    let [l0, l1, l2, l3] = lanes;
    let lo = mix(l0 ^ mix(l1 ^ mix(l2 ^ mix(l3 ^ K0))));
    let hi = mix(l3 ^ mix(l2 ^ mix(l1 ^ mix(l0 ^ K1))));
    (u128::from(hi) << 64) | u128::from(lo)
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

/// The fields of `value` that differ from those of `reference` (a value of the same type, its
/// defaults), one `name: value` per field in the order of the type's pretty `Debug`
/// (`{:#?}`), nested values whole. A field added to the type is named only where its value is
/// not the reference's, so the text of every value that leaves it at its default stays the same.
pub fn differing_fields<T: std::fmt::Debug>(value: &T, reference: &T) -> String {
    /// The top-level fields of a pretty `Debug`: each starts on a line indented four spaces,
    /// and runs over the deeper-indented lines after it.
    fn fields(text: &str) -> Vec<String> {
        let mut out: Vec<String> = Vec::new();
        for line in text.lines().skip(1) {
            let top = line.starts_with("    ") && !line.starts_with("     ");
            match out.last_mut() {
                Some(field) if !top && line.starts_with("     ") => {
                    field.push('\n');
                    field.push_str(line);
                }
                _ if top => out.push(line.to_string()),
                _ => {}
            }
        }
        out
    }
    let (ours, theirs) = (fields(&format!("{value:#?}")), fields(&format!("{reference:#?}")));
    ours.into_iter().filter(|f| !theirs.contains(f)).collect::<Vec<_>>().join("\n")
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Only the fields that differ from the reference are named, nested values whole; a field at
    /// its default adds nothing, so a type that gains one keeps its values' texts.
    #[test]
    fn only_fields_off_their_defaults_count() {
        #[derive(Debug)]
        #[allow(dead_code)] // read through Debug only
        struct Old {
            width: u32,
            aa: Option<(f64, u32)>,
        }
        #[derive(Debug)]
        #[allow(dead_code)] // read through Debug only
        struct New {
            width: u32,
            aa: Option<(f64, u32)>,
            budget: Option<u64>,
        }
        let old = |width, aa| Old { width, aa };
        let new = |width, aa, budget| New { width, aa, budget };
        assert_eq!(differing_fields(&old(800, None), &old(800, None)), "");
        assert_eq!(differing_fields(&old(64, None), &old(800, None)), "    width: 64,");
        let adaptive = differing_fields(&old(800, Some((0.02, 3))), &old(800, None));
        assert!(adaptive.starts_with("    aa: Some(") && adaptive.contains("0.02") && adaptive.contains('3'), "{adaptive}");
        // A new field at its default: the same text as before it existed.
        assert_eq!(
            differing_fields(&new(64, Some((0.02, 3)), None), &new(800, None, None)),
            differing_fields(&old(64, Some((0.02, 3))), &old(800, None))
        );
        assert_eq!(
            differing_fields(&new(64, None, Some(5)), &new(800, None, None)),
            "    width: 64,\n    budget: Some(\n        5,\n    ),"
        );
    }

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

    /// Every byte of a file of many blocks counts, and so does their order; the value is pinned
    /// (partial images and checkpoints store fingerprints: a change of the hash orphans them).
    #[test]
    fn every_byte_and_block_counts_and_the_value_is_pinned() {
        let bytes: Vec<u8> = (0..3 * BLOCK_BYTES as u64 + 77).map(|i| (mix(i) >> 56) as u8).collect();
        let whole = hash("file", &bytes);
        for at in [0, 31, 32, BLOCK_BYTES - 1, BLOCK_BYTES, 2 * BLOCK_BYTES + 5, bytes.len() - 1] {
            let mut changed = bytes.clone();
            changed[at] ^= 1;
            assert_ne!(hash("file", &changed), whole, "byte {at}");
        }
        let mut swapped = bytes.clone();
        let (first, second) = swapped.split_at_mut(BLOCK_BYTES);
        first.swap_with_slice(&mut second[..BLOCK_BYTES]);
        assert_ne!(hash("file", &swapped), whole, "blocks swapped");
        assert_ne!(hash("file", &bytes[..bytes.len() - 1]), whole, "one byte shorter");
        assert_ne!(hash("file", b"a"), hash("file", b"a\0"), "zero padding");
        assert_eq!(format!("{:032x}", hash("file", b"raylab")), "7f608f616aa35ec410c3b3ed77c0ac2e");
        assert_eq!(format!("{whole:032x}"), "3187322eda78ce20a275a8c654c6c794");
    }
}
