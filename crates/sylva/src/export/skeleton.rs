//! Skeleton files: LST (Pieterse2012 §4.1.5, Table 4.2) and sylva's JSON skeleton.
//!
//! - [`to_lst`] writes an LST file that [`crate::import::lst::parse`] reads back to the
//!   same skeleton (positions and radii within 1e-6 relative, same parents). It replays
//!   the reader's turtle while writing, so rounding never accumulates along a branch.
//!   Each internode's start radius ([`Skeleton::start_radius()`]) is its cylinder's r0
//!   and reads back exactly; where the skeleton has none, r0 is the parent node's
//!   radius, which reads back as an explicit start radius (the reader records every
//!   cylinder's r0). A root's radius is read back from its first cylinder's r0.
//! - [`to_json`] / [`from_json`] are an exact round trip of every field, organs and
//!   start radii included (`docs/formats.md` documents the format), so LST → JSON →
//!   read keeps every cylinder's r0.
//! - [`write()`] chooses the format from the file extension and writes atomically.
//!
//! What LST cannot hold: materials, organs and the exact `up` reference (an imported
//! node's `up` is the written frame's X axis: the original `up` made perpendicular to
//! the internode). Branch order comes back as the `SB()` nesting depth. Nodes are
//! written depth first (children in index order, each child's subtree before the next
//! child), which is the order every sylva generator produces; a skeleton in another
//! parent-first order reads back with its nodes renumbered into that order. Roots
//! without children are not written (an LST cylinder always has two ends). A forest
//! (several roots) is written root after root and must be read with
//! [`GapPolicy::NewRoot`](crate::import::lst::GapPolicy::NewRoot); two roots at the same
//! place read back as one.

use crate::error::{Error, Result};
use crate::fsutil::write_atomic;
use crate::import::lst::{perpendicular, Turtle};
pub use crate::import::skel_json::{from_json, from_json_named, JSON_FORMAT, JSON_VERSION};
use crate::import::skel_json::{JsonNode, JsonOrgan};
use crate::skeleton::{Organ, OrganKind, Skeleton, NO_PARENT};
use glam::{DMat3, DQuat, DVec3, Vec3};
use std::fmt::Write as _;
use std::path::Path;

/// The extensions [`write()`] understands, for error messages.
pub const EXTENSIONS: &str = ".lst, .json (.skel.json)";

/// Writes `skeleton` to `path` as LST (`.lst`) or JSON (`.json`, conventionally
/// `.skel.json`), atomically. The skeleton is validated first ([`Error::Skeleton`]);
/// any other extension is [`Error::UnknownFormat`].
pub fn write(skeleton: &Skeleton, path: &Path) -> Result<()> {
    let text = to_text(skeleton, path)?;
    write_atomic(path, |w| w.write_all(text.as_bytes()))
}

/// [`write()`], staged into `set` (written to a temporary that reaches `path` when the
/// set is committed with the run's other outputs, [`crate::fsutil::OutputSet`]).
pub fn stage(skeleton: &Skeleton, path: &Path, set: &mut crate::fsutil::OutputSet) -> Result<()> {
    let text = to_text(skeleton, path)?;
    set.stage(path, |w| w.write_all(text.as_bytes()))
}

/// The validated skeleton as the text of the format `path`'s extension names.
fn to_text(skeleton: &Skeleton, path: &Path) -> Result<String> {
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
    match ext.as_str() {
        "lst" => {
            skeleton.validate()?;
            Ok(to_lst(skeleton))
        }
        "json" => {
            skeleton.validate()?;
            Ok(to_json(skeleton))
        }
        _ => Err(Error::UnknownFormat { path: path.to_path_buf(), expected: EXTENSIONS }),
    }
}

// ---------------------------------------------------------------------------------
// LST

