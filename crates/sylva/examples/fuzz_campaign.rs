//! The fuzzing campaign of issues 27 and 39 (`docs/robustness.md`): mutated and
//! generated inputs for every reader, each run through the real readers under a
//! wall-clock limit and an address-space limit, counting panics, runs over the limit,
//! aborts (allocation failures, stack overflows and other crashes), failing runs that
//! leave files behind, canary leaks (bytes of a file outside a model folder in a
//! message or an output) and huge messages.
//!
//! ```text
//! cargo build --release -p sylva-cli -p sylva --examples
//! target/release/examples/fuzz_campaign --runs 16000 --class-runs 4000 \
//!     --cli target/release/sylva --cli-every 15 --class-cli-every 5 --kill-runs 200
//! ```
//!
//! Lanes:
//!
//! - **readers** (`--runs`): run `i` draws its input from `Rng::new(seed · 1000003 + i)`,
//!   its reader is `i mod 8` (L-system, recipe, `--set`, LST, `.str`, JSON, OBJ, glTF);
//!   every `--deep-every`-th round of eight goes through the whole pipeline.
//! - **classes** (`--class-runs`): case `j` of issue 39's generators
//!   (`fuzz_support::classes`; class `j mod 8`: long lines, deep nesting, degenerate
//!   skeletons, many roots, absurd numbers, raised budgets, duplicated glTF
//!   primitives, hostile model folders), always through the whole pipeline and the
//!   export (`.glb`, `.obj` + `.mtl`, `.gltf`, `.pov` + `.inc`, `.ply`).
//! - **cli** (`--cli`): every `--cli-every`-th readers run and every
//!   `--class-cli-every`-th round of eight classes runs also spawns the CLI (`sylva grow` with a random
//!   output format and sometimes a preview, `check`, `subdivide`) in a fresh folder
//!   under the same limits; its stdout and stderr are kept outside that folder.
//! - **kill** (`--kill-runs`, needs `--cli`): `sylva grow --kill-what` (a mid-size tree,
//!   with a preview half the time) killed by SIGTERM (70 %) or SIGKILL at a random
//!   time within its run; after SIGTERM nothing may be left in its folder; after
//!   SIGKILL a following grow into the same name must leave no stale temporary.
//!
//! In-process runs execute in worker processes (this program with `--worker`) under
//! `setrlimit(RLIMIT_AS)` (`--mem-gb`, 6); the parent kills a worker whose run is over
//! `--timeout` seconds (10) and restarts it after that run, so a hang or an abort costs
//! one run. `--jobs N` runs N workers side by side (each lane's runs split in N).
//! A run is replayed alone with `--lane readers|classes --from i --runs 1 --keep`
//! (the input is kept in `target/fuzz-campaign/`); the slowest runs' inputs are saved
//! in `target/fuzz-campaign/slowest/` with the command that replays each.

#[path = "../tests/fuzz_support/mod.rs"]
mod fuzz_support;

use fuzz_support::classes::{self, Case};
use fuzz_support::{next_input, Depth, Rng, Target};
use std::collections::BTreeMap;
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

#[derive(Debug, Clone)]
struct Args {
    runs: u64,
    class_runs: u64,
    from: u64,
    seed: u64,
    timeout: u64,
    mem_gb: u64,
    deep_every: u64,
    cli: Option<PathBuf>,
    cli_every: u64,
    class_cli_every: u64,
    kill_runs: u64,
    kill_what: String,
    jobs: u64,
    worker: bool,
    lane: Option<String>,
    keep: bool,
    cpfg: usize,
    slowest: usize,
}

fn args() -> Args {
    let mut a = Args {
        runs: 10_000,
        class_runs: 0,
        from: 0,
        seed: 39,
        timeout: 10,
        mem_gb: 6,
        deep_every: 4,
        cli: None,
        cli_every: 15,
        class_cli_every: 5,
        kill_runs: 0,
        kill_what: "mig-a".into(),
        jobs: 1,
        worker: false,
        lane: None,
        keep: false,
        cpfg: 50,
        slowest: 12,
    };
    let v: Vec<String> = std::env::args().skip(1).collect();
    let mut i = 0;
    while i < v.len() {
        let next = |i: usize| v.get(i + 1).cloned().unwrap_or_default();
        let num = |i: usize| next(i).parse::<u64>().unwrap_or_else(|_| panic!("{} needs a number", v[i]));
        match v[i].as_str() {
            "--runs" => a.runs = num(i),
            "--class-runs" => a.class_runs = num(i),
            "--from" => a.from = num(i),
            "--seed" => a.seed = num(i),
            "--timeout" => a.timeout = num(i),
            "--mem-gb" => a.mem_gb = num(i),
            "--deep-every" => a.deep_every = num(i),
            "--cli-every" => a.cli_every = num(i),
            "--class-cli-every" => a.class_cli_every = num(i),
            "--kill-runs" => a.kill_runs = num(i),
            "--kill-what" => a.kill_what = next(i),
            "--jobs" => a.jobs = num(i).max(1),
            "--cpfg" => a.cpfg = num(i) as usize,
            "--slowest" => a.slowest = num(i) as usize,
            "--lane" => a.lane = Some(next(i)),
            "--cli" => {
                let p = PathBuf::from(next(i));
                a.cli = Some(std::fs::canonicalize(&p).unwrap_or(p));
            }
            "--worker" => {
                a.worker = true;
                i += 1;
                continue;
            }
            "--keep" => {
                a.keep = true;
                i += 1;
                continue;
            }
            other => panic!("unknown argument {other}"),
        }
        i += 2;
    }
    if let (Some(l), false) = (&a.lane, a.worker) {
        // Replaying one lane: the other gets no runs.
        match l.as_str() {
            "readers" => a.class_runs = 0,
            "classes" => {
                a.class_runs = a.runs;
                a.runs = 0;
            }
            other => panic!("--lane readers|classes, not {other}"),
        }
    }
    a
}

