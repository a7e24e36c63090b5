//! Reading sylva's JSON skeleton (`.skel.json`, `docs/formats.md`): the document types
//! shared with the writer ([`crate::export::skeleton::to_json`]) and [`from_json`], which
//! locates every syntax, type and invariant error. Seed-independent (sylva's own format).

use super::lst::perpendicular;
use super::{located, nowhere};
use crate::diagnostic::{clip, clip_quoted, quote, QUOTE_CHARS};
use crate::error::{Error, Result};
use crate::lsystem::source::ErrorKind;
use crate::skeleton::{Organ, OrganKind, Skeleton, NO_PARENT};
use glam::{DVec3, Vec3};
use serde::{Deserialize, Serialize};

/// The `format` tag of a JSON skeleton.
pub const JSON_FORMAT: &str = "sylva-skeleton";

/// The JSON skeleton version this sylva writes and reads.
pub const JSON_VERSION: u32 = 1;

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct JsonDoc {
    pub(crate) format: String,
    pub(crate) version: u32,
    pub(crate) nodes: Vec<JsonNode>,
    #[serde(default)]
    pub(crate) organs: Vec<JsonOrgan>,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct JsonNode {
    pub(crate) position: [f32; 3],
    pub(crate) radius: f32,
    /// The explicit start radius of the internode ending at the node (issue 26): a
    /// number, or `null` where the node has none. Absent on every node when the skeleton
    /// has no start-radius column; present (if only as `null`) on every node when it has
    /// one, so the column round-trips exactly.
    #[serde(default, deserialize_with = "present", skip_serializing_if = "Option::is_none")]
    pub(crate) start_radius: Option<Option<f32>>,
    pub(crate) parent: Option<u32>,
    #[serde(default)]
    pub(crate) up: Option<[f32; 3]>,
    #[serde(default)]
    pub(crate) order: u16,
    #[serde(default)]
    pub(crate) material: u32,
}

/// A field that may be `null`: `Some(None)` when it is, so that a `null` is told apart
/// from a field left out (`None`, serde's default).
fn present<'de, D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Option<Option<f32>>, D::Error> {
    Option::<f32>::deserialize(d).map(Some)
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct JsonOrgan {
    pub(crate) kind: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub(crate) name: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub(crate) vertices: Option<Vec<[f32; 3]>>,
    /// A swept surface's rings (kind `swept`, issue 26).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub(crate) rings: Option<Vec<Vec<[f32; 3]>>>,
    /// Whether a swept surface's rings are closed loops.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub(crate) closed: Option<bool>,
    pub(crate) node: Option<u32>,
    pub(crate) position: [f32; 3],
    pub(crate) heading: [f32; 3],
    pub(crate) up: [f32; 3],
    pub(crate) size: f32,
    #[serde(default)]
    pub(crate) material: u32,
}

/// Reads a JSON skeleton written by [`crate::export::skeleton::to_json`] (or by hand: `up`, `order`, `material`,
/// `start_radius` and `organs` may be left out). A skeleton has start radii
/// ([`Skeleton::start_radius()`]) when any node gives `start_radius` (a number or
/// `null`). Syntax and type errors are located
/// (`<json>:line:column: what`); a skeleton that breaks an invariant is
/// [`Error::Skeleton`].
pub fn from_json(text: &str) -> Result<Skeleton> {
    from_json_named("<json>", text)
}

/// [`from_json`] with a file name for the messages.
pub fn from_json_named(name: &str, text: &str) -> Result<Skeleton> {
    from_json_budget(name, text, crate::skeleton::DEFAULT_MAX_NODES)
}

/// [`from_json_named`] with a node budget (`generator.max_nodes`): a skeleton of more
/// than `max_nodes` nodes is an error, checked before any node is built.
pub fn from_json_budget(name: &str, text: &str, max_nodes: usize) -> Result<Skeleton> {
    let mut de = serde_json::Deserializer::from_str(text);
    let doc: JsonDoc = match serde_path_to_error::deserialize(&mut de) {
        Ok(doc) => match de.end() {
            Ok(()) => doc,
            Err(e) => return Err(json_error(name, text, "", &e)),
        },
        Err(e) => return Err(json_error(name, text, &e.path().to_string(), e.inner())),
    };
    let bad = |what: String| -> Error { nowhere(name, text, ErrorKind::Syntax, &what).into() };
    if doc.format != JSON_FORMAT {
        return Err(bad(format!(
            "not a sylva skeleton: format is {:?}, expected {JSON_FORMAT:?}",
            quote(&doc.format)
        )));
    }
    if doc.version != JSON_VERSION {
        return Err(bad(format!(
            "unsupported skeleton version {}: this sylva reads version {JSON_VERSION}",
            doc.version
        )));
    }
    if doc.nodes.len() > max_nodes {
        return Err(bad(format!(
            "{} nodes: more than the skeleton node budget of {} ({})",
            doc.nodes.len(),
            max_nodes,
            crate::skeleton::NODE_BUDGET_HELP
        )));
    }
    let mut sk = Skeleton::new();
    for (i, node) in doc.nodes.iter().enumerate() {
        let parent = match node.parent {
            Some(NO_PARENT) => {
                return Err(bad(format!("nodes[{i}].parent: {NO_PARENT} is not a node index")))
            }
            Some(p) => p,
            None => NO_PARENT,
        };
        let position = Vec3::from_array(node.position);
        let up = match node.up {
            Some(u) => Vec3::from_array(u),
            None => default_up(&sk, position, parent),
        };
        sk.push(position, node.radius, parent, up, node.order);
        if let Some(m) = sk.material.last_mut() {
            *m = node.material;
        }
    }
    if doc.nodes.iter().any(|n| n.start_radius.is_some()) {
        for (i, node) in doc.nodes.iter().enumerate() {
            sk.set_start_radius(i, node.start_radius.flatten());
        }
    }
    for (k, o) in doc.organs.into_iter().enumerate() {
        let swept = o.kind == "swept";
        if swept != o.rings.is_some() || o.rings.is_some() != o.closed.is_some() {
            return Err(bad(format!(
                "organs[{k}]: `rings` and `closed` belong to (and are needed by) a swept organ only"
            )));
        }
        let kind = match (o.kind.as_str(), o.name, o.vertices) {
            ("swept", None, None) => {
                let rings: Vec<Vec<Vec3>> = o
                    .rings
                    .unwrap_or_default()
                    .into_iter()
                    .map(|r| r.into_iter().map(Vec3::from_array).collect())
                    .collect();
                let n = rings.first().map_or(0, Vec::len);
                if rings.iter().any(|r| r.len() != n) {
                    return Err(bad(format!(
                        "organs[{k}].rings: every ring needs the same number of points"
                    )));
                }
                OrganKind::Swept(crate::skeleton::SweptSurface { rings, closed: o.closed.unwrap_or(false) })
            }
            ("swept", ..) => {
                return Err(bad(format!("organs[{k}]: a swept organ has no `name` or `vertices`")))
            }
            ("leaf", None, None) => OrganKind::Leaf,
            ("sphere", None, None) => OrganKind::Sphere,
            ("disc", None, None) => OrganKind::Disc,
            ("polygon", None, Some(v)) => OrganKind::Polygon(v.into_iter().map(Vec3::from_array).collect()),
            ("surface", Some(s), None) => OrganKind::Surface(s),
            (kind @ ("leaf" | "sphere" | "disc"), ..) => {
                return Err(bad(format!("organs[{k}]: a {kind} has no `name` or `vertices`")))
            }
            ("polygon", ..) => {
                return Err(bad(format!("organs[{k}]: a polygon needs `vertices` (and no `name`)")))
            }
            ("surface", ..) => {
                return Err(bad(format!("organs[{k}]: a surface needs a `name` (and no `vertices`)")))
            }
            (other, ..) => {
                return Err(bad(format!(
                    "organs[{k}].kind: unknown organ kind {:?} (leaf, polygon, surface, sphere, disc, swept)",
                    quote(other)
                )))
            }
        };
        let node = match o.node {
            Some(NO_PARENT) => return Err(bad(format!("organs[{k}].node: {NO_PARENT} is not a node index"))),
            Some(i) if i as usize >= sk.len() => {
                return Err(bad(format!(
                    "organs[{k}].node: {i} is not a node index (there are {})",
                    sk.len()
                )))
            }
            Some(i) => i,
            None => NO_PARENT,
        };
        sk.organs.push(Organ {
            kind,
            node,
            position: Vec3::from_array(o.position),
            heading: Vec3::from_array(o.heading),
            up: Vec3::from_array(o.up),
            size: o.size,
            material: o.material,
        });
    }
    sk.validate()?;
    Ok(sk)
}

/// A located error from serde_json's line and column, prefixed with the field path.
fn json_error(name: &str, text: &str, path: &str, e: &serde_json::Error) -> Error {
    let at = offset_of(text, e.line(), e.column());
    let full = e.to_string();
    let msg = clip_quoted(full.rsplit_once(" at line ").map_or(full.as_str(), |(m, _)| m));
    let what = if path.is_empty() || path == "." {
        msg.into_owned()
    } else {
        format!("{}: {msg}", clip(path, 4 * QUOTE_CHARS))
    };
    located(name, text, ErrorKind::Syntax, at, 1, &what, "here").into()
}

/// An `up` for a node that gives none: perpendicular to its internode.
fn default_up(sk: &Skeleton, position: Vec3, parent: u32) -> Vec3 {
    let dir = match sk.position.get(parent as usize) {
        Some(&p) => (position - p).as_dvec3().normalize_or(DVec3::Y),
        None => DVec3::Y,
    };
    perpendicular(dir, [DVec3::X, DVec3::Z, DVec3::Y]).as_vec3()
}

/// Byte offset of serde_json's 1-based line and column.
fn offset_of(text: &str, line: usize, column: usize) -> usize {
    let mut off = 0;
    for (k, l) in text.split_inclusive('\n').enumerate() {
        if k + 1 == line {
            return off + column.saturating_sub(1).min(l.len());
        }
        off += l.len();
    }
    text.len()
}
