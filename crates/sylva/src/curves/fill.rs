//! Space-filling magnetic curves: an occupancy grid, the parent-cell rule and the
//! `(T, α)` ladder of retries, inside a bounded region (Xu2015 §7.2.4, Figs. 7.4,
//! 7.5, 7.7; Xu2015-spec §3.5).
//!
//! # The algorithm
//!
//! The region's bounding box is divided into square cells, all [`EMPTY`] at first.
//! Particles are released one at a time, the roots first, then from points at equal
//! arc-length spacing along every placed curve, generation by generation and, within a
//! generation, every curve's k-th release point before any curve's (k+1)-th (so the
//! largest curves come first, siblings grow evenly, and small ones fill the gaps). Each release point
//! tries the ladder `(T₁, α₁) > (T₂, α₂) > …` with `q(t) = k·(T − t)^−α` and a random
//! charge sign; the first rung whose curve completes is kept; when every rung fails
//! the position is abandoned.
//!
//! Every step of a particle is rasterized into all the cells its segment passes
//! through (a supercover traversal, so two segments that cross always share a cell).
//! For each such cell:
//!
//! - `EMPTY`: the particle claims it;
//! - its **parent**'s: allowed while the particle is peeling off the parent — during
//!   its first `peel` units of arc from the release point; afterwards touching the
//!   parent again is a crossing (the seed allows parent cells everywhere, which lets a
//!   child cross its parent far from the release point; Xu2015-spec §8 item 21 forbids
//!   that). The allowance is counted from the release, not from the last parent cell
//!   touched: a child running alongside its parent touches its cells every step and
//!   would otherwise never count as peeled off (it crossed its parent 26–58 units past
//!   the release in `curves-space-filling` and `curves-perlin`, issue 26); such a child
//!   now fails its rung and the next one is tried. The cell also records the one child that peeled through it: a sibling
//!   entering it is a crossing (two children running along their parent would
//!   otherwise cross each other unseen inside the parent's cells);
//! - its **own**, claimed within the last `recent` steps: allowed (a step often stays in
//!   its cell); claimed earlier: the curve has come back to itself (a spiral's centre),
//!   so it **stops** there, keeping what it drew;
//! - anyone else's: a **crossing**: every cell this attempt claimed is released (the
//!   grid is restored exactly) and the next rung is tried.
//!
//! A particle also stops, keeping its curve, before a step that would leave the region,
//! and before its radius of curvature falls below `min_radius` (spiral tips cannot
//! tighten below the grid's resolution, Xu2015-spec §3.5). A curve shorter than
//! `min_length` counts as a failed rung.
//!
//! Guarantees (tested in `tests/curves.rs`): no cell is traversed by two curves unless
//! one is the other's parent; the grid equals the one rebuilt from the placed curves
//! alone (failed attempts leave no marks); every point lies in the region.
//!
//! Cost: O(steps) for the traces plus O(cells touched); no allocation per step.

use crate::error::{Error, Result};
use glam::DVec2;
use rand::RngExt;
use rand_pcg::Pcg64;
use std::cmp::Reverse;
use std::collections::BinaryHeap;

use super::magnetic::{
    trace_with, Budget, Charge, Control, End, Field, Integrator, Particle, Profile, Signs, Trace,
    TraceOptions,
};

/// Release candidates: (parent generation, ordinal along the parent, parent curve,
/// point index), smallest first.
type Queue = BinaryHeap<Reverse<(u32, u32, usize, usize)>>;

/// The owner value of an unclaimed cell.
pub const EMPTY: u32 = u32::MAX;

/// Most cells an occupancy grid may have.
pub const MAX_CELLS: usize = 1 << 24;

/// A bounded region of the plane.
#[derive(Debug, Clone, PartialEq)]
pub enum Region {
    /// An axis-aligned rectangle (closed).
    Rect {
        /// Lower-left corner.
        min: DVec2,
        /// Upper-right corner.
        max: DVec2,
    },
    /// An axis-aligned ellipse (closed).
    Ellipse {
        /// Centre.
        center: DVec2,
        /// Semi-axes (x, y), positive.
        radii: DVec2,
    },
    /// A simple polygon (even-odd rule).
    Polygon(Vec<DVec2>),
}