/// The two in-process lanes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Lane {
    Readers,
    Classes,
}

impl Lane {
    fn name(self) -> &'static str {
        match self {
            Lane::Readers => "readers",
            Lane::Classes => "classes",
        }
    }
}

fn input_of(seed: u64, i: u64, corpus: &fuzz_support::Corpus) -> (Target, String, Vec<u8>, Option<PathBuf>) {
    let t = Target::ALL[(i % Target::ALL.len() as u64) as usize];
    let mut rng = Rng::new(seed.wrapping_mul(1_000_003).wrapping_add(i));
    let (origin, bytes, folder) = next_input(&mut rng, corpus, t);
    (t, origin, bytes, folder)
}

/// The output format of classes run `j` (in-process and CLI).
fn out_ext(j: u64) -> &'static str {
    ["glb", "obj", "glb", "gltf", "pov", "glb", "ply", "obj"][((j / 8) % 8) as usize]
}

/// A run's report key: the reader, or the class and its reader.
fn key_of(lane: Lane, seed: u64, i: u64, corpus: &fuzz_support::Corpus) -> (String, String) {
    match lane {
        Lane::Readers => {
            let (t, origin, ..) = input_of(seed, i, corpus);
            (t.name().to_string(), format!("from {origin}"))
        }
        Lane::Classes => {
            let c = fuzz_support::case_of(seed, i);
            (c.class.name().to_string(), format!("{}: {}", c.target.name(), c.what))
        }
    }
}

fn limit_memory(gb: u64) {
    let bytes = gb.saturating_mul(1 << 30);
    let lim = libc::rlimit { rlim_cur: bytes, rlim_max: bytes };
    // SAFETY: setrlimit with a valid struct only changes this process's limits.
    unsafe {
        libc::setrlimit(libc::RLIMIT_AS, &lim);
    }
}

/// An output of a run, or a temporary of one: `out.glb`, `out_bark.png`, `out.mtl`,
/// `out_bark.inc`, `.out.glb.tmp-123`.
fn is_output(name: &str) -> bool {
    name.starts_with("out") || name.starts_with(".out") || name.contains(".tmp-")
}

/// The worker: runs `from..from + runs` of its lane in-process, one line per event on
/// stdout: `BEGIN i`, then `END i kind ms depth left canary msgbytes message`.
fn worker(a: &Args) {
    limit_memory(a.mem_gb);
    // Panics are counted from the result; keep their messages off the terminal.
    std::panic::set_hook(Box::new(|_| {}));
    let lane = if a.lane.as_deref() == Some("classes") { Lane::Classes } else { Lane::Readers };
    let corpus = if lane == Lane::Readers { fuzz_support::corpus(a.cpfg) } else { Default::default() };
    let out = std::io::stdout();
    let work = fuzz_support::scratch("campaign");
    for i in a.from..a.from + a.runs {
        let case: Option<Case> = (lane == Lane::Classes).then(|| fuzz_support::case_of(a.seed, i));
        let input = (lane == Lane::Readers).then(|| input_of(a.seed, i, &corpus));
        // Every reader in turn goes deep: run i uses reader i mod 8.
        let deep = lane == Lane::Classes
            || (a.deep_every > 0 && (i / Target::ALL.len() as u64).is_multiple_of(a.deep_every));
        {
            let mut o = out.lock();
            let _ = writeln!(o, "BEGIN {i}");
            let _ = o.flush();
        }
        let t0 = Instant::now();
        let depth = if deep { Depth::Pipeline } else { Depth::Reader };
        let mut canary = false;
        let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| match (&case, &input) {
            (Some(c), _) => {
                let run = classes::run_case(c, &work, depth, out_ext(i));
                canary = !run.canary_hits.is_empty();
                run.result
            }
            (_, Some((t, _, bytes, folder))) => {
                fuzz_support::run_input(*t, bytes, folder.as_deref(), &work, depth)
            }
            _ => unreachable!(),
        }));
        // Output left behind by a failing run: the outputs, or a temporary file.
        let mut left = Vec::new();
        let failed = !matches!(r, Ok(Ok(_)));
        for e in std::fs::read_dir(&work).into_iter().flatten().flatten() {
            let name = e.file_name().to_string_lossy().into_owned();
            if is_output(&name) {
                if failed {
                    left.push(name);
                }
                let _ = std::fs::remove_file(e.path());
            }
        }
        let _ = std::fs::remove_dir_all(work.join("case"));
        let ms = t0.elapsed().as_millis();
        let (kind, msg) = match r {
            Ok(Ok(m)) => ("ok", m),
            Ok(Err(m)) => ("err", m),
            Err(p) => ("panic", fuzz_support::panic_message(&*p)),
        };
        let bytes = msg.len();
        let msg: String = msg.replace('\n', " ").chars().take(300).collect();
        let mut o = out.lock();
        let _ = writeln!(
            o,
            "END {i} {kind} {ms} {} {} {} {bytes} {msg}",
            if deep { "deep" } else { "reader" },
            if left.is_empty() { "-".into() } else { left.join(",") },
            if canary { "leak" } else { "-" },
        );
        let _ = o.flush();
    }
    let _ = std::fs::remove_dir_all(&work);
}

/// The report's columns.
const COLUMNS: [&str; 9] = [
    "runs",
    "ok",
    "clean errors",
    "panics",
    "over limit",
    "aborts",
    "leaving files",
    "canary leaks",
    "huge messages",
];
const RUNS: usize = 0;
const OK: usize = 1;
const ERR: usize = 2;
const PANIC: usize = 3;
const OVER: usize = 4;
const ABORT: usize = 5;
const LEFT: usize = 6;
const LEAK: usize = 7;
const HUGE: usize = 8;

/// A message over this many bytes (an error, or a CLI run's stdout and stderr) copies
/// a whole line or file instead of an excerpt.
const HUGE_MESSAGE: usize = 64 * 1024;

