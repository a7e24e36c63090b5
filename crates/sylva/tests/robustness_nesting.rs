//! Issue 39, item 2 (deep nesting overflowed the stack, exit 134) and the module part
//! of item 3 (a raised `generator.max_modules` aborted on allocation when the
//! derivation outgrew memory).
//!
//! Every deep input runs on a thread with the main thread's 8 MiB stack and on one with
//! the test harness's default 2 MiB: a stack overflow aborts this test binary, so each
//! test fails loudly if any reader or stage recurses once per nesting level again.
//! The memory tests run a copy of this binary under an address-space limit
//! (`ulimit -v`), where the old code aborted with "memory allocation of N bytes failed".

use sylva::lsystem::derive::{MAX_MODULE_BUDGET, PEAK_BYTES_PER_MODULE};
use sylva::lsystem::{DeriveOptions, ErrorKind, LSystem, LsystemError, ModuleString, TurtleOptions};

/// The main thread's stack and the test threads' default.
const STACKS: [usize; 2] = [8 << 20, 2 << 20];

/// Runs `f` on a thread of each of [`STACKS`].
fn on_both_stacks(f: impl Fn() + Send + Sync + 'static) {
    let f = std::sync::Arc::new(f);
    for size in STACKS {
        let g = f.clone();
        std::thread::Builder::new()
            .name(format!("stack-{}MiB", size >> 20))
            .stack_size(size)
            .spawn(move || g())
            .expect("a thread")
            .join()
            .expect("the thread returns");
    }
}

/// The error of a call that must fail.
trait Failing<E> {
    fn failure(self, what: &str) -> E;
}

impl<T, E> Failing<E> for Result<T, E> {
    fn failure(self, what: &str) -> E {
        match self {
            Ok(_) => panic!("expected {what}"),
            Err(e) => e,
        }
    }
}

fn parse(text: &str) -> Result<LSystem, Box<LsystemError>> {
    LSystem::parse("t.l", text, &[])
}

/// Parses and derives `steps` steps with a module budget of a million.
fn derive(text: &str, steps: u32) -> Result<(LSystem, ModuleString), Box<LsystemError>> {
    let ls = parse(text)?;
    let m = ls.derive(&DeriveOptions { steps, budget: 1_000_000, seed: 1 })?;
    Ok((ls, m))
}

/// The located nesting error of the expression compiler, on line `line`.
fn assert_too_deep(e: &LsystemError, line: usize) {
    assert_eq!(e.kind, ErrorKind::Syntax, "{}", e.message);
    assert!(e.message.starts_with(&format!("t.l:{line}:")), "{}", e.message);
    assert!(e.message.contains("more than 256 levels deep"), "{}", e.message);
}

fn lsystem(axiom: &str, productions: &str) -> String {
    format!("Lsystem: 1\nAxiom: {axiom}\n{productions}\nendlsystem\n")
}

fn nested(open: &str, inner: &str, close: &str, n: usize) -> String {
    format!("{}{inner}{}", open.repeat(n), close.repeat(n))
}