/// The skeleton as an LST file (see the [module docs](self) for what LST keeps).
///
/// Each internode is one line, `RotRel3f(angle, x, y, z) Cylinder(r0, r1, length)
/// MovRel3f(0, length, 0)` (the rotation is left out when the direction does not
/// change), with r0 the internode's start radius ([`Skeleton::start_radius()`]), or the
/// parent node's radius where it has none; a child that is not its parent's last,
/// or whose order differs from its parent's, is wrapped in `SB()` … `EB()`. A root is
/// reached with `MovRel3f(x, y, z)` from the origin. Numbers are printed so that they
/// read back exactly (Rust's shortest round-trip form).
///
/// The skeleton should be valid ([`Skeleton::validate`]); nodes whose parent does not
/// come before them are treated as roots, and nothing panics on invalid input.
pub fn to_lst(skeleton: &Skeleton) -> String {
    let sk = skeleton;
    let n = [sk.position.len(), sk.radius.len(), sk.parent.len(), sk.up.len(), sk.order.len()]
        .into_iter()
        .min()
        .unwrap_or(0);
    // Child lists (CSR) over valid parent links only.
    let parent_of = |i: usize| {
        let p = sk.parent[i];
        if p != NO_PARENT && (p as usize) < i {
            Some(p as usize)
        } else {
            None
        }
    };
    let mut offsets = vec![0usize; n + 1];
    for i in 0..n {
        if let Some(p) = parent_of(i) {
            offsets[p + 1] += 1;
        }
    }
    for i in 0..n {
        offsets[i + 1] += offsets[i];
    }
    let mut fill = offsets.clone();
    let mut kids = vec![0u32; offsets[n]];
    for i in 0..n {
        if let Some(p) = parent_of(i) {
            kids[fill[p]] = i as u32;
            fill[p] += 1;
        }
    }
    let children = |i: usize| &kids[offsets[i]..offsets[i + 1]];

    let mut w =
        LstWriter { out: String::with_capacity(64 * n + 16), t: Turtle::START, saved: Vec::new(), sk };
    w.out.push_str("LST 0.1\n");
    let roots: Vec<usize> = (0..n).filter(|&i| parent_of(i).is_none() && !children(i).is_empty()).collect();
    let mut tasks: Vec<Task> = Vec::new();
    for (ri, &r) in roots.iter().enumerate() {
        let last_root = ri + 1 == roots.len();
        let ch = children(r);
        for (j, &c) in ch.iter().enumerate() {
            let c = c as usize;
            let wrap = !(last_root && j + 1 == ch.len()) || sk.order[c] != sk.order[r];
            if wrap {
                w.push();
            }
            // The state is the start state here: at the origin, unrotated.
            w.move_to_root(sk.position[r]);
            w.internode(r, c);
            push_children(&mut tasks, children(c), c, sk);
            while let Some(task) = tasks.pop() {
                match task {
                    Task::Enter { node, wrap } => {
                        if wrap {
                            w.push();
                            tasks.push(Task::Exit);
                        }
                        let node = node as usize;
                        w.internode(sk.parent[node] as usize, node);
                        push_children(&mut tasks, children(node), node, sk);
                    }
                    Task::Exit => w.pop(),
                }
            }
            if wrap {
                w.pop();
            }
        }
    }
    w.out
}

/// Work items of the depth-first walk in [`to_lst`] (an explicit stack: trees can be
/// deeper than the call stack).
enum Task {
    /// Write the internode ending at `node` (inside `SB()`…`EB()` when `wrap`), then
    /// its subtree.
    Enter { node: u32, wrap: bool },
    /// Close a branch with `EB()`.
    Exit,
}

/// Pushes the children of `node` so that the first child is taken first. Every child
/// but the last, and any child whose order differs from `node`'s, is wrapped.
fn push_children(tasks: &mut Vec<Task>, kids: &[u32], node: usize, sk: &Skeleton) {
    for (j, &c) in kids.iter().enumerate().rev() {
        let wrap = j + 1 != kids.len() || sk.order[c as usize] != sk.order[node];
        tasks.push(Task::Enter { node: c, wrap });
    }
}

