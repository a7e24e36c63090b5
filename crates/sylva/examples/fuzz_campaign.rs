//! The fuzzing campaign of issue 27 (`docs/robustness.md`): mutated and generated inputs
//! for every reader, each run through the real readers under a wall-clock limit and an
//! address-space limit, counting panics, runs over the limit, aborts (allocation
//! failures and other crashes) and output files left behind by failing runs.
//!
//! ```text
//! cargo build --release -p sylva-cli
//! cargo run --release -p sylva --example fuzz_campaign -- --runs 10000 \
//!     --deep-every 10 --cli target/release/sylva --cli-every 25
//! ```
//!
//! Runs are numbered; run `i` draws its input from `Rng::new(seed · 1000003 + i)`, its
//! reader is `i mod 8` (L-system, recipe, `--set`, LST, `.str`, JSON, OBJ, glTF), so any
//! run can be replayed alone (`--from i --runs 1 --keep`, which keeps the input in
//! `target/fuzz-campaign/`). In-process runs execute in a worker process (this program
//! with `--worker`) under `setrlimit(RLIMIT_AS)`; the parent kills it when a run is over
//! the time limit and restarts it after the run, so a hang or an abort costs one run.
//! Every `--deep-every`-th run goes through the whole pipeline (`pipeline::grow`, the
//! export) instead of the reader and what it feeds; every `--cli-every`-th run also
//! spawns the CLI (`sylva grow`, `check` or `subdivide`) in a fresh folder under the
//! same limits and looks for files left behind when it fails.

#[path = "../tests/fuzz_support/mod.rs"]
mod fuzz_support;

use fuzz_support::{next_input, Depth, Rng, Target};
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

#[derive(Debug, Clone)]
struct Args {
    runs: u64,
    from: u64,
    seed: u64,
    timeout: u64,
    mem_gb: u64,
    deep_every: u64,
    cli: Option<PathBuf>,
    cli_every: u64,
    worker: bool,
    keep: bool,
    cpfg: usize,
}

fn args() -> Args {
    let mut a = Args {
        runs: 10_000,
        from: 0,
        seed: 27,
        timeout: 20,
        mem_gb: 6,
        deep_every: 10,
        cli: None,
        cli_every: 25,
        worker: false,
        keep: false,
        cpfg: 50,
    };
    let v: Vec<String> = std::env::args().skip(1).collect();
    let mut i = 0;
    while i < v.len() {
        let next = |i: usize| v.get(i + 1).cloned().unwrap_or_default();
        let num = |i: usize| next(i).parse::<u64>().unwrap_or_else(|_| panic!("{} needs a number", v[i]));
        match v[i].as_str() {
            "--runs" => a.runs = num(i),
            "--from" => a.from = num(i),
            "--seed" => a.seed = num(i),
            "--timeout" => a.timeout = num(i),
            "--mem-gb" => a.mem_gb = num(i),
            "--deep-every" => a.deep_every = num(i),
            "--cli-every" => a.cli_every = num(i),
            "--cpfg" => a.cpfg = num(i) as usize,
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
    a
}

fn input_of(seed: u64, i: u64, corpus: &fuzz_support::Corpus) -> (Target, String, Vec<u8>, Option<PathBuf>) {
    let t = Target::ALL[(i % Target::ALL.len() as u64) as usize];
    let mut rng = Rng::new(seed.wrapping_mul(1_000_003).wrapping_add(i));
    let (origin, bytes, folder) = next_input(&mut rng, corpus, t);
    (t, origin, bytes, folder)
}

fn limit_memory(gb: u64) {
    let bytes = gb.saturating_mul(1 << 30);
    let lim = libc::rlimit { rlim_cur: bytes, rlim_max: bytes };
    // SAFETY: setrlimit with a valid struct only changes this process's limits.
    unsafe {
        libc::setrlimit(libc::RLIMIT_AS, &lim);
    }
}

/// The worker: runs `from..from + runs` in-process, one line per event on stdout.
fn worker(a: &Args) {
    limit_memory(a.mem_gb);
    // Panics are counted from the result; keep their messages off the terminal.
    std::panic::set_hook(Box::new(|_| {}));
    let corpus = fuzz_support::corpus(a.cpfg);
    let out = std::io::stdout();
    let work = fuzz_support::scratch("campaign");
    for i in a.from..a.from + a.runs {
        let (t, _origin, bytes, folder) = input_of(a.seed, i, &corpus);
        // Every reader in turn goes deep: run i uses reader i mod 8.
        let deep = a.deep_every > 0 && (i / Target::ALL.len() as u64).is_multiple_of(a.deep_every);
        {
            let mut o = out.lock();
            let _ = writeln!(o, "BEGIN {i}");
            let _ = o.flush();
        }
        let t0 = Instant::now();
        let depth = if deep { Depth::Pipeline } else { Depth::Reader };
        let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            fuzz_support::run_input(t, &bytes, folder.as_deref(), &work, depth)
        }));
        // Output left behind by a failing run: the outputs, or a temporary file.
        let mut left = Vec::new();
        let failed = !matches!(r, Ok(Ok(_)));
        if let Ok(rd) = std::fs::read_dir(&work) {
            for e in rd.flatten() {
                let name = e.file_name().to_string_lossy().into_owned();
                if name.starts_with("out.") || name.contains(".tmp-") {
                    if failed {
                        left.push(name);
                    }
                    let _ = std::fs::remove_file(e.path());
                }
            }
        }
        let ms = t0.elapsed().as_millis();
        let (kind, msg) = match r {
            Ok(Ok(m)) => ("ok", m),
            Ok(Err(m)) => ("err", m),
            Err(p) => ("panic", fuzz_support::panic_message(&*p)),
        };
        let msg: String = msg.replace('\n', " ").chars().take(300).collect();
        let mut o = out.lock();
        let _ = writeln!(
            o,
            "END {i} {kind} {ms} {} {} {}",
            if deep { "deep" } else { "reader" },
            left.join(","),
            msg
        );
        let _ = o.flush();
    }
    let _ = std::fs::remove_dir_all(&work);
}

