//! The directed-edge test of a closed, consistently oriented 2-manifold, shared by the
//! tests that mesh every preset or generator output as tubes closed at both ends.

use std::collections::HashMap;

/// Counts of directed edges; a closed oriented manifold has each directed edge once
/// and its reverse once. Panics naming `name` and the edge otherwise.
pub fn check_closed_manifold(name: &str, mesh: &sylva::Mesh) {
    let mut directed: HashMap<(u32, u32), u32> = HashMap::new();
    for f in 0..mesh.face_count() {
        let face = mesh.face(f);
        for k in 0..face.len() {
            let (a, b) = (face[k], face[(k + 1) % face.len()]);
            assert_ne!(a, b, "{name}: face {f} has a repeated vertex");
            *directed.entry((a, b)).or_default() += 1;
        }
    }
    for (&(a, b), &n) in &directed {
        assert_eq!(n, 1, "{name}: directed edge {a}->{b} used {n} times (orientation or non-manifold)");
        assert_eq!(directed.get(&(b, a)), Some(&1), "{name}: edge {a}-{b} has only one face (a hole)");
    }
}