impl Region {
    /// Whether `p` lies in the region.
    pub fn contains(&self, p: DVec2) -> bool {
        match self {
            Region::Rect { min, max } => p.x >= min.x && p.y >= min.y && p.x <= max.x && p.y <= max.y,
            Region::Ellipse { center, radii } => ((p - *center) / *radii).length_squared() <= 1.0,
            Region::Polygon(pts) => {
                let mut inside = false;
                let n = pts.len();
                for i in 0..n {
                    let (a, b) = (pts[i], pts[(i + n - 1) % n]);
                    if (a.y > p.y) != (b.y > p.y) && p.x < (b.x - a.x) * (p.y - a.y) / (b.y - a.y) + a.x {
                        inside = !inside;
                    }
                }
                inside
            }
        }
    }

    /// The bounding box `(min, max)`.
    pub fn bounds(&self) -> (DVec2, DVec2) {
        match self {
            Region::Rect { min, max } => (*min, *max),
            Region::Ellipse { center, radii } => (*center - *radii, *center + *radii),
            Region::Polygon(pts) => bounding_box(pts),
        }
    }

    /// Checks finiteness and non-degeneracy; `what` names the region in messages.
    pub fn validate(&self, what: &str) -> Result<()> {
        let bad = |why: &str| Err(Error::Recipe(format!("{what}: {why}")));
        match self {
            Region::Rect { min, max } => {
                if !(min.is_finite() && max.is_finite() && max.x > min.x && max.y > min.y) {
                    return bad("a rectangle needs finite corners with max > min");
                }
            }
            Region::Ellipse { center, radii } => {
                if !(center.is_finite() && radii.is_finite() && radii.x > 0.0 && radii.y > 0.0) {
                    return bad("an ellipse needs a finite centre and positive radii");
                }
            }
            Region::Polygon(pts) => {
                if pts.len() < 3 || pts.iter().any(|p| !p.is_finite()) {
                    return bad("a polygon needs at least 3 finite points");
                }
            }
        }
        Ok(())
    }

    /// The region mirrored about the vertical line `x = axis`.
    pub fn mirrored(&self, axis: f64) -> Region {
        let m = |p: DVec2| DVec2::new(2.0 * axis - p.x, p.y);
        match self {
            Region::Rect { min, max } => Region::Rect {
                min: DVec2::new(2.0 * axis - max.x, min.y),
                max: DVec2::new(2.0 * axis - min.x, max.y),
            },
            Region::Ellipse { center, radii } => Region::Ellipse { center: m(*center), radii: *radii },
            Region::Polygon(pts) => Region::Polygon(pts.iter().map(|p| m(*p)).collect()),
        }
    }
}

/// The bounding box `(min, max)` of points (`(+∞, −∞)` for none).
pub(crate) fn bounding_box<'a>(pts: impl IntoIterator<Item = &'a DVec2>) -> (DVec2, DVec2) {
    let mut lo = DVec2::splat(f64::INFINITY);
    let mut hi = DVec2::splat(f64::NEG_INFINITY);
    for p in pts {
        lo = lo.min(*p);
        hi = hi.max(*p);
    }
    (lo, hi)
}

/// A grid of square cells, each [`EMPTY`] or holding the id of the particle that
/// claimed it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Occupancy {
    origin: (u64, u64),
    cell_bits: u64,
    nx: usize,
    ny: usize,
    owner: Vec<u32>,
    /// Step index at which the owner claimed the cell.
    stamp: Vec<u32>,
    /// For a claimed cell, the one child that has peeled off its owner through it.
    peeler: Vec<u32>,
}