/// 20,000 nested parentheses (the campaign's input) in a production, an axiom, a
/// condition, a probability, function arguments, array indices and a `#if`: located
/// syntax errors naming the limit. 200 levels still work.
#[test]
fn twenty_thousand_nested_parentheses_are_a_located_error() {
    on_both_stacks(|| {
        let deep = nested("(", "x", ")", 20_000);
        let cases = [
            (lsystem("A(1)", &format!("A(x) --> A({deep})")), 3),
            (lsystem(&format!("A({})", nested("(", "1", ")", 20_000)), ""), 2),
            (lsystem("A(1)", &format!("A(x) : {deep} > 0 --> A(x)")), 3),
            (lsystem("A(1)", &format!("A(x) --> A(x) : {deep}")), 3),
            (lsystem("A(1)", &format!("A(x) --> A({})", nested("sin(", "x", ")", 20_000))), 3),
            (lsystem("A(1)", &format!("A(x) --> A({})", nested("max(1, ", "x", ")", 20_000))), 3),
            (lsystem("A(1)", &format!("A(x) --> A({})", nested("2^", "x", "", 20_000))), 3),
            (lsystem("A(1)", &format!("A(x) --> A({})", nested("x ? 1 : ", "x", "", 20_000))), 3),
            (lsystem("A(1)", &format!("A(x) --> A({})", nested("x ? ", "x", " : 1", 20_000))), 3),
            (
                format!(
                    "Lsystem: 1\ndefine: {{ array a[2] = {{0, 1}}; }}\nAxiom: A({})\nendlsystem\n",
                    nested("a[", "0", "]", 20_000)
                ),
                3,
            ),
        ];
        for (text, line) in &cases {
            let e = derive(text, 1).failure("an error");
            assert_too_deep(&e, *line);
        }
        // Within the limit: 200 parentheses (and 200 function calls) evaluate.
        let (ls, m) = derive(&lsystem(&format!("A({})", nested("(", "7", ")", 200)), ""), 0).unwrap();
        assert_eq!(ls.format(&m), "A(7)");
        let (ls, m) = derive(&lsystem(&format!("A({})", nested("abs(", "-3", ")", 200)), ""), 0).unwrap();
        assert_eq!(ls.format(&m), "A(3)");
        // Function-like macros nested 20,000 deep stop at the preprocessor's 64 levels.
        let text =
            format!("#define M(x) (x)\n{}", lsystem(&format!("A({})", nested("M(", "1", ")", 20_000)), ""));
        let e = parse(&text).failure("an error");
        assert!(
            e.message.starts_with("t.l:3:") && e.message.contains("more than 64 levels"),
            "{}",
            e.message
        );
        // A `#if` condition is an expression too.
        let text = format!("#if {}\n#endif\n{}", nested("(", "1", ")", 20_000), lsystem("A", ""));
        let e = parse(&text).failure("an error");
        assert_eq!(e.kind, ErrorKind::Syntax, "{}", e.message);
        assert!(e.message.starts_with("t.l:1:"), "{}", e.message);
    });
}

/// 40,000 and 100,000 unary minus signs (and `!`, `+`) in an axiom's and a production's
/// parameters; a string of 100,000 turtle `-` modules is no expression and derives.
#[test]
fn a_hundred_thousand_unary_minus_signs_are_a_located_error() {
    on_both_stacks(|| {
        for n in [40_000, 100_000] {
            for op in ["-", "!", "+", "- ", "-!"] {
                let ops = op.repeat(n);
                let e = derive(&lsystem(&format!("A({ops}1)"), ""), 0).failure("an error");
                assert_too_deep(&e, 2);
                let e = derive(&lsystem("A(1)", &format!("A(x) --> A({ops}x)")), 1).failure("an error");
                assert_too_deep(&e, 3);
                let e = derive(&lsystem("A(1)", &format!("A(x) : {ops}x --> A(x)")), 1).failure("an error");
                assert_too_deep(&e, 3);
            }
        }
        // 200 minus signs are still an expression.
        let (ls, m) = derive(&lsystem(&format!("A({}5)", "-".repeat(200)), ""), 0).unwrap();
        assert_eq!(ls.format(&m), "A(5)");
        // Turtle turns, not an expression: 100,000 modules in the axiom and a production.
        let turns = "-".repeat(100_000);
        let (ls, m) = derive(&lsystem(&format!("F{turns}F"), &format!("F --> F{turns}")), 1).unwrap();
        assert_eq!(m.len(), 300_002);
        let sk = sylva::lsystem::interpret(&ls.symbols, &m, &TurtleOptions::default(), &ls.source).unwrap();
        assert_eq!(sk.len(), 3);
    });
}

