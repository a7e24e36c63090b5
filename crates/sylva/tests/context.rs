//! Context-sensitive L-systems (ABOP §1.8): signal propagation through a branching
//! structure, checked against an independent character-level implementation, and the
//! effect of `ignore:`.

use sylva::lsystem::{DeriveOptions, LSystem};

/// An independent reference: one step of a bracketed 1L-system with single-letter
/// modules, productions `(left, pred, right) -> succ` (contexts optional).
fn reference_step(s: &[u8], prods: &[(Option<u8>, u8, Option<u8>, &str)], ignore: &[u8]) -> Vec<u8> {
    let left_of = |i: usize| -> Option<u8> {
        let mut j = i as isize - 1;
        while j >= 0 {
            let c = s[j as usize];
            if c == b'[' || ignore.contains(&c) {
                j -= 1;
            } else if c == b']' {
                let mut depth = 1;
                j -= 1;
                while j >= 0 && depth > 0 {
                    match s[j as usize] {
                        b']' => depth += 1,
                        b'[' => depth -= 1,
                        _ => {}
                    }
                    j -= 1;
                }
            } else {
                return Some(c);
            }
        }
        None
    };
    let right_of = |i: usize| -> Option<u8> {
        let mut j = i + 1;
        while j < s.len() {
            let c = s[j];
            if c == b']' {
                return None;
            }
            if c == b'[' {
                let mut depth = 1;
                j += 1;
                while j < s.len() && depth > 0 {
                    match s[j] {
                        b'[' => depth += 1,
                        b']' => depth -= 1,
                        _ => {}
                    }
                    j += 1;
                }
            } else if ignore.contains(&c) {
                j += 1;
            } else {
                return Some(c);
            }
        }
        None
    };
    let mut out = Vec::new();
    for (i, &c) in s.iter().enumerate() {
        let p = prods.iter().find(|(l, p, r, _)| {
            *p == c && l.is_none_or(|l| left_of(i) == Some(l)) && r.is_none_or(|r| right_of(i) == Some(r))
        });
        match p {
            Some((_, _, _, succ)) => out.extend_from_slice(succ.as_bytes()),
            None => out.push(c),
        }
    }
    out
}

fn derive_text(text: &str, n: u32) -> String {
    let ls = LSystem::parse("ctx.l", text, &[]).unwrap();
    let m = ls.derive(&DeriveOptions { steps: n, budget: 1 << 20, seed: 1 }).unwrap();
    ls.format(&m)
}

/// Checks that `text` (with `ignore: +-F`) derives, at each of steps 1 to 8, what
/// [`reference_step`] makes of `axiom` with `prods`.
fn matches_the_reference(text: &str, axiom: &str, prods: &[(Option<u8>, u8, Option<u8>, &str)]) {
    let mut s = axiom.as_bytes().to_vec();
    for n in 1..=8 {
        s = reference_step(&s, prods, b"+-F");
        assert_eq!(derive_text(text, n), String::from_utf8(s.clone()).unwrap(), "step {n}");
    }
}

#[test]
fn acropetal_signal() {
    let axiom = "Fb[+Fa]Fa[+Fa]Fa[+Fa]Fa";
    let text = format!("Lsystem: 1\nignore: +-F\nAxiom: {axiom}\nb < a --> b\nb --> a\nendlsystem\n");
    matches_the_reference(&text, axiom, &[(Some(b'b'), b'a', None, "b"), (None, b'b', None, "a")]);
    // The book's first step, by hand: the signal enters the first branch and the next
    // internode of the main axis.
    assert_eq!(derive_text(&text, 1), "Fa[+Fb]Fb[+Fa]Fa[+Fa]Fa");
}

#[test]
fn basipetal_signal() {
    let axiom = "Fa[+Fa]Fa[+Fa]Fa[+Fa]Fb";
    let text = format!("Lsystem: 1\nignore: +-F\nAxiom: {axiom}\na > b --> b\nb --> a\nendlsystem\n");
    matches_the_reference(&text, axiom, &[(None, b'a', Some(b'b'), "b"), (None, b'b', None, "a")]);
    assert_eq!(derive_text(&text, 1), "Fa[+Fa]Fa[+Fa]Fb[+Fa]Fa");
}

#[test]
fn ignore_changes_matching() {
    let with = "Lsystem: 1\nignore: F\nAxiom: bFa\nb < a --> X\nendlsystem\n";
    let without = "Lsystem: 1\nAxiom: bFa\nb < a --> X\nendlsystem\n";
    assert_eq!(derive_text(with, 1), "bFX");
    assert_eq!(derive_text(without, 1), "bFa");
    // consider: only the listed modules take part in context matching.
    let consider = "Lsystem: 1\nconsider: ab\nAxiom: bFG+a\nb < a --> X\nendlsystem\n";
    assert_eq!(derive_text(consider, 1), "bFG+X");
}

#[test]
fn parametric_contexts_bind_parameters() {
    let text = "Lsystem: 1\nAxiom: A(1)B(2)[C(5)]D(3)\nA(x) < B(y) > [C(z)]D(w) --> B(x+y+z+w)\nendlsystem\n";
    assert_eq!(derive_text(text, 1), "A(1)B(11)[C(5)]D(3)");
    // A right context `]` continues after the end of the current branch.
    let text = "Lsystem: 1\nAxiom: [A B]C\nA > ]C --> X\nendlsystem\n";
    assert_eq!(derive_text(text, 1), "[X B]C".replace(' ', ""));
    // Pipe model (the Lilac model's rule): widths sum over the children.
    let text = "Lsystem: 1\nAxiom: I(0)[I(1)][I(2)]I(3)\nI(w) > [I(a)][I(b)]I(c) --> I(a+b+c)\nendlsystem\n";
    assert_eq!(derive_text(text, 1), "I(6)[I(1)][I(2)]I(3)");
}