impl Occupancy {
    /// A grid of `cell`-sized squares covering `[min, max]` (one spare cell around).
    /// Fails when `cell` is not positive or the grid would exceed [`MAX_CELLS`].
    pub fn new(min: DVec2, max: DVec2, cell: f64) -> Result<Self> {
        if !(cell.is_finite() && cell > 0.0 && min.is_finite() && max.is_finite()) {
            return Err(Error::Recipe(format!("fill: cell = {cell} must be a positive number")));
        }
        let o = min - DVec2::splat(cell);
        let nx = ((max.x - o.x) / cell).ceil() + 2.0;
        let ny = ((max.y - o.y) / cell).ceil() + 2.0;
        // NaN sizes fail this test too.
        if nx * ny > MAX_CELLS as f64 || nx.is_nan() || ny.is_nan() {
            return Err(Error::Recipe(format!(
                "fill: the occupancy grid would have {:.0} cells (limit {MAX_CELLS}); raise `cell`",
                nx * ny
            )));
        }
        let (nx, ny) = (nx as usize, ny as usize);
        Ok(Occupancy {
            origin: (o.x.to_bits(), o.y.to_bits()),
            cell_bits: cell.to_bits(),
            nx,
            ny,
            owner: vec![EMPTY; nx * ny],
            stamp: vec![0; nx * ny],
            peeler: vec![EMPTY; nx * ny],
        })
    }

    /// The grid's lower-left corner.
    pub fn origin(&self) -> DVec2 {
        DVec2::new(f64::from_bits(self.origin.0), f64::from_bits(self.origin.1))
    }

    /// The cell size.
    pub fn cell(&self) -> f64 {
        f64::from_bits(self.cell_bits)
    }

    /// Grid size in cells `(nx, ny)`.
    pub fn size(&self) -> (usize, usize) {
        (self.nx, self.ny)
    }

    /// The owner of every cell, row by row.
    pub fn owners(&self) -> &[u32] {
        &self.owner
    }

    /// The owner of cell `i`.
    pub fn owner(&self, i: usize) -> u32 {
        self.owner.get(i).copied().unwrap_or(EMPTY)
    }

    /// The child that peeled off its parent through cell `i` (the cell's owner), or
    /// [`EMPTY`].
    pub fn peeler(&self, i: usize) -> u32 {
        self.peeler.get(i).copied().unwrap_or(EMPTY)
    }

    /// The peeler of every cell, row by row.
    pub fn peelers(&self) -> &[u32] {
        &self.peeler
    }

    /// Claims cell `i` for `id` at step `step` if it is empty; returns whether it did.
    pub fn claim(&mut self, i: usize, id: u32, step: u32) -> bool {
        match self.owner.get_mut(i) {
            Some(o) if *o == EMPTY => {
                *o = id;
                self.stamp[i] = step;
                true
            }
            _ => false,
        }
    }

    /// Appends to `out` every cell the segment `a → b` passes through (Amanatides–Woo
    /// traversal, clipped to the grid), `a`'s cell first.
    pub fn segment_cells(&self, a: DVec2, b: DVec2, out: &mut Vec<usize>) {
        let cell = self.cell();
        let o = self.origin();
        let pa = (a - o) / cell;
        let pb = (b - o) / cell;
        if !pa.is_finite() || !pb.is_finite() {
            return;
        }
        let (mut ix, mut iy) = (pa.x.floor() as i64, pa.y.floor() as i64);
        let (ex, ey) = (pb.x.floor() as i64, pb.y.floor() as i64);
        let d = pb - pa;
        let (step_x, t_delta_x, mut t_max_x) = traversal_axis(pa.x, ix, d.x);
        let (step_y, t_delta_y, mut t_max_y) = traversal_axis(pa.y, iy, d.y);
        let mut push = |ix: i64, iy: i64| {
            if ix >= 0 && iy >= 0 && (ix as usize) < self.nx && (iy as usize) < self.ny {
                out.push(iy as usize * self.nx + ix as usize);
            }
        };
        push(ix, iy);
        // The number of cell crossings is |Δix| + |Δiy|; bound the loop by it.
        let n = (ex - ix).unsigned_abs() + (ey - iy).unsigned_abs();
        for _ in 0..n.min(1 << 20) {
            if t_max_x < t_max_y {
                ix += step_x;
                t_max_x += t_delta_x;
            } else {
                iy += step_y;
                t_max_y += t_delta_y;
            }
            push(ix, iy);
        }
    }
}