/// 100,000 nested brackets in the axiom (balanced and unclosed) derive with a context
/// production (bracket matching) and interpret: the turtle's branch stack is a `Vec`.
/// Past a million open levels the turtle stops with a budget error, before its saved
/// states take gigabytes.
#[test]
fn deep_brackets_in_the_axiom_are_followed_without_recursion() {
    on_both_stacks(|| {
        let n = 100_000;
        for axiom in
            [nested("[", "F A", "]", n), format!("{}F A", "[".repeat(n)), nested("{[", "F A", "]}", n)]
        {
            // The axiom may continue on following lines: split it in lines of 50,000.
            let lines: Vec<String> =
                axiom.as_bytes().chunks(50_000).map(|c| String::from_utf8(c.to_vec()).unwrap()).collect();
            let text = lsystem(&lines.join("\n"), "F < A --> F A\nF > A --> F");
            let (ls, m) = derive(&text, 2).unwrap_or_else(|e| panic!("{}", e.message));
            assert_eq!(m.len(), axiom.matches(['[', ']', '{', '}', 'F', 'A']).count() + 2);
            let sk = sylva::lsystem::interpret(&ls.symbols, &m, &TurtleOptions::default(), &ls.source)
                .unwrap_or_else(|e| panic!("{}", e.message));
            // Inside polygons too, `F` draws its internode (as cpfg does, issue 46).
            assert_eq!(sk.len(), 4, "{}", &axiom[..8]);
        }
        // A million and one open branches, and as many open polygons.
        let ls = parse(&lsystem("[ { F", "")).unwrap();
        for (sym, what) in [("[", "a branch (`[`)"), ("{", "a polygon (`{`)")] {
            let id = ls.symbols.get(sym).unwrap();
            let mut m = ModuleString::new();
            for _ in 0..=sylva::lsystem::turtle::MAX_NESTING {
                m.push(id, &[]);
            }
            let e = sylva::lsystem::interpret(&ls.symbols, &m, &TurtleOptions::default(), &ls.source)
                .failure("an error");
            assert_eq!(e.kind, ErrorKind::Budget, "{}", e.message);
            assert!(
                e.message.contains(what) && e.message.contains("more than 1000000 levels"),
                "{}",
                e.message
            );
        }
    });
}

/// Statement blocks nested 20,000 deep (braces, `if`, `else if`, `while`, `do`): located
/// syntax errors; 100 levels still run.
#[test]
fn deep_statement_nesting_is_a_located_error() {
    on_both_stacks(|| {
        let n = 20_000;
        let blocks = [
            nested("{", "x = 1;", "}", n),
            format!("{{ {} x = 1; }}", "if (1) ".repeat(n)),
            format!("{{ if (0) x = 1; {} }}", "else if (0) x = 2; ".repeat(n)),
            format!("{{ {} x = 1; }}", "while (0) ".repeat(n)),
            format!("{{ {} }}", nested("do ", "x = 1;", " while (0);", n)),
        ];
        for b in &blocks {
            let text = format!("Lsystem: 1\nStart: {b}\nAxiom: A\nendlsystem\n");
            let e = derive(&text, 0).failure("an error");
            assert_too_deep(&e, 2);
            // In a production's statement block too.
            let text = lsystem("A(1)", &format!("A(x) : {b} x > 0 --> A(x)"));
            let e = derive(&text, 1).failure("an error");
            assert_too_deep(&e, 3);
        }
        let text = format!(
            "Lsystem: 1\nStart: {}\nAxiom: A(y)\nendlsystem\n",
            nested("{ if (1) ", "y = 4;", "}", 100)
        );
        let (ls, m) = derive(&text, 0).unwrap_or_else(|e| panic!("{}", e.message));
        assert_eq!(ls.format(&m), "A(4)");
    });
}

/// The preprocessor keeps `#if` nesting on a `Vec`: 100,000 nested conditionals parse.
#[test]
fn deeply_nested_preprocessor_conditionals_parse() {
    on_both_stacks(|| {
        let n = 100_000;
        let text =
            format!("{}#define X 3\n{}{}", "#if 1\n".repeat(n), "#endif\n".repeat(n), lsystem("A(X)", ""));
        let (ls, m) = derive(&text, 0).unwrap_or_else(|e| panic!("{}", e.message));
        assert_eq!(ls.format(&m), "A(3)");
        let text = format!("{}{}", "#ifdef Y\n".repeat(n), lsystem("A", ""));
        let e = parse(&text).failure("an error");
        assert!(e.message.contains("#endif"), "{}", e.message);
    });
}