#[derive(Default, Debug)]
struct Tally {
    deep: u64,
    per_key: BTreeMap<String, [u64; 9]>,
    findings: Vec<String>,
    /// (milliseconds, lane, run index, what).
    slowest: Vec<(u128, &'static str, u64, String)>,
}

impl Tally {
    fn note(&mut self, key: &str, k: usize) {
        self.per_key.entry(key.to_string()).or_default()[k] += 1;
    }
    fn total(&self, k: usize) -> u64 {
        self.per_key.values().map(|v| v[k]).sum()
    }
    fn time(&mut self, ms: u128, lane: &'static str, i: u64, what: String, keep: usize) {
        self.slowest.push((ms, lane, i, what));
        self.slowest.sort_by_key(|s| std::cmp::Reverse(s.0));
        self.slowest.truncate(keep);
    }
    fn merge(&mut self, o: Tally, keep: usize) {
        self.deep += o.deep;
        for (k, v) in o.per_key {
            let e = self.per_key.entry(k).or_default();
            for c in 0..v.len() {
                e[c] += v[c];
            }
        }
        self.findings.extend(o.findings);
        for s in o.slowest {
            self.time(s.0, s.1, s.2, s.3, keep);
        }
    }
}

fn spawn_worker(a: &Args, lane: Lane, from: u64, runs: u64) -> (Child, mpsc::Receiver<String>) {
    let exe = std::env::current_exe().expect("own path");
    let mut child = Command::new(exe)
        .args([
            "--worker",
            "--lane",
            lane.name(),
            "--from",
            &from.to_string(),
            "--runs",
            &runs.to_string(),
            "--seed",
            &a.seed.to_string(),
            "--mem-gb",
            &a.mem_gb.to_string(),
            "--deep-every",
            &a.deep_every.to_string(),
            "--cpfg",
            &a.cpfg.to_string(),
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("spawn worker");
    let stdout = child.stdout.take().expect("piped");
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(stdout).lines() {
            let Ok(line) = line else { break };
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    (child, rx)
}

/// An in-process lane over `from..end`, in worker processes.
fn in_process(a: &Args, lane: Lane, from: u64, end: u64, corpus: &fuzz_support::Corpus) -> Tally {
    let mut tally = Tally::default();
    let mut next = from;
    let limit = Duration::from_secs(a.timeout);
    let lname = lane.name();
    while next < end {
        let (mut child, rx) = spawn_worker(a, lane, next, end - next);
        let mut current: Option<(u64, Instant)> = None;
        loop {
            let wait = match current {
                Some((_, t0)) => limit.saturating_sub(t0.elapsed()).max(Duration::from_millis(1)),
                // Making an input (the corpus, a 10⁵-triangle glTF) is not a run.
                None => limit * 6,
            };
            match rx.recv_timeout(wait) {
                Ok(line) => {
                    let mut w = line.splitn(9, ' ');
                    match w.next() {
                        Some("BEGIN") => {
                            let i: u64 = w.next().and_then(|x| x.parse().ok()).unwrap_or(next);
                            current = Some((i, Instant::now()));
                        }
                        Some("END") => {
                            let i: u64 = w.next().and_then(|x| x.parse().ok()).unwrap_or(next);
                            let kind = w.next().unwrap_or("");
                            let ms: u128 = w.next().and_then(|x| x.parse().ok()).unwrap_or(0);
                            let deep = w.next() == Some("deep");
                            let left = w.next().unwrap_or("-");
                            let leak = w.next() == Some("leak");
                            let bytes: usize = w.next().and_then(|x| x.parse().ok()).unwrap_or(0);
                            let msg = w.next().unwrap_or("");
                            let (key, what) = key_of(lane, a.seed, i, corpus);
                            tally.note(&key, RUNS);
                            tally.deep += u64::from(deep);
                            tally.time(ms, lname, i, format!("{key}, {what}"), a.slowest);
                            match kind {
                                "ok" => tally.note(&key, OK),
                                "err" => tally.note(&key, ERR),
                                _ => {
                                    tally.note(&key, PANIC);
                                    tally
                                        .findings
                                        .push(format!("{lname} run {i} ({key}, {what}): panic: {msg}"));
                                }
                            }
                            if left != "-" {
                                tally.note(&key, LEFT);
                                tally
                                    .findings
                                    .push(format!("{lname} run {i} ({key}): failed and left {left}"));
                            }
                            if leak {
                                tally.note(&key, LEAK);
                                tally.findings.push(format!(
                                    "{lname} run {i} ({key}, {what}): the canary's content is in its message or output: {msg}"
                                ));
                            }
                            if bytes > HUGE_MESSAGE {
                                tally.note(&key, HUGE);
                                tally.findings.push(format!(
                                    "{lname} run {i} ({key}, {what}): a message of {bytes} bytes"
                                ));
                            }
                            if ms > limit.as_millis() {
                                tally.note(&key, OVER);
                                tally.findings.push(format!("{lname} run {i} ({key}, {what}): {ms} ms"));
                            }
                            next = i + 1;
                            current = None;
                            let runs = tally.total(RUNS);
                            if runs.is_multiple_of(500) {
                                eprintln!("  {lname} {from}..{end}: {runs} runs: {}", short(&tally));
                            }
                        }
                        _ => {}
                    }
                }
                Err(mpsc::RecvTimeoutError::Timeout) => {
                    let _ = child.kill();
                    let _ = child.wait();
                    match current {
                        None => {
                            // No run started: making the input itself hung (a harness bug);
                            // skip it rather than wait forever.
                            tally.findings.push(format!(
                                "{lname} run {next}: the harness could not make its input in time"
                            ));
                            next += 1;
                        }
                        Some((i, _)) => {
                            let (key, what) = key_of(lane, a.seed, i, corpus);
                            tally.note(&key, RUNS);
                            tally.note(&key, OVER);
                            tally.time(
                                limit.as_millis() + 1,
                                lname,
                                i,
                                format!("{key}, {what} (killed)"),
                                a.slowest,
                            );
                            tally
                                .findings
                                .push(format!("{lname} run {i} ({key}, {what}): over {} s", a.timeout));
                            next = i + 1;
                        }
                    }
                    break;
                }
                Err(mpsc::RecvTimeoutError::Disconnected) => {
                    let status = child.wait().ok();
                    match current {
                        None if next < end => {
                            tally.findings.push(format!(
                                "{lname} run {next}: the harness died making its input ({status:?})"
                            ));
                            next += 1;
                        }
                        None => {}
                        Some((i, _)) => {
                            let (key, what) = key_of(lane, a.seed, i, corpus);
                            tally.note(&key, RUNS);
                            tally.note(&key, ABORT);
                            tally.findings.push(format!(
                                "{lname} run {i} ({key}, {what}): worker died ({status:?}: allocation failure, stack overflow or crash)"
                            ));
                            next = i + 1;
                        }
                    }
                    break;
                }
            }
        }
        let _ = child.kill();
        let _ = child.wait();
    }
    tally
}

fn short(t: &Tally) -> String {
    COLUMNS
        .iter()
        .enumerate()
        .skip(1)
        .map(|(k, c)| format!("{c} {}", t.total(k)))
        .collect::<Vec<_>>()
        .join(", ")
}

/// Sets the address-space limit of a command's process.
fn limit_command(cmd: &mut Command, gb: u64) {
    // SAFETY: only async-signal-safe setrlimit between fork and exec.
    unsafe {
        use std::os::unix::process::CommandExt;
        cmd.pre_exec(move || {
            let bytes = gb.saturating_mul(1 << 30);
            let lim = libc::rlimit { rlim_cur: bytes, rlim_max: bytes };
            libc::setrlimit(libc::RLIMIT_AS, &lim);
            Ok(())
        });
    }
}

/// Every path under `dir` (relative), folders included, symlinks not followed.
fn listing(dir: &Path) -> Vec<String> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).into_iter().flatten().flatten() {
            let p = e.path();
            out.push(p.strip_prefix(dir).unwrap_or(&p).display().to_string());
            if e.file_type().is_ok_and(|t| t.is_dir()) {
                stack.push(p);
            }
        }
    }
    out.sort();
    out
}

fn campaign_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../target/fuzz-campaign")
}