/// One axis of [`Occupancy::segment_cells`]'s traversal, for a segment starting at
/// grid coordinate `p` (in cell `i`) and moving `d` cells along the axis: the cell step
/// (±1), the segment parameter one cell spans, and the parameter of the first cell
/// boundary crossed (∞ when the segment does not move along the axis).
fn traversal_axis(p: f64, i: i64, d: f64) -> (i64, f64, f64) {
    let step = if d > 0.0 { 1 } else { -1 };
    let span = if d != 0.0 { (1.0 / d).abs() } else { f64::INFINITY };
    let first = if d > 0.0 {
        ((i + 1) as f64 - p) / d
    } else if d < 0.0 {
        (i as f64 - p) / d
    } else {
        f64::INFINITY
    };
    (step, span, first)
}

/// A root particle of a space filling.
#[derive(Debug, Clone, PartialEq)]
pub struct Root {
    /// Start position (inside the region).
    pub position: DVec2,
    /// Start direction (any length; the fill's speed is used).
    pub direction: DVec2,
    /// Its own charge and duration; `None` climbs the ladder like any other release.
    pub charge: Option<(Charge, f64)>,
}

/// Parameters of [`space_fill`].
#[derive(Debug, Clone, PartialEq)]
pub struct FillParams {
    /// The `(T, α)` ladder, largest first (§7.2.4: the diagonal of Fig. 7.3).
    pub ladder: Vec<(f64, f64)>,
    /// Charge scale k in `q = k·(T − t)^−α`.
    pub k: f64,
    /// Particle speed.
    pub speed: f64,
    /// Particle mass.
    pub mass: f64,
    /// Arc length between release points along a placed curve.
    pub release_every: f64,
    /// Arc length at the start of each curve with no release point.
    pub release_skip: f64,
    /// Release points must lie here (default: anywhere in the region). The Klimt tree
    /// releases only in the top ¾ of the image (§7.3).
    pub release_region: Option<Region>,
    /// Every curve stays inside this region.
    pub region: Region,
    /// Occupancy cell size (about 1–2 steps).
    pub cell: f64,
    /// Own cells claimed within this many steps may be re-entered.
    pub recent: u32,
    /// Arc length from its release point during which a child may touch its parent's
    /// cells (peeling off); touching them later is a crossing.
    pub peel: f64,
    /// Stop a particle when its radius of curvature falls below this.
    pub min_radius: f64,
    /// Curves shorter than this count as failed rungs.
    pub min_length: f64,
    /// Stop after placing this many curves.
    pub max_curves: usize,
    /// Sign rule for released particles: random (the seed), alternating, or split (try
    /// a random sign, then the other one, before giving a rung up).
    pub signs: Signs,
    /// Integration step and integrator.
    pub dt: f64,
    /// The integrator.
    pub integrator: Integrator,
}

impl Default for FillParams {
    fn default() -> Self {
        FillParams {
            ladder: vec![(650.0, 0.8), (450.0, 0.75), (250.0, 0.7), (50.0, 0.65)],
            k: 1.0,
            speed: 1.0,
            mass: 1.0,
            release_every: 25.0,
            release_skip: 10.0,
            release_region: None,
            region: Region::Rect { min: DVec2::ZERO, max: DVec2::new(800.0, 600.0) },
            cell: 2.0,
            recent: 8,
            peel: 12.0,
            min_radius: 3.0,
            min_length: 8.0,
            max_curves: 10_000,
            signs: Signs::Random,
            dt: 1.0,
            integrator: Integrator::Exact,
        }
    }
}

/// One placed curve.
#[derive(Debug, Clone, PartialEq)]
pub struct FillCurve {
    /// The curve.
    pub trace: Trace,
    /// `(parent curve index, point index on the parent)`; `None` for roots.
    pub parent: Option<(usize, usize)>,
    /// Generation (0 for roots).
    pub depth: u32,
    /// Ladder rung used (0 = largest); `usize::MAX` for a root with its own charge.
    pub rung: usize,
    /// Charge sign.
    pub sign: f64,
}

