//! A memo of group searches (issue 44, local and incremental fitting): while a
//! [`scope`] is open on a thread, [`group_crossings_within`](super::group_crossings_within)
//! remembers each group's result under a 128-bit key of everything the search reads —
//! its triangles' corner positions (bit for bit), which corners share a vertex (vertices
//! numbered by first use in the group) and the per-group limit — and a group met again
//! with the same key takes the remembered pairs and work instead of being searched.
//!
//! The mesh clearing ([`crate::fit::clear`]) opens a scope around its rounds: each round
//! remeshes the whole tree after thinning a few internodes, and the quad and sweep
//! meshers' repair loops search every junction again although only those near the
//! thinned nodes changed. Results are those a search would give (the key covers every
//! input of the search; a collision of two different groups on 128 bits is not a
//! practical concern), so outputs stay byte-identical.

use std::cell::RefCell;
use std::collections::HashMap;

/// A remembered group: its crossing pairs (local triangle positions in the group, in the
/// order the search found them) and the work the search spent.
#[derive(Debug, Clone)]
pub(crate) struct Entry {
    /// Pairs `(a, b)` of positions in the group's sorted triangle list.
    pub(crate) pairs: Vec<(u32, u32)>,
    /// Work units the search spent (the group's triangles plus its candidate pairs).
    pub(crate) work: u64,
}

/// The groups remembered by a scope, with counts of hits and misses.
#[derive(Debug, Default)]
pub(crate) struct Memo {
    pub(crate) groups: HashMap<u128, Entry>,
    /// Groups answered from the memo.
    pub(crate) hits: u64,
    /// Groups searched.
    pub(crate) misses: u64,
}

thread_local! {
    static CURRENT: RefCell<Option<Memo>> = const { RefCell::new(None) };
}

/// Runs `f` with a group-search memo open on this thread (a scope already open is used
/// as it is). Returns `f`'s result and, for the outermost scope, the hits and misses.
pub(crate) fn scope<R>(f: impl FnOnce() -> R) -> (R, Option<(u64, u64)>) {
    if CURRENT.with(|c| c.borrow().is_some()) {
        return (f(), None);
    }
    struct Close;
    impl Drop for Close {
        fn drop(&mut self) {
            CURRENT.with(|c| c.borrow_mut().take());
        }
    }
    CURRENT.with(|c| *c.borrow_mut() = Some(Memo::default()));
    let close = Close;
    let r = f();
    let counts = CURRENT.with(|c| c.borrow().as_ref().map(|m| (m.hits, m.misses)));
    drop(close);
    (r, counts)
}

/// Takes this thread's memo out for a search (put it back with [`restore`]).
pub(crate) fn take() -> Option<Memo> {
    CURRENT.with(|c| c.borrow_mut().take())
}

/// Puts a memo taken with [`take`] back.
pub(crate) fn restore(memo: Memo) {
    CURRENT.with(|c| *c.borrow_mut() = Some(memo));
}

/// A 128-bit hash of a stream of words (two 64-bit multiply–rotate lanes, finished with
/// MurmurHash3's `fmix64`): the memo's key.
pub(crate) struct Key {
    a: u64,
    b: u64,
    n: u64,
}

impl Key {
    /// An empty stream.
    pub(crate) fn new() -> Self {
        Self { a: 0x243f_6a88_85a3_08d3, b: 0x1319_8a2e_0370_7344, n: 0 }
    }

    /// Adds one word.
    pub(crate) fn write(&mut self, w: u64) {
        self.a = (self.a ^ w).wrapping_mul(0x9e37_79b9_7f4a_7c15).rotate_left(29);
        self.b = (self.b.rotate_left(17) ^ w).wrapping_mul(0xc2b2_ae3d_27d4_eb4f).wrapping_add(self.a);
        self.n += 1;
    }