/// Copies the files of a cpfg model folder (and, for recipes, the presets' L-systems)
/// into a run's folder.
fn copy_side_files(dir: &Path, t: Target, folder: Option<&Path>) {
    if let Some(f) = folder {
        for e in std::fs::read_dir(f).into_iter().flatten().flatten() {
            if e.path().is_file() {
                let _ = std::fs::copy(e.path(), dir.join(e.file_name()));
            }
        }
    }
    if t == Target::Recipe {
        let l = dir.join("lsystem");
        let _ = std::fs::create_dir_all(&l);
        for e in std::fs::read_dir(fuzz_support::repo_root().join("presets/lsystem"))
            .into_iter()
            .flatten()
            .flatten()
        {
            let _ = std::fs::copy(e.path(), l.join(e.file_name()));
        }
    }
}

/// One CLI run: what to run and how to judge it.
struct CliRun {
    key: String,
    what: String,
    dir: PathBuf,
    args: Vec<String>,
    canary: Option<String>,
}

/// The `grow` arguments for an output: a random format, sometimes a preview.
fn grow_output_args(rng: &mut Rng) -> Vec<String> {
    let ext = *rng.pick(&["glb", "glb", "obj", "gltf", "pov", "ply", "lst", "skel.json"]);
    let mut v = vec!["-o".to_string(), format!("out.{ext}")];
    if rng.chance(0.3) && !matches!(ext, "lst" | "skel.json") {
        v.extend(["--preview-size".to_string(), "96".to_string()]);
        if rng.chance(0.2) {
            // A preview path that cannot be written: the model must not be left.
            v.extend(["--preview".to_string(), "no-such-folder/p.png".to_string()]);
        }
    } else {
        v.push("--no-preview".into());
    }
    if rng.chance(0.2) && ext != "lst" && ext != "skel.json" {
        v.extend(["--set".to_string(), "output.textures=files".to_string()]);
        v.extend(["--set".to_string(), "textures.bark_size=64".to_string()]);
    }
    v.push("-q".into());
    v
}

/// The CLI run of readers run `i`.
fn readers_cli(a: &Args, i: u64, corpus: &fuzz_support::Corpus) -> CliRun {
    let (t, origin, bytes, folder) = input_of(a.seed, i, corpus);
    let dir = campaign_dir().join(format!("cli-{i}"));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("campaign folder");
    copy_side_files(&dir, t, folder.as_deref());
    let mut rng = Rng::new(a.seed ^ i.wrapping_mul(0x51_7CC1_B727_220A));
    let name =
        if t == Target::Json { "input.skel.json".to_string() } else { format!("input.{}", t.ext(&bytes)) };
    let mut args: Vec<String> = Vec::new();
    let key = match t {
        Target::Set => "cli set",
        Target::Obj | Target::Gltf => "cli mesh",
        _ => "cli grow",
    };
    match t {
        Target::Set => {
            let text = String::from_utf8_lossy(&bytes);
            let mut lines = text.lines();
            args.extend(["grow".into(), lines.next().unwrap_or("lsys-binary-tree").to_string()]);
            args.extend(grow_output_args(&mut rng));
            for l in lines {
                args.extend(["--set".into(), l.to_string()]);
            }
        }
        Target::Obj if i.is_multiple_of(2) => {
            std::fs::write(dir.join(&name), &bytes).expect("write input");
            args.extend(["subdivide", "input.obj", "-o", "out.obj", "-q"].map(String::from));
        }
        Target::Obj | Target::Gltf => {
            std::fs::write(dir.join(&name), &bytes).expect("write input");
            args.extend(["check".into(), name]);
        }
        _ => {
            std::fs::write(dir.join(&name), &bytes).expect("write input");
            args.extend(["grow".into(), name]);
            args.extend(grow_output_args(&mut rng));
        }
    }
    CliRun { key: key.into(), what: format!("{}, from {origin}", t.name()), dir, args, canary: None }
}