/// What happened to one attempt.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    /// Placed as this curve index.
    Placed(usize),
    /// It crossed another curve and was erased.
    Crossed,
    /// It ended shorter than `min_length` and was erased.
    TooShort,
}

/// A record of one attempt (for tests and statistics).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Attempt {
    /// Parent curve index, `None` for roots.
    pub parent: Option<usize>,
    /// Release position.
    pub position: DVec2,
    /// Ladder rung (`usize::MAX` for a root's own charge).
    pub rung: usize,
    /// Charge sign.
    pub sign: f64,
    /// What happened.
    pub outcome: Outcome,
}

/// The result of [`space_fill`].
#[derive(Debug, Clone, PartialEq)]
pub struct FillResult {
    /// Placed curves; curve `i` owns the cells marked `i` in the grid. Parents come
    /// before their children.
    pub curves: Vec<FillCurve>,
    /// The final occupancy grid.
    pub grid: Occupancy,
    /// Every attempt, in order.
    pub attempts: Vec<Attempt>,
    /// Release positions abandoned after the last rung failed.
    pub abandoned: usize,
}

impl FillParams {
    /// Checks every number; `what` names the fill in messages.
    pub fn validate(&self, what: &str) -> Result<()> {
        let bad = |why: String| Err(Error::Recipe(format!("{what}: {why}")));
        if self.ladder.is_empty() {
            return bad("the (T, α) ladder is empty".into());
        }
        for (t, a) in &self.ladder {
            if !(t.is_finite() && *t > 0.0 && a.is_finite()) {
                return bad(format!("ladder rung ({t}, {a}) needs T > 0 and a finite α"));
            }
        }
        // (key, value, whether 0 is allowed): the rest must be positive.
        let limits = [
            ("k", self.k, false),
            ("speed", self.speed, false),
            ("mass", self.mass, false),
            ("release_every", self.release_every, false),
            ("cell", self.cell, false),
            ("dt", self.dt, false),
            ("release_skip", self.release_skip, true),
            ("peel", self.peel, true),
            ("min_radius", self.min_radius, true),
            ("min_length", self.min_length, true),
        ];
        for (name, v, zero_allowed) in limits {
            let (ok, must) =
                if zero_allowed { (v >= 0.0, "be ≥ 0") } else { (v > 0.0, "be a positive number") };
            if !(v.is_finite() && ok) {
                return bad(format!("`{name}` = {v} must {must}"));
            }
        }
        self.region.validate(&format!("{what}: region"))?;
        if let Some(r) = &self.release_region {
            r.validate(&format!("{what}: release_region"))?;
        }
        Ok(())
    }
}

/// Per-attempt scratch state of the grid visitor.
struct Walker<'a> {
    grid: &'a mut Occupancy,
    region: &'a Region,
    id: u32,
    parent: u32,
    recent: u32,
    peel: f64,
    claimed: Vec<usize>,
    peeled: Vec<usize>,
    cells: Vec<usize>,
    /// Arc length drawn so far (the parent's cells are allowed while it is ≤ `peel`).
    travelled: f64,
    step: u32,
}

impl Walker<'_> {
    /// Undoes every mark of this attempt: the grid is as it was before.
    fn erase(&mut self) {
        for &c in &self.claimed {
            self.grid.owner[c] = EMPTY;
        }
        for &c in &self.peeled {
            self.grid.peeler[c] = EMPTY;
        }
    }

    fn visit(&mut self, from: DVec2, to: DVec2) -> Control {
        if !self.region.contains(to) {
            return Control::Stop;
        }
        self.cells.clear();
        self.grid.segment_cells(from, to, &mut self.cells);
        let step = self.step + 1;
        for &c in &self.cells {
            let o = self.grid.owner[c];
            if o == EMPTY {
                continue;
            }
            if o == self.id {
                if step.saturating_sub(self.grid.stamp[c]) > self.recent {
                    return Control::Stop;
                }
            } else if o == self.parent && self.parent != EMPTY {
                let p = self.grid.peeler[c];
                if self.travelled > self.peel || (p != EMPTY && p != self.id) {
                    return Control::Abort;
                }
            } else {
                return Control::Abort;
            }
        }
        for &c in &self.cells {
            if self.grid.claim(c, self.id, step) {
                self.claimed.push(c);
            } else if self.grid.owner[c] == self.parent && self.grid.peeler[c] == EMPTY {
                self.grid.peeler[c] = self.id;
                self.peeled.push(c);
            }
        }
        self.travelled += from.distance(to);
        self.step = step;
        Control::Continue
    }
}

