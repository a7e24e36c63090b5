//! The refinement's peak memory, estimated from its element counts before anything is
//! allocated (issue 39 item 3: a face budget is a count, but memory is what runs out).
//!
//! Every level's counts follow from the control level's by the scheme's recurrences
//! (exact, not asymptotic), and every array the refinement allocates is charged by its
//! element size:
//!
//! | array | bytes |
//! |---|---|
//! | face vertices (every level) | 4 per corner |
//! | face edges, vertex corners (levels with adjacency) | 4 + 4 per corner |
//! | edge vertices, edge corners (levels with adjacency) | 8 + 8 per edge |
//! | vertex corner offsets | 4 per vertex |
//! | sharp features and rules | [`SHARP_EDGE`] per crease or boundary edge |
//! | positions (`Vec3`), interpolated | 12 per vertex of the last two levels |
//! | limit normals and positions | 24 + 12 per vertex, 4 per corner |
//! | the refined mesh, its control faces | 4 per corner, 4 + 4 per face |
//! | UVs (`Vec2`): the channel's own levels, values and indices | as above for its vertices, 8 per value |
//!
//! [`peak`] adds up what is alive at once at the two peaks of
//! [`super::subdivide_traced`]: while positions are interpolated, and at the end (the
//! refined mesh, its normals and UVs, the UV channel's levels or its finest values, and
//! the control faces). `tests/robustness_memory.rs` checks it against a counting
//! allocator.

use super::topology::Topology;
use super::{FvarInterpolation, PeakParts, RefineOptions, Scheme};

/// Bytes per sharp (crease or boundary) edge of a level: its feature entry (8), its edge
/// rule (8), a vertex rule for one of its ends (24), and the transient grouping of the
/// features by vertex while the next level's rules are made.
const SHARP_EDGE: u128 = 96;

/// Element counts of one level.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub(crate) struct Counts {
    pub v: u128,
    pub f: u128,
    pub c: u128,
    pub e: u128,
    /// Sharp edges: creases and boundary edges (they split in two at every level).
    pub s: u128,
}

impl Counts {
    /// The counts of `topo` with `sharp` crease and boundary edges.
    pub(crate) fn of(topo: &Topology, sharp: usize) -> Counts {
        Counts {
            v: topo.vertex_count() as u128,
            f: topo.face_count() as u128,
            c: topo.corner_count() as u128,
            e: topo.edge_count() as u128,
            s: sharp as u128,
        }
    }

    /// The counts one level finer.
    fn next(self, scheme: Scheme) -> Counts {
        let Counts { v, f, c, e, s } = self;
        let (add, mul) = (u128::saturating_add, u128::saturating_mul);
        match scheme {
            Scheme::CatmullClark => {
                Counts { v: add(add(v, f), e), f: c, c: mul(4, c), e: add(mul(2, e), c), s: mul(2, s) }
            }
            Scheme::Loop => {
                Counts { v: add(v, e), f: mul(4, f), c: mul(4, c), e: add(mul(2, e), c), s: mul(2, s) }
            }
        }
    }
}

/// How much adjacency a level keeps.
#[derive(Clone, Copy, PartialEq)]
enum Kept {
    Faces,
    Edges,
    Full,
}

/// Bytes of one level's topology.
fn topology(k: Counts, kept: Kept) -> u128 {
    let m = u128::saturating_mul;
    let faces = m(4, k.c);
    match kept {
        Kept::Faces => faces,
        Kept::Edges => faces.saturating_add(m(4, k.c)).saturating_add(m(8, k.e)),
        Kept::Full => faces
            .saturating_add(m(8, k.c))
            .saturating_add(m(16, k.e))
            .saturating_add(m(4, k.v.saturating_add(1))),
    }
}