/// The CLI run of classes run `j`.
fn classes_cli(a: &Args, j: u64) -> CliRun {
    let c = fuzz_support::case_of(a.seed, j);
    let dir = campaign_dir().join(format!("cli-class-{j}"));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("campaign folder");
    let built = classes::materialize(&c, &dir).expect("build the case");
    if c.target == Target::Recipe && c.model.is_none() {
        copy_side_files(&dir, c.target, None);
    }
    let mut rng = Rng::new(a.seed ^ j.wrapping_mul(0x2545_F491_4F6C_DD1D));
    let input = built.input.strip_prefix(&dir).unwrap_or(&built.input).display().to_string();
    let mut args: Vec<String> = Vec::new();
    let sets: Vec<String> = if c.target == Target::Set {
        String::from_utf8_lossy(&c.bytes).lines().skip(1).map(str::to_string).chain(c.sets.clone()).collect()
    } else {
        c.sets.clone()
    };
    match c.target {
        Target::Obj if j.is_multiple_of(2) => {
            args.extend(["subdivide".into(), input, "-o".into(), "out.obj".into(), "-q".into()])
        }
        Target::Obj | Target::Gltf => args.extend(["check".into(), input]),
        Target::Set => {
            let base =
                String::from_utf8_lossy(&c.bytes).lines().next().unwrap_or("lsys-binary-tree").to_string();
            args.extend(["grow".into(), base]);
            args.extend(grow_output_args(&mut rng));
        }
        _ => {
            args.extend(["grow".into(), input]);
            args.extend(grow_output_args(&mut rng));
        }
    }
    if matches!(args.first().map(String::as_str), Some("grow")) {
        for s in sets {
            args.extend(["--set".into(), s]);
        }
        if c.class == classes::Class::RaisedBudgets {
            args.extend(["--time-limit".into(), classes::RAISED_TIME_LIMIT_S.to_string()]);
        }
    }
    CliRun {
        key: format!("cli {}", c.class.name()),
        what: format!("{}: {}", c.target.name(), c.what),
        dir,
        args,
        canary: c.canary,
    }
}

/// Runs one CLI run to its end (or the time limit) and judges it.
fn run_cli(a: &Args, cli: &Path, run: CliRun, lane: &'static str, i: u64, tally: &mut Tally) {
    let (stdout, stderr) = (run.dir.with_extension("stdout"), run.dir.with_extension("stderr"));
    let mut cmd = Command::new(cli);
    cmd.current_dir(&run.dir).args(&run.args);
    match (std::fs::File::create(&stdout), std::fs::File::create(&stderr)) {
        (Ok(o), Ok(e)) => {
            cmd.stdout(o).stderr(e);
        }
        _ => {
            cmd.stdout(Stdio::null()).stderr(Stdio::null());
        }
    }
    limit_command(&mut cmd, a.mem_gb);
    let before = listing(&run.dir);
    let t0 = Instant::now();
    let mut child = match cmd.spawn() {
        Ok(c) => c,
        Err(e) => {
            // An argument over the kernel's limit (E2BIG) is the harness's problem.
            tally.findings.push(format!("{lane} run {i} ({}): cannot run {}: {e}", run.key, cli.display()));
            return;
        }
    };
    let limit = Duration::from_secs(a.timeout);
    let status = loop {
        if let Ok(Some(s)) = child.try_wait() {
            break Some(s);
        }
        if t0.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            break None;
        }
        std::thread::sleep(Duration::from_millis(5));
    };
    let ms = t0.elapsed().as_millis();
    let key = run.key.as_str();
    let what = format!("{} `sylva {}`", run.what, short_args(&run.args));
    tally.note(key, RUNS);
    tally.time(ms, lane, i, format!("{key}, {what}"), a.slowest);
    use std::os::unix::process::ExitStatusExt;
    match status {
        None => {
            tally.note(key, OVER);
            tally.findings.push(format!("cli {lane} run {i} ({key}, {what}): over {} s", a.timeout));
        }
        Some(s) if s.code() == Some(0) => tally.note(key, OK),
        Some(s) if s.code() == Some(1) || s.code() == Some(2) => tally.note(key, ERR),
        Some(s) if s.code() == Some(101) => {
            tally.note(key, PANIC);
            let err = std::fs::read(&stderr).unwrap_or_default();
            let m: String = String::from_utf8_lossy(&err).chars().take(300).collect();
            tally.findings.push(format!("cli {lane} run {i} ({key}, {what}): panic: {m}"));
        }
        Some(s) => {
            tally.note(key, ABORT);
            tally.findings.push(format!(
                "cli {lane} run {i} ({key}, {what}): exit {:?}, signal {:?}",
                s.code(),
                s.signal()
            ));
        }
    }
    let failed = !matches!(status, Some(s) if s.code() == Some(0));
    if failed {
        let after = listing(&run.dir);
        let new: Vec<&String> = after.iter().filter(|f| !before.contains(f)).collect();
        if !new.is_empty() {
            tally.note(key, LEFT);
            tally.findings.push(format!("cli {lane} run {i} ({key}, {what}): failed and left {new:?}"));
        }
    }
    let said =
        std::fs::metadata(&stdout).map_or(0, |m| m.len()) + std::fs::metadata(&stderr).map_or(0, |m| m.len());
    if said as usize > HUGE_MESSAGE {
        tally.note(key, HUGE);
        tally.findings.push(format!("cli {lane} run {i} ({key}, {what}): printed {said} bytes"));
    }
    if let Some(token) = &run.canary {
        let outside = run.dir.join(classes::OUTSIDE);
        let mut hits: Vec<String> = Vec::new();
        for f in [&stdout, &stderr] {
            if classes::file_contains(f, token.as_bytes()) {
                hits.push(f.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default());
            }
        }
        for f in classes::files_under(&run.dir) {
            if !f.starts_with(&outside) && classes::file_contains(&f, token.as_bytes()) {
                hits.push(f.strip_prefix(&run.dir).unwrap_or(&f).display().to_string());
            }
        }
        if !hits.is_empty() {
            tally.note(key, LEAK);
            tally
                .findings
                .push(format!("cli {lane} run {i} ({key}, {what}): the canary's content is in {hits:?}"));
        }
    }
    if !a.keep {
        let _ = std::fs::remove_dir_all(&run.dir);
        let _ = std::fs::remove_file(&stdout);
        let _ = std::fs::remove_file(&stderr);
    }
}