/// Writes LST text while replaying the reader's turtle bit for bit.
struct LstWriter<'a> {
    out: String,
    t: Turtle,
    saved: Vec<Turtle>,
    sk: &'a Skeleton,
}

impl LstWriter<'_> {
    fn push(&mut self) {
        self.out.push_str("SB()\n");
        self.saved.push(self.t);
    }

    fn pop(&mut self) {
        self.out.push_str("EB()\n");
        if let Some(t) = self.saved.pop() {
            self.t = t;
        }
    }

    /// Moves from the start state to a root's position.
    fn move_to_root(&mut self, p: Vec3) {
        if p == Vec3::ZERO {
            return;
        }
        let (x, y, z) = (num32(p.x), num32(p.y), num32(p.z));
        let _ = writeln!(self.out, "MovRel3f({}, {}, {})", x.0, y.0, z.0);
        self.t.mov(x.1, y.1, z.1);
    }

    /// Writes the internode from node `from` (where the turtle stands) to node `to`.
    fn internode(&mut self, from: usize, to: usize) {
        let sk = self.sk;
        // Aim from where the reader's turtle really is, so errors never accumulate.
        let d = sk.position[to].as_dvec3() - self.t.p;
        let len = d.length();
        let len = if len.is_finite() { len } else { 0.0 };
        if len > 0.0 {
            let h = d / len;
            let u = perpendicular(h, [sk.up[to].as_dvec3(), self.t.r.x_axis, self.t.r.z_axis]);
            let target = DMat3::from_cols(u, h, u.cross(h));
            let q = DQuat::from_mat3(&(self.t.r.transpose() * target)).normalize();
            let q = if q.w < 0.0 { -q } else { q };
            let v = DVec3::new(q.x, q.y, q.z);
            let s = v.length();
            if s > 0.0 && s.is_finite() {
                let angle = 2.0 * s.atan2(q.w);
                let axis = v / s;
                let _ = write!(self.out, "RotRel3f({angle}, {}, {}, {}) ", axis.x, axis.y, axis.z);
                let _ = self.t.rot(angle, axis.x, axis.y, axis.z);
            }
        }
        let r0 = sk.start_radius(to).unwrap_or(sk.radius[from]);
        let (r0, r1) = (num32(r0).0, num32(sk.radius[to]).0);
        let _ = write!(self.out, "Cylinder({r0}, {r1}, {len})");
        self.t.current = to as u32;
        if len > 0.0 {
            let _ = write!(self.out, " MovRel3f(0, {len}, 0)");
            self.t.mov(0.0, len, 0.0);
        }
        self.out.push('\n');
    }
}

/// An `f32` in its shortest round-trip form, and the `f64` a reader parses from it.
fn num32(v: f32) -> (String, f64) {
    let s = format!("{v}");
    let back = s.parse::<f64>().unwrap_or(f64::from(v));
    (s, back)
}

// ---------------------------------------------------------------------------------
// JSON