/// Bytes of a refiner's levels from control counts `k0`: levels `0..levels` with
/// `inner` adjacency, the last with `last`, and (with `sharp`) their sharp features.
/// Returns the bytes and the counts of the last two levels.
fn levels(
    scheme: Scheme,
    k0: Counts,
    levels: u32,
    inner: Kept,
    last: Kept,
    sharp: bool,
) -> (u128, Counts, Counts) {
    let (mut k, mut prev) = (k0, k0);
    let mut bytes = 0u128;
    for l in 0..=levels {
        let kept = if l == levels { last } else { inner };
        bytes = bytes.saturating_add(topology(k, kept));
        if sharp {
            bytes = bytes.saturating_add(k.s.saturating_mul(SHARP_EDGE));
        }
        if l < levels {
            prev = k;
            k = k.next(scheme);
        }
    }
    (bytes, prev, k)
}

/// The estimated peak, in bytes, of refining a control level with counts `k0` (`mixed`:
/// faces of several sizes, which keep offsets and a face per corner) with `options`,
/// interpolating positions and what `parts` adds.
pub(crate) fn peak(options: &RefineOptions, k0: Counts, mixed: bool, parts: &PeakParts) -> u128 {
    let m = u128::saturating_mul;
    let scheme = options.scheme;
    let last = if options.full_last_level || options.levels == 0 { Kept::Full } else { Kept::Faces };
    let (mut topo, prev, fine) = levels(scheme, k0, options.levels, Kept::Full, last, true);
    // Level 0: its edge arrays grow by doubling while they are built, and mixed faces
    // keep offsets and the face of every corner.
    topo = topo.saturating_add(m(16, k0.e));
    if mixed {
        topo = topo.saturating_add(m(4, k0.c)).saturating_add(m(4, k0.f));
    }
    // Interpolating positions: the control copy and the last two levels' values.
    let interpolation = m(12, k0.v).saturating_add(m(12, prev.v)).saturating_add(m(12, fine.v));
    if !parts.output {
        return topo.saturating_add(interpolation);
    }
    let positions = m(12, fine.v);
    // Limit normals (one value per vertex, more on creases) and their indices, and the
    // new positions while the old ones are alive.
    let (normals, limit) =
        if parts.limit { (m(24, fine.v).saturating_add(m(4, fine.c)), m(12, fine.v)) } else { (0, 0) };
    let mesh = m(4, fine.c).saturating_add(m(4, fine.f.saturating_add(1))).saturating_add(m(12, fine.s));
    let control_faces = m(4, fine.f);
    // The UV channel: its levels and the values being interpolated, then its finest
    // values and indices (the levels are dropped before the control faces are made).
    let (uv_build, uv_out) = match parts.uvs {
        None => (0, 0),
        Some((u0, interpolation)) => {
            let linear = interpolation == FvarInterpolation::Linear;
            let inner = if linear { Kept::Edges } else { Kept::Full };
            let (bytes, uprev, ufine) = levels(scheme, u0, options.levels, inner, Kept::Faces, !linear);
            // Level 0's growing edge arrays, and the union–find, ids and pinning flags
            // that build its vertices.
            let bytes =
                bytes.saturating_add(m(16, u0.e)).saturating_add(m(20, u0.c)).saturating_add(m(8, u0.v));
            let values = m(8, uprev.v).saturating_add(m(8, ufine.v)).saturating_add(m(8, u0.v));
            let out = m(8, ufine.v).saturating_add(m(4, ufine.c));
            (bytes.saturating_add(values.max(out)), out)
        }
    };
    let during_interpolation = topo.saturating_add(interpolation);
    let during_limit = topo.saturating_add(positions).saturating_add(normals).saturating_add(limit);
    let at_end = topo
        .saturating_add(positions)
        .saturating_add(normals)
        .saturating_add(mesh)
        .saturating_add(uv_build.max(uv_out.saturating_add(control_faces)));
    let peak = during_interpolation.max(during_limit).max(at_end);
    // What is not counted above (allocator rounding, the control mesh's transients,
    // small per-vertex lists): a sixteenth more.
    peak.saturating_add(peak / 16)
}