/// The command line for reports, long arguments shortened.
fn short_args(args: &[String]) -> String {
    args.iter()
        .map(|s| {
            if s.len() > 60 {
                format!("{}…({} chars)", &s[..s.char_indices().nth(40).map_or(s.len(), |c| c.0)], s.len())
            } else {
                s.clone()
            }
        })
        .collect::<Vec<_>>()
        .join(" ")
}

/// The CLI lane: every `cli_every`-th readers run and every `class_cli_every`-th
/// classes run through the `sylva` binary.
fn cli_lane(a: &Args, cli: &Path, corpus: &fuzz_support::Corpus) -> Tally {
    let mut tally = Tally::default();
    let (mut i, mut j) = (a.from, a.from);
    let (ei, ej) = (a.from + a.runs, a.from + a.class_runs);
    // Interleaved so both lanes progress together.
    loop {
        while i < ei && !(a.cli_every > 0 && i % a.cli_every == 0) {
            i += 1;
        }
        // Whole rounds of the eight classes, so every class reaches the CLI.
        while j < ej && !(a.class_cli_every > 0 && (j / 8).is_multiple_of(a.class_cli_every)) {
            j += 1;
        }
        if i >= ei && j >= ej {
            break;
        }
        if i < ei {
            let run = readers_cli(a, i, corpus);
            run_cli(a, cli, run, "readers", i, &mut tally);
            i += 1;
        }
        if j < ej {
            let run = classes_cli(a, j);
            run_cli(a, cli, run, "classes", j, &mut tally);
            j += 1;
        }
    }
    tally
}

/// The fault lane: `sylva grow` killed by SIGTERM or SIGKILL during its run.
fn kill_lane(a: &Args, cli: &Path) -> Tally {
    let mut tally = Tally::default();
    if a.kill_runs == 0 {
        return tally;
    }
    let base = campaign_dir().join("kill");
    let _ = std::fs::remove_dir_all(&base);
    let command = |dir: &Path, ext: &str, preview: bool| {
        let mut cmd = Command::new(cli);
        cmd.current_dir(dir).args(["grow", &a.kill_what, "-o", &format!("out.{ext}"), "-q"]);
        if preview {
            cmd.args(["--preview-size", "256"]);
        } else {
            cmd.arg("--no-preview");
        }
        cmd.stdout(Stdio::null()).stderr(Stdio::null());
        limit_command(&mut cmd, a.mem_gb);
        cmd
    };
    let temps =
        |dir: &Path| -> Vec<String> { listing(dir).into_iter().filter(|n| n.contains(".tmp-")).collect() };
    let wait_for = |child: &mut Child, limit: Duration| -> Option<std::process::ExitStatus> {
        let t0 = Instant::now();
        loop {
            if let Ok(Some(s)) = child.try_wait() {
                return Some(s);
            }
            if t0.elapsed() > limit {
                let _ = child.kill();
                let _ = child.wait();
                return None;
            }
            std::thread::sleep(Duration::from_millis(2));
        }
    };
    // How long a whole run takes: the kills land anywhere in it.
    let probe = base.join("probe");
    let _ = std::fs::create_dir_all(&probe);
    let t0 = Instant::now();
    let full =
        command(&probe, "glb", true).spawn().ok().and_then(|mut c| wait_for(&mut c, Duration::from_secs(60)));
    let full_ms = (t0.elapsed().as_millis() as u64).max(50);
    eprintln!("  kill lane: `sylva grow {}` takes {full_ms} ms ({full:?})", a.kill_what);
    let _ = std::fs::remove_dir_all(&probe);
    // The files a finished run leaves, by (extension, preview): made when first needed.
    let mut complete: std::collections::HashMap<(&str, bool), Vec<String>> = Default::default();
    for k in 0..a.kill_runs {
        let mut rng = Rng::new(a.seed.wrapping_mul(1_000_003).wrapping_add(k) ^ 0x4B11_4B11);
        let dir = base.join(format!("kill-{k}"));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("kill folder");
        let ext = *rng.pick(&["glb", "obj", "gltf", "pov"]);
        let preview = rng.chance(0.5);
        let term = rng.chance(0.7);
        let key = if term { "kill SIGTERM" } else { "kill SIGKILL, then regrow" };
        let delay = Duration::from_millis(rng.below((full_ms * 11 / 10) as usize) as u64);
        let what = format!(
            "grow {} -o out.{ext}{} killed after {} ms",
            a.kill_what,
            if preview { " with preview" } else { "" },
            delay.as_millis()
        );
        tally.note(key, RUNS);
        let Ok(mut child) = command(&dir, ext, preview).spawn() else {
            tally.findings.push(format!("kill run {k}: cannot run {}", cli.display()));
            continue;
        };
        std::thread::sleep(delay);
        let sig = if term { libc::SIGTERM } else { libc::SIGKILL };
        // SAFETY: signals our own child, which has not been waited for yet.
        unsafe {
            libc::kill(child.id() as libc::pid_t, sig);
        }
        let status = wait_for(&mut child, Duration::from_secs(a.timeout));
        let finished = matches!(status, Some(s) if s.success());
        use std::os::unix::process::ExitStatusExt;
        match status {
            None => {
                tally.note(key, OVER);
                tally
                    .findings
                    .push(format!("kill run {k} ({what}): still running {} s after the signal", a.timeout));
            }
            Some(_) if finished => tally.note(key, OK),
            Some(s) if s.code() == Some(101) => {
                tally.note(key, PANIC);
                tally.findings.push(format!("kill run {k} ({what}): panicked"));
            }
            Some(s) if s.signal() == Some(sig) || s.code().is_some() => tally.note(key, ERR),
            Some(s) => {
                tally.note(key, ABORT);
                tally.findings.push(format!("kill run {k} ({what}): {s:?}"));
            }
        }
        if term {
            // A SIGTERM leaves nothing: the outputs when it finished first, else no file.
            // A signal that arrives while the outputs are renamed into place is held until
            // the whole set is there (then the process dies of it): the complete set of a
            // finished run, and no temporary, is a run that committed before the signal.
            let mut files = listing(&dir);
            files.sort();
            let committed = !finished
                && !files.is_empty()
                && files
                    == *complete.entry((ext, preview)).or_insert_with(|| {
                        let probe = base.join(format!("complete-{ext}-{preview}"));
                        let _ = std::fs::create_dir_all(&probe);
                        let _ = command(&probe, ext, preview)
                            .spawn()
                            .ok()
                            .and_then(|mut c| wait_for(&mut c, Duration::from_secs(60)));
                        let mut names = listing(&probe);
                        names.sort();
                        let _ = std::fs::remove_dir_all(&probe);
                        names
                    });
            if committed {
                tally.note("kill SIGTERM: the whole output set committed before the signal", RUNS);
            }
            let left: Vec<String> =
                files.into_iter().filter(|n| !(finished || committed) || n.contains(".tmp-")).collect();
            if !left.is_empty() {
                tally.note(key, LEFT);
                tally.findings.push(format!("kill run {k} ({what}): left {left:?} ({status:?})"));
            }
        } else {
            let stale = temps(&dir);
            if !stale.is_empty() {
                tally.note("kill SIGKILL: temporaries left by the kill (expected)", RUNS);
            }
            let again = command(&dir, ext, preview)
                .spawn()
                .ok()
                .and_then(|mut c| wait_for(&mut c, Duration::from_secs(a.timeout)));
            let ok = matches!(again, Some(s) if s.success());
            let after = temps(&dir);
            if !ok {
                tally
                    .findings
                    .push(format!("kill run {k} ({what}): the regrow after the kill failed: {again:?}"));
            }
            if !after.is_empty() {
                tally.note(key, LEFT);
                tally.findings.push(format!(
                    "kill run {k} ({what}): stale temporaries {after:?} after a regrow into the same name (before it: {stale:?})"
                ));
            }
        }
        if !a.keep {
            let _ = std::fs::remove_dir_all(&dir);
        }
    }
    tally
}