/// The skeleton as a JSON document (`docs/formats.md`): one node, and one organ, per
/// line, every field written (`start_radius` on every node when the skeleton has the
/// column, `null` where a node has none; on none when it has not), numbers in their shortest exact form, so [`from_json`]
/// gives back an identical skeleton. Deterministic.
pub fn to_json(skeleton: &Skeleton) -> String {
    let sk = skeleton;
    let n = sk.position.len();
    let mut out = String::with_capacity(128 * n + 64);
    let _ = writeln!(out, "{{\"format\": {:?}, \"version\": {},", JSON_FORMAT, JSON_VERSION);
    out.push_str("\"nodes\": [");
    for i in 0..n {
        let node = JsonNode {
            position: sk.position[i].to_array(),
            radius: sk.radius.get(i).copied().unwrap_or(0.0),
            start_radius: (!sk.start_radius.is_empty()).then(|| sk.start_radius.get(i).copied().flatten()),
            parent: sk.parent.get(i).copied().filter(|&p| p != NO_PARENT),
            up: Some(sk.up.get(i).copied().unwrap_or(Vec3::X).to_array()),
            order: sk.order.get(i).copied().unwrap_or(0),
            material: sk.material.get(i).copied().unwrap_or(0),
        };
        out.push_str(if i == 0 { "\n  " } else { ",\n  " });
        out.push_str(&serde_json::to_string(&node).unwrap_or_default());
    }
    out.push_str(if n == 0 { "],\n" } else { "\n],\n" });
    out.push_str("\"organs\": [");
    for (k, o) in sk.organs.iter().enumerate() {
        out.push_str(if k == 0 { "\n  " } else { ",\n  " });
        out.push_str(&serde_json::to_string(&organ_to_json(o)).unwrap_or_default());
    }
    out.push_str(if sk.organs.is_empty() { "]}\n" } else { "\n]}\n" });
    out
}