/// TOML nested 100,000 deep in a `--set` value and in a recipe file: the `toml` crate's
/// recursion limit (80, the `unbounded` feature off) makes it an error, not an overflow.
#[test]
fn deep_toml_in_set_values_and_recipes_is_an_error() {
    on_both_stacks(|| {
        let n = 100_000;
        for value in [nested("[", "1", "]", n), nested("{a=", "1", "}", n), "[".repeat(n)] {
            let e = sylva::recipe::parse_set(&format!("generator.angle={value}")).failure("an error");
            assert!(e.to_string().contains("generator.angle"), "{e}");
        }
        let dir = std::env::temp_dir().join(format!("sylva-nesting-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        for (k, body) in [
            format!("[generator]\nkind = \"lsystem\"\nangle = {}\n", nested("[", "1", "]", n)),
            format!("a = {}\n", nested("{b=", "1", "}", n)),
            format!("[{}]\n", vec!["a"; n].join(".")),
            format!("{} = 1\n", vec!["a"; n].join(".")),
            format!("a = {}\n", "[".repeat(n)),
        ]
        .iter()
        .enumerate()
        {
            let path = dir.join(format!("deep{k}-{:?}.toml", std::thread::current().id()));
            std::fs::write(&path, body).unwrap();
            let e = sylva::recipe::load(path.to_str().unwrap(), &[]).failure("an error");
            assert!(e.to_string().contains(&format!("deep{k}")), "{e}");
        }
        let _ = std::fs::remove_dir_all(&dir);
    });
}

/// JSON skeletons nested 100,000 deep: serde_json's recursion limit (128, never
/// disabled in this workspace) makes it an error.
#[test]
fn deep_json_skeletons_are_an_error() {
    on_both_stacks(|| {
        for text in [
            nested("[", "1", "]", 100_000),
            "[".repeat(100_000),
            format!("{{\"format\": {}}}", nested("{\"a\":", "1", "}", 100_000)),
        ] {
            assert!(sylva::import::skel_json::from_json(&text).is_err());
        }
    });
}

/// `generator.max_modules` above [`MAX_MODULE_BUDGET`] (the campaign's 2,000,000,000) is
/// an error naming the key, from a recipe and from the derivation itself.
#[test]
fn module_budgets_past_the_cap_are_an_error_naming_the_key() {
    assert_eq!(PEAK_BYTES_PER_MODULE, 124);
    let set = sylva::recipe::parse_set("generator.max_modules=2000000000").unwrap();
    let e = sylva::recipe::load("lsys-binary-tree", &[set]).failure("an error");
    let m = e.to_string();
    assert!(
        m.contains("generator.max_modules") && m.contains("more than the largest module budget 500000000"),
        "{m}"
    );
    let ls = parse(&lsystem("A", "A --> AA")).unwrap();
    let e =
        ls.derive(&DeriveOptions { steps: 1, budget: MAX_MODULE_BUDGET + 1, seed: 1 }).failure("an error");
    assert_eq!(e.kind, ErrorKind::Budget);
    assert!(e.message.contains("`generator.max_modules` is 500000001"), "{}", e.message);
    // At the cap the derivation runs.
    let m = ls.derive(&DeriveOptions { steps: 10, budget: MAX_MODULE_BUDGET, seed: 1 }).unwrap();
    assert_eq!(m.len(), 1024);
}

// ---------------------------------------------------------------------------------------
// Derivations that outgrow memory, under an address-space limit.

/// The environment variable that makes [`outgrow_memory_child`] run (in the child).
const CHILD: &str = "SYLVA_NESTING_OOM_CHILD";

/// `A(1)` rewritten into a thousand copies of itself: the third step's string would
/// hold a billion modules (14 GB); its reservation, capped by the module budget at
/// 500 million modules (7 GB), is refused under the limit before anything is written.
fn thousandfold() -> String {
    lsystem("A(1)", &format!("A(x) --> {}", "A(x)".repeat(1000)))
}

/// The axiom decomposed into a billion modules of four parameters (38 GB): the
/// string grows module by module (the step's estimate does not see decomposition)
/// until the allocator refuses its next doubling.
fn decomposed() -> String {
    format!(
        "Lsystem: 1\nAxiom: A\ndecomposition\nmaximum depth: 4\nA --> {}\nB --> {}\nC --> {}\nendlsystem\n",
        "B".repeat(1000),
        "C".repeat(1000),
        "D(1,2,3,4)".repeat(1000)
    )
}

/// Nine million query modules `?P(0,0,0)` (270 MB of string): the turtle's answers to
/// them (104 bytes each, 936 MB) are reserved before the query pass, and refused.
fn queries() -> String {
    lsystem(&"B".repeat(3000), &format!("B --> {}", "?P(0,0,0)".repeat(3000)))
}

/// Runs in the child, under the limit: derives the L-system `$SYLVA_NESTING_OOM_CHILD`
/// names with the largest module budget and prints the error.
#[test]
#[ignore = "run by a_derivation_that_outgrows_memory_is_a_named_error under ulimit -v"]
fn outgrow_memory_child() {
    let Ok(which) = std::env::var(CHILD) else { return };
    let (text, steps) = match which.as_str() {
        "thousandfold" => (thousandfold(), 3),
        // One step: the axiom is not decomposed (cpfg, issue 46); its first step is.
        "decomposed" => (decomposed(), 1),
        _ => (queries(), 1),
    };
    let ls = parse(&text).unwrap();
    let opts = DeriveOptions { steps, budget: MAX_MODULE_BUDGET, seed: 1 };
    let e = ls
        .derive_full(&opts, Default::default(), Some(&TurtleOptions::default()), None)
        .failure("the derivation outgrows the address-space limit");
    println!("ERROR: {:?}: {} HELP: {}", e.kind, e.message, e.help.as_deref().unwrap_or(""));
}

/// With `generator.max_modules` at its largest and a 1 GB address-space limit, a
/// derivation whose step reservation or whose module-by-module growth is refused ends
/// with a budget error naming the key and the bytes asked, not an abort (exit 134).
#[test]
fn a_derivation_that_outgrows_memory_is_a_named_error() {
    if !cfg!(target_os = "linux") {
        println!("skipped: the address-space limit (ulimit -v) is set through a Linux shell");
        return;
    }
    let exe = std::env::current_exe().unwrap();
    for which in ["thousandfold", "decomposed", "queries"] {
        let out = std::process::Command::new("sh")
            .arg("-c")
            .arg("ulimit -v 1000000 || exit 77; exec \"$0\" \"$@\"")
            .arg(&exe)
            .args(["--exact", "outgrow_memory_child", "--ignored", "--nocapture", "--test-threads=1"])
            .env(CHILD, which)
            .output()
            .expect("sh runs");
        let stdout = String::from_utf8_lossy(&out.stdout);
        let stderr = String::from_utf8_lossy(&out.stderr);
        if out.status.code() == Some(77) {
            println!("skipped: `ulimit -v` is not available here ({stderr})");
            return;
        }
        assert!(out.status.success(), "{which}: {:?}\n{stdout}\n{stderr}", out.status);
        let line =
            stdout.lines().find_map(|l| l.split_once("ERROR: ")).unwrap_or_else(|| panic!("{stdout}")).1;
        assert!(line.starts_with("Budget: t.l: "), "{which}: {line}");
        if which == "queries" {
            assert!(line.contains("9000000 query modules") && line.contains("936000000 bytes"), "{line}");
            assert!(line.contains("--set generator.max_modules=N"), "{line}");
            continue;
        }
        assert!(
            line.contains("outgrows the memory available")
                && line.contains("generator.max_modules = 500000000")
                && line.contains(" bytes for a string of "),
            "{which}: {line}"
        );
    }
}