/// Saves the slowest runs' inputs in `target/fuzz-campaign/slowest/` with the command
/// that replays each.
fn save_slowest(a: &Args, t: &Tally, corpus: &fuzz_support::Corpus) {
    let dir = campaign_dir().join("slowest");
    let _ = std::fs::remove_dir_all(&dir);
    let _ = std::fs::create_dir_all(&dir);
    let mut index = String::new();
    for (ms, lane, i, what) in &t.slowest {
        let sub = dir.join(format!("{lane}-{i}"));
        let _ = std::fs::create_dir_all(&sub);
        match *lane {
            "classes" => {
                let c = fuzz_support::case_of(a.seed, *i);
                let _ = classes::materialize(&c, &sub);
                let _ = std::fs::write(sub.join("sets.txt"), c.sets.join("\n"));
            }
            _ => {
                let (t, _, bytes, folder) = input_of(a.seed, *i, corpus);
                let _ = std::fs::write(sub.join(format!("input.{}", t.ext(&bytes))), &bytes);
                if let Some(f) = folder {
                    let _ = std::fs::write(sub.join("folder.txt"), f.display().to_string());
                }
            }
        }
        let replay = format!(
            "target/release/examples/fuzz_campaign --seed {} --lane {lane} --from {i} --runs 1 --keep --timeout {}",
            a.seed, a.timeout
        );
        let _ = std::fs::write(sub.join("what.txt"), format!("{ms} ms: {what}\nreplay: {replay}\n"));
        index.push_str(&format!("{ms} ms  {lane} {i}: {what}\n    {replay}\n"));
    }
    let _ = std::fs::write(dir.join("README.txt"), &index);
}

fn print_table(name: &str, t: &Tally, timeout: u64) {
    if t.per_key.is_empty() && t.findings.is_empty() {
        return;
    }
    println!();
    println!("{name}: {} runs ({} through the whole pipeline): {}", t.total(RUNS), t.deep, short(t));
    println!(
        "| {name} | {} |",
        COLUMNS
            .iter()
            .map(|c| if *c == "over limit" { format!("over {timeout} s") } else { c.to_string() })
            .collect::<Vec<_>>()
            .join(" | ")
    );
    println!("|---|{}", "---|".repeat(COLUMNS.len()));
    for (k, v) in &t.per_key {
        println!("| {k} | {} |", v.iter().map(u64::to_string).collect::<Vec<_>>().join(" | "));
    }
    println!(
        "| **all** | {} |",
        (0..COLUMNS.len()).map(|k| t.total(k).to_string()).collect::<Vec<_>>().join(" | ")
    );
    for f in &t.findings {
        println!("  {f}");
    }
}