    /// The key of the words written.
    pub(crate) fn finish(&self) -> u128 {
        let fmix = |mut k: u64| {
            k ^= k >> 33;
            k = k.wrapping_mul(0xff51_afd7_ed55_8ccd);
            k ^= k >> 33;
            k = k.wrapping_mul(0xc4ce_b9fe_1a85_ec53);
            k ^ (k >> 33)
        };
        let hi = fmix(self.a ^ self.n.rotate_left(32));
        let lo = fmix(self.b ^ hi);
        (u128::from(hi) << 64) | u128::from(lo)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_differ_for_different_streams_and_agree_for_equal_ones() {
        let key = |ws: &[u64]| {
            let mut k = Key::new();
            ws.iter().for_each(|&w| k.write(w));
            k.finish()
        };
        assert_eq!(key(&[1, 2, 3]), key(&[1, 2, 3]));
        assert_ne!(key(&[1, 2, 3]), key(&[1, 3, 2]));
        assert_ne!(key(&[0]), key(&[0, 0]));
        assert_ne!(key(&[]), key(&[0]));
        let mut seen = std::collections::HashSet::new();
        for i in 0..10_000u64 {
            assert!(seen.insert(key(&[i, i >> 3])), "collision at {i}");
        }
    }

    #[test]
    fn remembered_groups_give_the_searched_pairs_and_work_and_changed_ones_are_searched() {
        use super::super::intersect::group_crossings_within;
        use glam::Vec3;
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_pcg::Pcg64::seed_from_u64(3);
        let mut p: Vec<Vec3> =
            (0..900).map(|_| Vec3::new(rng.random(), rng.random(), rng.random())).collect();
        // 300 triangles in 10 groups (each triangle in its group and, every third, in the next one).
        let tris = |offset: u32| -> Vec<(u32, [u32; 3], u32)> {
            (0..300u32)
                .flat_map(|t| {
                    let c = [3 * t, 3 * t + 1, 3 * t + 2];
                    let g = t / 30;
                    let twice = (t % 3 == 0).then_some((g + 1, c, t + offset));
                    std::iter::once((g, c, t + offset)).chain(twice)
                })
                .collect()
        };
        let plain = |p: &[Vec3], per: usize| group_crossings_within(p, tris(0), per, u64::MAX).unwrap();
        let want = plain(&p, 2);
        assert!(!want.0.is_empty(), "the groups should cross");
        // The searches without a memo: another limit, and one vertex moved.
        let want64 = plain(&p, 64);
        let mut q = p.clone();
        q[0] += Vec3::splat(0.3);
        let want_moved = plain(&q, 2);
        let ((), counts) = scope(|| {
            assert_eq!(group_crossings_within(&p, tris(0), 2, u64::MAX).unwrap(), want);
            // Faces renumbered: the same groups, remembered, with the new face numbers.
            let moved = group_crossings_within(&p, tris(1000), 2, u64::MAX).unwrap();
            let shifted: Vec<_> = want.0.iter().map(|&(g, a, b)| (g, a + 1000, b + 1000)).collect();
            assert_eq!(moved, (shifted, want.1));
            // Another limit is another key.
            assert_eq!(group_crossings_within(&p, tris(0), 64, u64::MAX).unwrap(), want64);
            // One vertex moved: its groups are searched again.
            p[0] += Vec3::splat(0.3);
            assert_eq!(group_crossings_within(&p, tris(0), 2, u64::MAX).unwrap(), want_moved);
            // A budget too small is still an error.
            assert!(group_crossings_within(&p, tris(0), 2, 10).is_none());
        });
        // 11 groups: searched, remembered, searched (limit 64), 2 searched and 9
        // remembered, remembered (over the budget).
        assert_eq!(counts, Some((11 + 9 + 11, 11 + 11 + 2)));
    }

    #[test]
    fn a_scope_is_open_only_inside_and_nests() {
        assert!(take().is_none());
        let ((), counts) = scope(|| {
            let inner = scope(|| CURRENT.with(|c| c.borrow().is_some()));
            assert!(inner.0 && inner.1.is_none(), "the inner scope uses the outer memo");
        });
        assert_eq!(counts, Some((0, 0)));
        assert!(take().is_none());
    }
}