fn organ_to_json(o: &Organ) -> JsonOrgan {
    let (kind, name, vertices) = match &o.kind {
        OrganKind::Leaf => ("leaf", None, None),
        OrganKind::Polygon(v) => ("polygon", None, Some(v.iter().map(|p| p.to_array()).collect())),
        OrganKind::Surface(s) => ("surface", Some(s.clone()), None),
        OrganKind::Sphere => ("sphere", None, None),
        OrganKind::Disc => ("disc", None, None),
        OrganKind::Swept(_) => ("swept", None, None),
    };
    let (rings, closed) = match &o.kind {
        OrganKind::Swept(s) => {
            (Some(s.rings.iter().map(|r| r.iter().map(|p| p.to_array()).collect()).collect()), Some(s.closed))
        }
        _ => (None, None),
    };
    JsonOrgan {
        kind: kind.to_string(),
        name,
        vertices,
        rings,
        closed,
        node: (o.node != NO_PARENT).then_some(o.node),
        position: o.position.to_array(),
        heading: o.heading.to_array(),
        up: o.up.to_array(),
        size: o.size,
        material: o.material,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::import::lst::{self, LstOptions};

    fn fork() -> Skeleton {
        let mut s = Skeleton::new();
        let r = s.push(Vec3::ZERO, 0.3, NO_PARENT, Vec3::X, 0);
        let a = s.push(Vec3::new(0.0, 1.0, 0.0), 0.2, r, Vec3::X, 0);
        s.push(Vec3::new(0.7, 1.6, 0.1), 0.1, a, Vec3::Z, 1);
        s.push(Vec3::new(0.0, 2.0, 0.0), 0.15, a, Vec3::X, 0);
        s
    }

    #[test]
    fn lst_of_a_fork_reads_back() {
        let s = fork();
        let text = to_lst(&s);
        assert!(
            text.starts_with("LST 0.1\nCylinder(0.3, 0.2, 1) MovRel3f(0, 1, 0)\nSB()\nRotRel3f("),
            "{text}"
        );
        let back = lst::parse("t.lst", &text, &LstOptions::default()).unwrap();
        assert_eq!(back.parent, s.parent);
        assert_eq!(back.radius, s.radius);
        assert_eq!(back.order, s.order);
        for i in 0..s.len() {
            assert!((back.position[i] - s.position[i]).length() < 1e-6, "{i}: {text}");
        }
        // The up reference comes back made perpendicular to its internode.
        let h = (s.position[2] - s.position[1]).normalize();
        let want = (Vec3::Z - h * h.dot(Vec3::Z)).normalize();
        assert!((back.up[2] - want).length() < 1e-6, "{} {want}", back.up[2]);
        assert!((back.up[3] - Vec3::X).length() < 1e-6);
    }

    /// Issue 26: read → write → read keeps every cylinder's start and end radius, also
    /// where a cylinder starts thinner or fatter than the node it starts at.
    #[test]
    fn lst_keeps_each_cylinders_start_radius() {
        let text =
            "LST 0.1\nCylinder(0.5, 0.1, 4) MovRel3f(0, 4, 0)\nCylinder(0.3, 0.05, 2) MovRel3f(0, 2, 0)\n\
                    SB() RotRel3f(0.7, 0, 0, 1) Cylinder(0.02, 0.01, 1) MovRel3f(0, 1, 0) EB()\n\
                    Cylinder(0.05, 0.04, 1)\n";
        let radii = |t: &lst::LstTree| -> Vec<(f64, f64)> {
            t.branches.iter().map(|b| (b.start_radius, b.end_radius)).collect()
        };
        let a = lst::parse_tree("a.lst", text, &LstOptions::default()).unwrap();
        assert_eq!(radii(&a), [(0.5, 0.1), (0.3, 0.05), (0.02, 0.01), (0.05, 0.04)]);
        assert_eq!(a.skeleton.start_radius(2), Some(0.3));
        let written = to_lst(&a.skeleton);
        let b = lst::parse_tree("b.lst", &written, &LstOptions::default()).unwrap();
        assert_eq!(b.skeleton.parent, a.skeleton.parent);
        assert_eq!(b.skeleton.radius, a.skeleton.radius);
        assert_eq!(b.skeleton.start_radius, a.skeleton.start_radius, "{written}");
        assert_eq!(radii(&b), radii(&a));
        assert_eq!(to_lst(&b.skeleton), written);
        // Without explicit start radii r0 is the parent node's radius, as before.
        assert!(to_lst(&fork()).contains("Cylinder(0.2, 0.1, "));
    }

    #[test]
    fn json_is_exact() {
        let mut s = fork();
        s.material[2] = 7;
        s.position[1].x = -0.0;
        s.organs.push(Organ {
            kind: OrganKind::Polygon(vec![Vec3::ZERO, Vec3::X, Vec3::new(0.1, 1e-30, 3e38)]),
            node: 2,
            position: Vec3::new(0.1, 0.2, 0.3),
            heading: Vec3::Y,
            up: Vec3::Z,
            size: 0.05,
            material: 3,
        });
        s.organs.push(Organ {
            kind: OrganKind::Surface("l".into()),
            node: NO_PARENT,
            position: Vec3::ONE,
            heading: Vec3::X,
            up: Vec3::Y,
            size: 1.0,
            material: 0,
        });
        let text = to_json(&s);
        let back = from_json(&text).unwrap();
        assert_eq!(back, s);
        assert!(back.position[1].x.is_sign_negative());
        assert_eq!(to_json(&back), text);
        assert_eq!(from_json(&to_json(&Skeleton::new())).unwrap(), Skeleton::new());
    }

    /// Issue 26: start radii go through JSON exactly: the column, its `None`s (`null`)
    /// and a skeleton without it (no `start_radius` at all).
    #[test]
    fn json_keeps_start_radii() {
        let mut s = fork();
        s.set_start_radius(2, Some(0.25));
        s.set_start_radius(3, Some(1e-30));
        let text = to_json(&s);
        assert!(text.contains("\"radius\":0.1,\"start_radius\":0.25,"), "{text}");
        assert!(text.contains("\"start_radius\":null"), "{text}");
        let back = from_json(&text).unwrap();
        assert_eq!(back.start_radius, s.start_radius);
        assert_eq!(back, s);
        assert_eq!(to_json(&back), text);
        // A column of `None`s stays a column.
        let mut none = fork();
        none.set_start_radius(1, None);
        assert_eq!(from_json(&to_json(&none)).unwrap(), none);
        assert!(!to_json(&fork()).contains("start_radius"));
        assert!(from_json(&to_json(&fork())).unwrap().start_radius.is_empty());
    }
}