fn main() {
    let a = args();
    if a.worker {
        worker(&a);
        return;
    }
    let t0 = Instant::now();
    let corpus = fuzz_support::corpus(a.cpfg);
    eprintln!(
        "fuzz campaign: seed {}, readers {}..{} (every {}th round through the pipeline), classes {}..{}, {} s and {} GiB per run, {} job(s){}{}",
        a.seed,
        a.from,
        a.from + a.runs,
        a.deep_every,
        a.from,
        a.from + a.class_runs,
        a.timeout,
        a.mem_gb,
        a.jobs,
        a.cli.as_ref().map_or(String::new(), |c| format!(
            ", CLI {} (every {}th readers run, every {}th classes run)",
            c.display(),
            a.cli_every,
            a.class_cli_every
        )),
        if a.kill_runs > 0 { format!(", {} kills of `sylva grow {}`", a.kill_runs, a.kill_what) } else { String::new() }
    );
    if a.keep {
        let dir = campaign_dir();
        let _ = std::fs::create_dir_all(&dir);
        for i in a.from..a.from + a.runs {
            let (t, origin, bytes, folder) = input_of(a.seed, i, &corpus);
            let p = dir.join(format!("run-{i}.{}", t.ext(&bytes)));
            let _ = std::fs::write(&p, &bytes);
            eprintln!(
                "readers run {i}: {} from {origin} ({} bytes{}) → {}",
                t.name(),
                bytes.len(),
                folder.map_or(String::new(), |f| format!(", folder {}", f.display())),
                p.display()
            );
        }
        for j in a.from..a.from + a.class_runs {
            let c = fuzz_support::case_of(a.seed, j);
            let d = dir.join(format!("class-{j}"));
            let _ = std::fs::remove_dir_all(&d);
            let built = classes::materialize(&c, &d);
            let _ = std::fs::write(d.join("sets.txt"), c.sets.join("\n"));
            eprintln!(
                "classes run {j}: {} ({}, {}), sets {:?} → {:?}",
                c.class.name(),
                c.target.name(),
                c.what,
                c.sets,
                built.map(|b| b.input)
            );
        }
    }
    let mut readers = Tally::default();
    let mut classes_t = Tally::default();
    let mut cli_t = Tally::default();
    let mut kill_t = Tally::default();
    std::thread::scope(|s| {
        let cli_job = a.cli.as_ref().map(|cli| {
            let (a2, corpus2) = (&a, &corpus);
            s.spawn(move || {
                let mut t = cli_lane(a2, cli, corpus2);
                t.merge(kill_lane(a2, cli), a2.slowest);
                t
            })
        });
        let mut jobs = Vec::new();
        for (lane, n) in [(Lane::Readers, a.runs), (Lane::Classes, a.class_runs)] {
            let chunk = n.div_ceil(a.jobs).max(1);
            let mut from = a.from;
            while from < a.from + n {
                let end = (from + chunk).min(a.from + n);
                let (a2, corpus2) = (&a, &corpus);
                jobs.push((lane, s.spawn(move || in_process(a2, lane, from, end, corpus2))));
                from = end;
                if (jobs.len() as u64).is_multiple_of(a.jobs) {
                    // At most `jobs` workers at once: wait for this batch.
                    for (lane, j) in jobs.drain(..) {
                        let t = j.join().expect("lane thread");
                        match lane {
                            Lane::Readers => readers.merge(t, a.slowest),
                            Lane::Classes => classes_t.merge(t, a.slowest),
                        }
                    }
                }
            }
        }
        for (lane, j) in jobs {
            let t = j.join().expect("lane thread");
            match lane {
                Lane::Readers => readers.merge(t, a.slowest),
                Lane::Classes => classes_t.merge(t, a.slowest),
            }
        }
        if let Some(j) = cli_job {
            let t = j.join().expect("cli thread");
            // The kill lane's rows are its own table.
            let (kill_rows, cli_rows): (Vec<_>, Vec<_>) =
                t.per_key.into_iter().partition(|(k, _)| k.starts_with("kill"));
            let (kill_f, cli_f): (Vec<_>, Vec<_>) =
                t.findings.into_iter().partition(|f| f.starts_with("kill"));
            cli_t = Tally {
                deep: 0,
                per_key: cli_rows.into_iter().collect(),
                findings: cli_f,
                slowest: t.slowest,
            };
            kill_t = Tally {
                deep: 0,
                per_key: kill_rows.into_iter().collect(),
                findings: kill_f,
                slowest: Vec::new(),
            };
        }
    });
    let secs = t0.elapsed().as_secs_f64();
    println!(
        "fuzz campaign, seed {}, readers {}..{}, classes {}..{}, {} s and {} GiB per run, {:.0} s",
        a.seed,
        a.from,
        a.from + a.runs,
        a.from,
        a.from + a.class_runs,
        a.timeout,
        a.mem_gb,
        secs
    );
    print_table("readers (in-process)", &readers, a.timeout);
    print_table("classes (in-process, issue 39 generators)", &classes_t, a.timeout);
    print_table("cli", &cli_t, a.timeout);
    print_table("kill (SIGTERM / SIGKILL during grow)", &kill_t, a.timeout);
    let mut all = Tally::default();
    all.merge(readers, a.slowest);
    all.merge(classes_t, a.slowest);
    all.merge(cli_t, a.slowest);
    let total_runs = all.total(RUNS) + kill_t.total(RUNS);
    println!();
    println!(
        "all lanes: {total_runs} runs; failures: {} panics, {} over {} s, {} aborts, {} leaving files, {} canary leaks, {} huge messages (kill lane: {} leaving files, {} over time)",
        all.total(PANIC),
        all.total(OVER),
        a.timeout,
        all.total(ABORT),
        all.total(LEFT),
        all.total(LEAK),
        all.total(HUGE),
        kill_t.total(LEFT),
        kill_t.total(OVER)
    );
    println!("slowest runs (inputs in {}):", campaign_dir().join("slowest").display());
    for (ms, lane, i, what) in &all.slowest {
        println!("  {ms} ms  {lane} {i}: {what}");
    }
    save_slowest(&a, &all, &corpus);
}
