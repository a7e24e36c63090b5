//! Step 1 of the tube mesher: the skeleton split into axes (chains of stations), each
//! node continuing into its same-order, thickest, best-aligned child; laterals start at
//! the branching node with the internode's start radius (McLoughlin2021 §4.2; rules in
//! `docs/meshers.md`, "tube").

use crate::skeleton::{Children, Skeleton, NO_PARENT};
use glam::Vec3;

/// One ring centre along an axis.
#[derive(Debug, Clone, Copy)]
pub(super) struct Station {
    pub(super) pos: Vec3,
    pub(super) radius: f32,
    /// Skeleton node whose `up` this station carries (for a lateral base: the child).
    pub(super) node: u32,
}

impl Station {
    /// A radius-0 station is a single vertex, not a ring. So is a radius too small for
    /// `f32` to place distinct ring vertices around this position (a twig tapering to
    /// ~1e-6 m at 4 m from the origin): its ring would be a fan of zero-area faces.
    pub(super) fn is_point(&self) -> bool {
        self.radius <= self.pos.abs().max_element() * (16.0 * f32::EPSILON)
    }
}

/// All axes as stations in compressed rows.
pub(super) struct Axes {
    stations: Vec<Station>,
    offsets: Vec<u32>,
}

impl Axes {
    pub(super) fn count(&self) -> usize {
        self.offsets.len() - 1
    }

    pub(super) fn axis(&self, a: usize) -> &[Station] {
        &self.stations[self.offsets[a] as usize..self.offsets[a + 1] as usize]
    }
}

/// True when `b` is at `a` up to float noise (a zero-length internode).
fn coincident(a: Vec3, b: Vec3) -> bool {
    let d = (a - b).abs().max_element();
    let scale = a.abs().max_element().max(b.abs().max_element());
    d <= 4.0 * f32::EPSILON * scale || d < 1e-30
}

/// The child that continues node `i`'s axis, or [`NO_PARENT`] when `i` has none.
pub(super) fn continuation(s: &Skeleton, children: &Children, i: usize) -> u32 {
    let kids = children.of(i);
    let order = s.order[i];
    let same_order = kids.iter().any(|&c| s.order[c as usize] == order);
    let incoming = match s.parent[i] {
        NO_PARENT => Vec3::ZERO,
        p => (s.position[i] - s.position[p as usize]).normalize_or_zero(),
    };
    let mut best = NO_PARENT;
    let (mut best_r, mut best_align) = (0.0f32, 0.0f32);
    for &c in kids {
        let cu = c as usize;
        if same_order && s.order[cu] != order {
            continue;
        }
        let r = s.radius[cu];
        let align = incoming.dot((s.position[cu] - s.position[i]).normalize_or_zero());
        if best == NO_PARENT || r > best_r || (r == best_r && align > best_align) {
            best = c;
            best_r = r;
            best_align = align;
        }
    }
    best
}

/// Splits the skeleton into axes of stations (step 1 of the module docs). Axes with
/// fewer than two stations are dropped.
pub(super) fn build_axes(s: &Skeleton) -> Axes {
    let n = s.len();
    let children = s.children();
    let next: Vec<u32> = (0..n).map(|i| continuation(s, &children, i)).collect();
    let mut stations = Vec::with_capacity(n + n / 2);
    let mut offsets = vec![0u32];
    for i in 0..n {
        let p = s.parent[i];
        if p != NO_PARENT && next[p as usize] == i as u32 {
            continue; // i continues its parent's axis
        }
        let begin = stations.len();
        if p != NO_PARENT {
            // Lateral axis: its first ring is at the branching node, with the internode's
            // explicit start radius, else the smaller of the two radii so the base stays
            // inside the parent tube.
            let pu = p as usize;
            stations.push(Station {
                pos: s.position[pu],
                radius: s.start_radius(i).unwrap_or(s.radius[pu].min(s.radius[i])),
                node: i as u32,
            });
        }
        let mut k = i as u32;
        while k != NO_PARENT {
            let ku = k as usize;
            let pos = s.position[ku];
            let merged = stations.len() > begin
                && stations.last().is_some_and(|last: &Station| coincident(last.pos, pos));
            if !merged {
                stations.push(Station { pos, radius: s.radius[ku], node: k });
            }
            k = next[ku]; // always > k, so this ends
        }
        // A run of point stations at either end would leave all but one of its vertices
        // unused (a cone needs one apex): keep only the point next to the last ring.
        while stations.len() - begin >= 2
            && stations[stations.len() - 1].is_point()
            && stations[stations.len() - 2].is_point()
        {
            stations.pop();
        }
        while stations.len() - begin >= 2 && stations[begin].is_point() && stations[begin + 1].is_point() {
            stations.remove(begin);
        }
        if stations.len() - begin >= 2 {
            offsets.push(stations.len() as u32);
        } else {
            stations.truncate(begin);
        }
    }
    Axes { stations, offsets }
}

/// An axis makes faces unless every ring is a point.
pub(super) fn has_faces(st: &[Station]) -> bool {
    st.windows(2).any(|w| !w[0].is_point() || !w[1].is_point())
}