#[derive(Default, Debug)]
struct Tally {
    runs: u64,
    ok: u64,
    errors: u64,
    panics: u64,
    timeouts: u64,
    aborts: u64,
    leftovers: u64,
    deep: u64,
    slowest_ms: u128,
    per_target: std::collections::BTreeMap<&'static str, [u64; 6]>,
    findings: Vec<String>,
}

impl Tally {
    fn note(&mut self, t: Target, k: usize) {
        self.per_target.entry(t.name()).or_default()[k] += 1;
    }
}

fn spawn_worker(a: &Args, from: u64, runs: u64) -> (Child, mpsc::Receiver<String>) {
    let exe = std::env::current_exe().expect("own path");
    let mut child = Command::new(exe)
        .args([
            "--worker",
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

/// The in-process lane: runs every run in worker processes.
fn in_process(a: &Args, corpus: &fuzz_support::Corpus, tally: &mut Tally) {
    let end = a.from + a.runs;
    let mut next = a.from;
    let limit = Duration::from_secs(a.timeout);
    while next < end {
        let (mut child, rx) = spawn_worker(a, next, end - next);
        let mut current: Option<(u64, Instant)> = None;
        loop {
            let wait = match current {
                Some((_, t0)) => limit.saturating_sub(t0.elapsed()).max(Duration::from_millis(1)),
                None => limit,
            };
            match rx.recv_timeout(wait) {
                Ok(line) => {
                    let mut w = line.splitn(7, ' ');
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
                            let left = w.next().unwrap_or("");
                            let msg = w.next().unwrap_or("");
                            let (t, origin, ..) = input_of(a.seed, i, corpus);
                            tally.runs += 1;
                            tally.deep += u64::from(deep);
                            tally.slowest_ms = tally.slowest_ms.max(ms);
                            match kind {
                                "ok" => {
                                    tally.ok += 1;
                                    tally.note(t, 0);
                                }
                                "err" => {
                                    tally.errors += 1;
                                    tally.note(t, 1);
                                }
                                _ => {
                                    tally.panics += 1;
                                    tally.note(t, 2);
                                    tally
                                        .findings
                                        .push(format!("run {i} ({}, from {origin}): panic: {msg}", t.name()));
                                }
                            }
                            if !left.is_empty() {
                                tally.leftovers += 1;
                                tally.note(t, 5);
                                tally
                                    .findings
                                    .push(format!("run {i} ({}): failed and left {left}", t.name()));
                            }
                            if ms > limit.as_millis() {
                                tally.timeouts += 1;
                                tally.note(t, 3);
                                tally
                                    .findings
                                    .push(format!("run {i} ({}, from {origin}): {ms} ms", t.name()));
                            }
                            next = i + 1;
                            current = None;
                            if tally.runs.is_multiple_of(500) {
                                eprintln!("  {} runs: {:?}", tally.runs, short(tally));
                            }
                        }
                        _ => {}
                    }
                }
                Err(mpsc::RecvTimeoutError::Timeout) => {
                    if current.is_none() {
                        // No run started within the limit: making the input itself hung
                        // (a harness bug); skip it rather than wait forever.
                        let _ = child.kill();
                        let _ = child.wait();
                        tally
                            .findings
                            .push(format!("run {next}: the harness could not make its input in time"));
                        next += 1;
                        break;
                    }
                    if let Some((i, _)) = current {
                        let _ = child.kill();
                        let _ = child.wait();
                        let (t, origin, ..) = input_of(a.seed, i, corpus);
                        tally.runs += 1;
                        tally.timeouts += 1;
                        tally.note(t, 3);
                        tally.findings.push(format!(
                            "run {i} ({}, from {origin}): over {} s",
                            t.name(),
                            a.timeout
                        ));
                        next = i + 1;
                        break;
                    }
                }
                Err(mpsc::RecvTimeoutError::Disconnected) => {
                    let status = child.wait().ok();
                    if current.is_none() && next < end {
                        tally
                            .findings
                            .push(format!("run {next}: the harness died making its input ({status:?})"));
                        next += 1;
                    }
                    if let Some((i, _)) = current {
                        let (t, origin, ..) = input_of(a.seed, i, corpus);
                        tally.runs += 1;
                        tally.aborts += 1;
                        tally.note(t, 4);
                        tally.findings.push(format!(
                            "run {i} ({}, from {origin}): worker died ({status:?}: allocation failure or crash)",
                            t.name()
                        ));
                        next = i + 1;
                    }
                    break;
                }
            }
        }
        let _ = child.kill();
        let _ = child.wait();
    }
}

fn short(t: &Tally) -> String {
    format!(
        "ok {} errors {} panics {} timeouts {} aborts {} leftovers {}",
        t.ok, t.errors, t.panics, t.timeouts, t.aborts, t.leftovers
    )
}

/// The CLI lane: every `cli_every`-th run through the `sylva` binary.
fn cli_lane(a: &Args, cli: &Path, corpus: &fuzz_support::Corpus, tally: &mut Tally) {
    let base = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../target/fuzz-campaign");
    for i in (a.from..a.from + a.runs).filter(|i| a.cli_every > 0 && i % a.cli_every == 0) {
        let (t, origin, bytes, folder) = input_of(a.seed, i, corpus);
        let dir = base.join(format!("cli-{i}"));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("campaign folder");
        if let Some(f) = &folder {
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
        let input = dir.join(format!("input.{}", t.ext(&bytes)));
        let input_name = if t == Target::Json { dir.join("input.skel.json") } else { input.clone() };
        let mut cmd = Command::new(cli);
        cmd.current_dir(&dir).stdout(Stdio::null()).stderr(Stdio::null());
        match t {
            Target::Set => {
                let text = String::from_utf8_lossy(&bytes);
                let mut lines = text.lines();
                cmd.args([
                    "grow",
                    lines.next().unwrap_or("lsys-binary-tree"),
                    "-o",
                    "out.glb",
                    "--no-preview",
                    "-q",
                ]);
                for l in lines {
                    cmd.args(["--set", l]);
                }
            }
            Target::Obj if i % 2 == 0 => {
                std::fs::write(&input_name, &bytes).expect("write input");
                cmd.args(["subdivide", "input.obj", "-o", "out.obj", "-q"]);
            }
            Target::Obj | Target::Gltf => {
                std::fs::write(&input_name, &bytes).expect("write input");
                cmd.args(["check", input_name.file_name().and_then(|n| n.to_str()).unwrap_or("input")]);
            }
            _ => {
                std::fs::write(&input_name, &bytes).expect("write input");
                let name = input_name.file_name().and_then(|n| n.to_str()).unwrap_or("input").to_string();
                cmd.args(["grow", &name, "-o", "out.glb", "--no-preview", "-q"]);
            }
        }
        let gb = a.mem_gb;
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
        let before: Vec<String> = listing(&dir);
        let t0 = Instant::now();
        let mut child = match cmd.spawn() {
            Ok(c) => c,
            Err(e) => panic!("cannot run {}: {e}", cli.display()),
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
            std::thread::sleep(Duration::from_millis(10));
        };
        tally.runs += 1;
        let key = match t {
            Target::Set => "cli set",
            Target::Obj | Target::Gltf => "cli mesh",
            _ => "cli grow",
        };
        let slot = tally.per_target.entry(key).or_default();
        use std::os::unix::process::ExitStatusExt;
        match status {
            None => {
                slot[3] += 1;
                tally.timeouts += 1;
                tally.findings.push(format!(
                    "cli run {i} ({}, from {origin}): over {} s",
                    t.name(),
                    a.timeout
                ));
            }
            Some(s) if s.code() == Some(0) => {
                slot[0] += 1;
                tally.ok += 1;
            }
            Some(s) if s.code() == Some(1) || s.code() == Some(2) => {
                slot[1] += 1;
                tally.errors += 1;
            }
            Some(s) if s.code() == Some(101) => {
                slot[2] += 1;
                tally.panics += 1;
                tally.findings.push(format!("cli run {i} ({}, from {origin}): panic", t.name()));
            }
            Some(s) => {
                slot[4] += 1;
                tally.aborts += 1;
                tally.findings.push(format!(
                    "cli run {i} ({}, from {origin}): {:?} (signal {:?})",
                    t.name(),
                    s.code(),
                    s.signal()
                ));
            }
        }
        let failed = !matches!(status, Some(s) if s.code() == Some(0));
        if failed {
            let after = listing(&dir);
            let new: Vec<&String> = after.iter().filter(|f| !before.contains(f)).collect();
            if !new.is_empty() {
                tally.per_target.entry(key).or_default()[5] += 1;
                tally.leftovers += 1;
                tally.findings.push(format!("cli run {i} ({}): failed and left {new:?}", t.name()));
            }
        }
        if !a.keep {
            let _ = std::fs::remove_dir_all(&dir);
        }
    }
}

fn listing(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .into_iter()
        .flatten()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
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
        "fuzz campaign: runs {}..{}, seed {}, {} s and {} GiB per run, every {}th through the pipeline{}",
        a.from,
        a.from + a.runs,
        a.seed,
        a.timeout,
        a.mem_gb,
        a.deep_every,
        a.cli.as_ref().map_or(String::new(), |c| format!(
            ", every {}th also through {}",
            a.cli_every,
            c.display()
        ))
    );
    if a.keep {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../target/fuzz-campaign");
        let _ = std::fs::create_dir_all(&dir);
        for i in a.from..a.from + a.runs {
            let (t, origin, bytes, folder) = input_of(a.seed, i, &corpus);
            let p = dir.join(format!("run-{i}.{}", t.ext(&bytes)));
            let _ = std::fs::write(&p, &bytes);
            eprintln!(
                "run {i}: {} from {origin} ({} bytes{}) → {}",
                t.name(),
                bytes.len(),
                folder.map_or(String::new(), |f| format!(", folder {}", f.display())),
                p.display()
            );
        }
    }
    let mut tally = Tally::default();
    let mut cli_tally = Tally::default();
    std::thread::scope(|s| {
        if let Some(cli) = &a.cli {
            let (a2, corpus2, ct) = (&a, &corpus, &mut cli_tally);
            s.spawn(move || cli_lane(a2, cli, corpus2, ct));
        }
        in_process(&a, &corpus, &mut tally);
    });
    let secs = t0.elapsed().as_secs_f64();
    println!("fuzz campaign, seed {}, runs {}..{}, {:.0} s", a.seed, a.from, a.from + a.runs, secs);
    for (name, t) in [("in-process", &tally), ("cli", &cli_tally)] {
        if t.runs == 0 {
            continue;
        }
        println!(
            "{name}: {} runs ({} through the whole pipeline): {} ok, {} clean errors, {} panics, {} over {} s, {} aborts, {} failing runs leaving files; slowest {} ms",
            t.runs, t.deep, t.ok, t.errors, t.panics, t.timeouts, a.timeout, t.aborts, t.leftovers, t.slowest_ms
        );
        println!("  | reader | ok | errors | panics | over time | aborts | left files |");
        for (k, v) in &t.per_target {
            println!("  | {k} | {} | {} | {} | {} | {} | {} |", v[0], v[1], v[2], v[3], v[4], v[5]);
        }
        for f in &t.findings {
            println!("  {f}");
        }
    }
}
