//! Leaf outlines by `LeafShape` (WeberPenn1995 §4.8, Arbaro's shapes): the polygon
//! each leaf organ is drawn with.

use std::f64::consts::PI;

/// A leaf outline in leaf units: `u` across (width 1 = LeafScaleX·LeafScale), `w` along
/// the midrib from the petiole (0) to the tip (1). Concave outlines carry a `center`
/// from which they are star-shaped: the organ polygon then starts at it, so its fan
/// triangulation covers the outline exactly.
#[derive(Debug, Clone)]
pub(super) struct LeafOutline {
    pub(super) center: Option<(f64, f64)>,
    pub(super) points: Vec<(f64, f64)>,
}

/// Builds a symmetric outline from its right half (base to tip, `u ≥ 0`).
fn mirrored(center: Option<(f64, f64)>, right: &[(f64, f64)]) -> LeafOutline {
    let mut points: Vec<(f64, f64)> = right.to_vec();
    let on_axis = |p: &(f64, f64)| p.0.abs() < 1e-12;
    let inner: Vec<(f64, f64)> = right.iter().rev().filter(|p| !on_axis(p)).map(|&(u, w)| (-u, w)).collect();
    points.extend(inner);
    LeafOutline { center, points }
}

/// The outline of `LeafShape` (0–8).
pub(super) fn leaf_outline(shape: u32) -> LeafOutline {
    match shape {
        // Ovate: widest below the middle.
        1 => mirrored(None, &[(0.0, 0.0), (0.32, 0.08), (0.5, 0.3), (0.45, 0.55), (0.3, 0.78), (0.0, 1.0)]),
        // Linear (lanceolate): long, parallel sides.
        2 => mirrored(None, &[(0.0, 0.0), (0.35, 0.06), (0.5, 0.2), (0.5, 0.75), (0.3, 0.92), (0.0, 1.0)]),
        // Cordate: a notch at the petiole.
        3 => mirrored(
            Some((0.0, 0.45)),
            &[(0.0, 0.12), (0.2, 0.0), (0.42, 0.08), (0.5, 0.3), (0.42, 0.55), (0.24, 0.8), (0.0, 1.0)],
        ),
        // Maple: five pointed lobes.
        4 => mirrored(
            Some((0.0, 0.4)),
            &[
                (0.0, 0.08),
                (0.1, 0.02),
                (0.42, 0.12),
                (0.22, 0.3),
                (0.5, 0.56),
                (0.16, 0.58),
                (0.18, 0.8),
                (0.0, 1.0),
            ],
        ),
        // Palmate: narrow fingers spreading from the petiole.
        5 => mirrored(
            Some((0.0, 0.22)),
            &[(0.0, 0.0), (0.08, 0.1), (0.5, 0.42), (0.12, 0.4), (0.34, 0.9), (0.06, 0.55), (0.0, 1.0)],
        ),
        // Spiky oak: pointed lobes.
        6 => mirrored(
            Some((0.0, 0.5)),
            &[
                (0.0, 0.0),
                (0.12, 0.06),
                (0.36, 0.12),
                (0.2, 0.3),
                (0.5, 0.42),
                (0.24, 0.52),
                (0.44, 0.68),
                (0.18, 0.76),
                (0.26, 0.9),
                (0.0, 1.0),
            ],
        ),
        // Rounded oak: rounded lobes.
        7 => mirrored(
            Some((0.0, 0.5)),
            &[
                (0.0, 0.0),
                (0.16, 0.08),
                (0.34, 0.18),
                (0.24, 0.3),
                (0.46, 0.4),
                (0.48, 0.5),
                (0.26, 0.58),
                (0.4, 0.7),
                (0.36, 0.8),
                (0.18, 0.86),
                (0.2, 0.95),
                (0.0, 1.0),
            ],
        ),
        // Triangle (deltoid).
        8 => mirrored(None, &[(0.0, 0.0), (0.5, 0.04), (0.0, 1.0)]),
        // Ellipse, as a hexagon (Sapling's "hex" leaf).
        _ => {
            let right: Vec<(f64, f64)> = (0..=3)
                .map(|k| {
                    let a = k as f64 * PI / 3.0;
                    (0.5 * a.sin(), 0.5 - 0.5 * a.cos())
                })
                .collect();
            mirrored(None, &right)
        }
    }
}
