//! cpfg's predecessors of several modules in decomposition and homomorphism productions
//! (issue 26): `A B --> X` in a `decomposition` or `homomorphism` section matches
//! consecutive modules of the string being decomposed or interpreted (the derived string
//! after a step, or one production's successor one level deeper; as in cpfg the axiom is
//! not decomposed, so decomposition is tested after one step without productions), as a multi-module
//! predecessor of a rewriting production matches consecutive modules of the string being
//! rewritten. Single-module decomposition and homomorphism behave as before.

use sylva::lsystem::expr::ModelFunctions;
use sylva::lsystem::{interpret, DeriveOptions, ErrorKind, LSystem, ModuleString, DEFAULT_MODULE_BUDGET};

fn parse(text: &str) -> LSystem {
    LSystem::parse("t.l", text, &[]).unwrap_or_else(|e| panic!("{}", e.message))
}

fn derive(ls: &LSystem, steps: u32) -> ModuleString {
    ls.derive(&DeriveOptions { steps, budget: DEFAULT_MODULE_BUDGET, seed: 1 })
        .unwrap_or_else(|e| panic!("{}", e.message))
}

/// The derived string after `steps` steps and the string the turtle reads.
fn strings(text: &str, steps: u32) -> (String, String) {
    let ls = parse(text);
    let m = derive(&ls, steps);
    let mut ev = ls.evaluator(1, ModelFunctions::default()).unwrap();
    let shown =
        ls.interpretation(&m, &mut ev, DEFAULT_MODULE_BUDGET).unwrap_or_else(|e| panic!("{}", e.message));
    (ls.format(&m), ls.format(&shown))
}

fn lsystem(body: &str) -> String {
    format!("Lsystem: 1\n{body}\nendlsystem\n")
}

/// [`strings`] of the L-system whose body (between `Lsystem: 1` and `endlsystem`) is
/// `body`.
fn of(body: &str, steps: u32) -> (String, String) {
    strings(&lsystem(body), steps)
}

/// The example: the axiom `A B` decomposes into `X`, and the homomorphism draws
/// `X Y` as one internode.
#[test]
fn two_module_decomposition_and_homomorphism() {
    assert_eq!(
        of("Axiom: A B\ndecomposition\nA B --> X\nhomomorphism\nX Y --> F(1)", 1),
        ("X".into(), "X".into())
    );
    let t = lsystem("Axiom: A B Y\ndecomposition\nA B --> X\nhomomorphism\nX Y --> F(1)");
    let (derived, shown) = strings(&t, 1);
    assert_eq!((derived.as_str(), shown.as_str()), ("XY", "F(1)"));
    // The turtle draws the homomorphism's image: one internode of length 1.
    let ls = parse(&t);
    let m = derive(&ls, 1);
    let mut ev = ls.evaluator(1, ModelFunctions::default()).unwrap();
    let shown = ls.interpretation(&m, &mut ev, DEFAULT_MODULE_BUDGET).unwrap();
    let sk = interpret(&ls.symbols, &shown, &Default::default(), &ls.source).unwrap();
    assert_eq!(sk.stats().segments, 1);
    assert!((sk.stats().total_length - 1.0).abs() < 1e-6, "{:?}", sk.stats());
}

/// Modules must be consecutive and in order; the first match from the left wins and its
/// modules are consumed, the scan going on after them; a module no production matches
/// stays.
#[test]
fn matches_are_consecutive_left_to_right() {
    assert_eq!(of("Axiom: A A B B A C B A B\ndecomposition\nA B --> X", 1).0, "AXBACBX");
    // Overlapping candidates: `A A A` with `A A --> X` gives `X A`.
    assert_eq!(of("Axiom: A A A\nhomomorphism\nA A --> X", 0), ("AAA".into(), "XA".into()));
    // A longer predecessor listed first wins where it matches; the single-module
    // production of the same first module applies elsewhere.
    assert_eq!(of("Axiom: A B C A B D\ndecomposition\nA B C --> X\nA --> Y", 1).0, "XYBD");
}

/// Parameters of every module of the predecessor are bound in order, and conditions
/// and statements see them all.
#[test]
fn parameters_and_conditions() {
    assert_eq!(
        of("Axiom: A(1) B(2) A(3) B(1)\ndecomposition\nA(x) B(y) : x < y --> C(x + y)", 1).0,
        "C(3)A(3)B(1)"
    );
    assert_eq!(
        of("Axiom: A(2) B(5)\nhomomorphism\nA(x) B(y) : {z = x * y;} 1 --> F(z) +(x)", 0),
        ("A(2)B(5)".into(), "F(10)+(2)".into())
    );
}