/// Fills `params.region` with non-crossing magnetic curves grown from `roots` (see the
/// module docs). `field` is the magnetic field; random signs come from `rng`; every
/// integration step is charged to `budget`.
pub fn space_fill(
    roots: &[Root],
    params: &FillParams,
    field: &Field,
    rng: &mut Pcg64,
    budget: &mut Budget,
) -> Result<FillResult> {
    params.validate("fill")?;
    let (lo, hi) = params.region.bounds();
    let mut grid = Occupancy::new(lo, hi, params.cell)?;
    let opts = TraceOptions { dt: params.dt, integrator: params.integrator, min_radius: params.min_radius };
    let mut curves: Vec<FillCurve> = Vec::new();
    let mut attempts = Vec::new();
    let mut abandoned = 0;
    // Release candidates, taken in order of (generation, ordinal along the parent,
    // parent index): every curve's first release point before any curve's second, so
    // sibling curves grow evenly and the largest curves still come first.
    let mut queue = Queue::new();
    let mut alternate = false;

    // One attempt: trace with the grid visitor; on failure restore the grid.
    let attempt = |grid: &mut Occupancy,
                   particle: &Particle,
                   parent: Option<usize>,
                   budget: &mut Budget,
                   id: u32|
     -> Result<(Option<Trace>, Outcome)> {
        let mut w = Walker {
            grid,
            region: &params.region,
            id,
            parent: parent.map_or(EMPTY, |p| p as u32),
            recent: params.recent,
            peel: params.peel,
            claimed: Vec::new(),
            peeled: Vec::new(),
            cells: Vec::with_capacity(8),
            travelled: 0.0,
            step: 0,
        };
        // The start point's own cell: claim it (or accept the parent's).
        let mut cells = Vec::new();
        w.grid.segment_cells(particle.position, particle.position, &mut cells);
        for &c in &cells {
            let o = w.grid.owner[c];
            let p = w.grid.peeler[c];
            if o != EMPTY && (o != w.parent || (p != EMPTY && p != id)) {
                return Ok((None, Outcome::Crossed));
            }
        }
        for &c in &cells {
            if w.grid.claim(c, id, 0) {
                w.claimed.push(c);
            } else if w.grid.peeler[c] == EMPTY {
                w.grid.peeler[c] = id;
                w.peeled.push(c);
            }
        }
        let tr = trace_with(particle, field, &opts, budget, id as u64, |s| w.visit(s.from, s.to));
        let tr = match tr {
            Ok(t) => t,
            Err(e) => {
                w.erase();
                return Err(e);
            }
        };
        let outcome = if tr.end == End::Aborted {
            Outcome::Crossed
        } else if tr.length() < params.min_length {
            Outcome::TooShort
        } else {
            return Ok((Some(tr), Outcome::Placed(id as usize)));
        };
        w.erase();
        Ok((None, outcome))
    };

    let ladder_particle = |position: DVec2, direction: DVec2, rung: usize, sign: f64| {
        let (t_end, alpha) = params.ladder[rung];
        Particle {
            position,
            velocity: direction.normalize_or(DVec2::Y) * params.speed,
            mass: params.mass,
            charge: Charge::new(Profile::Spiral { t_end, alpha }, params.k * sign),
            duration: t_end,
        }
    };

    let mut pick_signs = |rng: &mut Pcg64| -> Vec<f64> {
        match params.signs {
            Signs::Random => vec![if rng.random::<f64>() < 0.5 { 1.0 } else { -1.0 }],
            Signs::Alternate => {
                alternate = !alternate;
                vec![if alternate { 1.0 } else { -1.0 }]
            }
            Signs::Split => {
                let s = if rng.random::<f64>() < 0.5 { 1.0 } else { -1.0 };
                vec![s, -s]
            }
        }
    };

    let enqueue = |queue: &mut Queue, idx: usize, depth: u32, tr: &Trace| {
        let mut s = 0.0;
        let mut ordinal = 0u32;
        let total = tr.length();
        let mut next = params.release_skip;
        for i in 1..tr.points.len() {
            s += tr.points[i - 1].distance(tr.points[i]);
            if s >= next {
                next += params.release_every;
                if s > total - 0.5 * params.release_every {
                    break;
                }
                let p = tr.points[i];
                if params.release_region.as_ref().is_none_or(|r| r.contains(p)) {
                    queue.push(Reverse((depth, ordinal, idx, i)));
                    ordinal += 1;
                }
            }
        }
    };

    let mut try_position = |grid: &mut Occupancy,
                            curves: &mut Vec<FillCurve>,
                            attempts: &mut Vec<Attempt>,
                            queue: &mut Queue,
                            rng: &mut Pcg64,
                            budget: &mut Budget,
                            position: DVec2,
                            direction: DVec2,
                            parent: Option<(usize, usize)>,
                            own: Option<&(Charge, f64)>|
     -> Result<bool> {
        let id = curves.len() as u32;
        let depth = parent.map_or(0, |(p, _)| curves[p].depth + 1);
        if let Some((charge, duration)) = own {
            let particle = Particle {
                position,
                velocity: direction.normalize_or(DVec2::Y) * params.speed,
                mass: params.mass,
                charge: charge.clone(),
                duration: *duration,
            };
            let (tr, outcome) = attempt(grid, &particle, parent.map(|p| p.0), budget, id)?;
            attempts.push(Attempt {
                parent: parent.map(|p| p.0),
                position,
                rung: usize::MAX,
                sign: charge.scale.signum(),
                outcome,
            });
            if let Some(tr) = tr {
                enqueue(queue, curves.len(), depth, &tr);
                curves.push(FillCurve {
                    trace: tr,
                    parent,
                    depth,
                    rung: usize::MAX,
                    sign: charge.scale.signum(),
                });
                return Ok(true);
            }
            return Ok(false);
        }
        let signs = pick_signs(rng);
        for rung in 0..params.ladder.len() {
            for &sign in &signs {
                let particle = ladder_particle(position, direction, rung, sign);
                let (tr, outcome) = attempt(grid, &particle, parent.map(|p| p.0), budget, id)?;
                attempts.push(Attempt { parent: parent.map(|p| p.0), position, rung, sign, outcome });
                if let Some(tr) = tr {
                    enqueue(queue, curves.len(), depth, &tr);
                    curves.push(FillCurve { trace: tr, parent, depth, rung, sign });
                    return Ok(true);
                }
            }
        }
        Ok(false)
    };

    // The roots first, in order, then the release points, smallest generation first.
    let mut roots = roots.iter().enumerate();
    while curves.len() < params.max_curves {
        let (position, direction, parent, own) = if let Some((r, root)) = roots.next() {
            if !(root.position.is_finite() && root.direction.is_finite()) {
                return Err(Error::Recipe(format!("fill: root {} has a non-finite start", r + 1)));
            }
            if !params.region.contains(root.position) {
                return Err(Error::Recipe(format!(
                    "fill: root {} starts at ({}, {}), outside the region",
                    r + 1,
                    root.position.x,
                    root.position.y
                )));
            }
            (root.position, root.direction, None, root.charge.as_ref())
        } else if let Some(Reverse((_, _, p, i))) = queue.pop() {
            let tr = &curves[p].trace;
            (tr.points[i], tr.velocities[i], Some((p, i)), None)
        } else {
            break;
        };
        let placed = try_position(
            &mut grid,
            &mut curves,
            &mut attempts,
            &mut queue,
            rng,
            budget,
            position,
            direction,
            parent,
            own,
        )?;
        if !placed {
            abandoned += 1;
        }
    }
    Ok(FillResult { curves, grid, attempts, abandoned })
}