/// In a derivation step the string decomposed is the derived string as a whole: a
/// predecessor matches modules that different productions wrote (here `P --> A` and
/// `Q --> B`), and modules no production rewrote.
#[test]
fn decomposition_sees_the_whole_derived_string() {
    let t = lsystem("Axiom: P Q R\nP --> A\nQ --> B\nR --> A R\ndecomposition\nA B --> X\nA R --> Z");
    let ls = parse(&t);
    assert_eq!(ls.format(&derive(&ls, 1)), "XZ");
    // Step 2: X and Z are not rewritten; Z stays Z.
    assert_eq!(ls.format(&derive(&ls, 2)), "XZ");
    assert_eq!(of("Axiom: P B\nP --> A\ndecomposition\nA B --> X", 1).0, "X");
}

/// The recursive case (`maximum depth:`): a successor is decomposed as a string of its
/// own one level deeper, so a predecessor matches consecutive modules of one successor;
/// it never spans the end of a successor (the successor's modules and the modules that
/// follow the rewritten module are not consecutive in the same string).
#[test]
fn recursion_matches_within_one_successor() {
    assert_eq!(of("Axiom: A\ndecomposition\nmaximum depth: 3\nA --> B C\nB C --> D D\nD D --> F", 1).0, "F");
    // `B` comes from A's successor, `C` from the axiom: not one string.
    assert_eq!(of("Axiom: A C\ndecomposition\nmaximum depth: 3\nA --> B\nB C --> X", 1).0, "BC");
    // Two sibling successors do not join either: `A A` gives `B B`, not `X`.
    assert_eq!(of("Axiom: A A\nhomomorphism\nmaximum depth: 3\nA --> B\nB B --> X", 0).1, "BB");
    // A successor's own pair does match, at any depth within the maximum.
    assert_eq!(of("Axiom: A A\nhomomorphism\nmaximum depth: 3\nA --> B B\nB B --> X", 0).1, "XX");
    // Without `maximum depth:` a single level applies, as for one-module predecessors.
    assert_eq!(of("Axiom: A\nhomomorphism\nA --> B C\nB C --> X", 0).1, "BC");
    // With an explicit depth, a pair still matching at that depth is an error naming it.
    let t = lsystem("Axiom: A\ndecomposition\nmaximum depth: 1\nA --> B C\nB C --> X");
    let e = parse(&t).derive(&DeriveOptions { steps: 1, budget: 1000, seed: 0 }).unwrap_err();
    assert!(
        e.message.contains("module B still has a decomposition production at the maximum depth 1"),
        "{}",
        e.message
    );
}

/// Sub-L-systems: each run of modules one L-system owns is decomposed and interpreted
/// by its own rules; a predecessor never spans the `?(n, s)` / `$` boundary.
#[test]
fn sub_lsystems_keep_their_own_runs() {
    let t = "Lsystem: 1\nAxiom: A ?(2, 1) B $ A B\nhomomorphism\nA B --> F(1)\nendlsystem\n\
             Lsystem: 2\nAxiom: B\nhomomorphism\nB B --> X\nendlsystem\n";
    assert_eq!(strings(t, 0).1, "A?(2,1)B$F(1)");
}

/// Contexts stay refused in these sections, with the same clear error.
#[test]
fn contexts_are_still_unsupported() {
    let e = LSystem::parse("t.l", &lsystem("Axiom: A B\ndecomposition\nA < B --> X"), &[]).unwrap_err();
    assert_eq!(e.kind, ErrorKind::Unsupported);
    assert!(e.message.contains("unsupported: context in decomposition or homomorphism"), "{}", e.message);
}

/// Single-module decomposition and homomorphism are unchanged, also next to a
/// multi-module production in the same section.
#[test]
fn single_module_productions_are_unchanged() {
    assert_eq!(
        of("Axiom: a\na --> b[a]a\nb --> bb\nhomomorphism\na --> F(0.5)\nb --> F(1)", 1),
        ("b[a]a".into(), "F(1)[F(0.5)]F(0.5)".into())
    );
    let t = lsystem("Axiom: P\nP --> A B\ndecomposition\nmaximum depth: 3\nA --> X[Y]\nB --> CC\nC --> DE");
    let single = strings(&t, 1);
    assert_eq!(single.0, "X[Y]DEDE");
    let t2 = t.replace("C --> DE", "C --> DE\nQ R --> S");
    assert_eq!(strings(&t2, 1), single);
}
