//! The worker pools refinement runs on: a bounded count ([`MAX_THREADS`]), refused
//! before any thread starts when the count or the address-space limit cannot hold it
//! ([`ThreadsError`]), for a dedicated pool ([`with_threads`]) and rayon's global one
//! ([`start_global_threads`]). Robustness rules: docs/robustness.md.

/// The most worker threads a pool may have ([`with_threads`], `sylva subdivide
/// --threads`, `RAYON_NUM_THREADS` for [`start_global_threads`]). A fixed number, not one
/// derived from the machine, so a command that works on one machine is not refused on
/// another: far above the cores of any machine sylva runs on (the result is the same
/// for any count, so more threads than cores only cost memory), yet small enough that
/// the pool's stacks (2 MiB of address space each, 2 GiB for 1024) fit a 6 GB
/// address-space limit. Issue 39: 100,000 threads failed after 36 s with an error that
/// never named threads.
pub const MAX_THREADS: usize = 1024;

/// Why a pool of worker threads could not be started.
#[derive(Debug, thiserror::Error, miette::Diagnostic)]
pub enum ThreadsError {
    /// More threads were asked for than [`MAX_THREADS`]; nothing was started.
    #[error("{threads} worker threads: more than the limit of {MAX_THREADS} (use 1..={MAX_THREADS}; the output is the same for any count)")]
    TooMany {
        /// The count asked for.
        threads: usize,
    },
    /// The process's address-space limit (`ulimit -v`) leaves no room for the threads'
    /// stacks; checked before any thread starts, because a thread the system starts
    /// without room for its signal stack aborts the process (Rust's runtime cannot
    /// unwind from that).
    #[error("cannot start {threads} worker threads: with their stacks and malloc arenas they need about {need_mib} MiB of address space and the limit (ulimit -v) leaves {free_mib} MiB ({})", room_for(.fit))]
    AddressSpace {
        /// The count asked for.
        threads: usize,
        /// Address space the threads need (stacks and malloc arenas), in MiB.
        need_mib: u64,
        /// Address space left under the limit, in MiB.
        free_mib: u64,
        /// The most threads that fit (0: not even one).
        fit: usize,
    },
    /// The system refused to start the threads (too many processes, no memory).
    #[error("cannot start {threads} worker threads: {source} (use fewer)")]
    Start {
        /// The count asked for.
        threads: usize,
        /// Why.
        source: rayon::ThreadPoolBuildError,
    },
}

/// Runs `f` on a dedicated rayon pool of `threads` workers (refinement inside it uses that
/// many threads; the result is the same for any count). `0` counts as 1. More than
/// [`MAX_THREADS`] is [`ThreadsError::TooMany`], checked before any thread starts; a pool
/// the system cannot start is [`ThreadsError::Start`].
pub fn with_threads<R: Send>(threads: usize, f: impl FnOnce() -> R + Send) -> Result<R, ThreadsError> {
    let threads = threads.max(1);
    if threads > MAX_THREADS {
        return Err(ThreadsError::TooMany { threads });
    }
    check_address_space(threads)?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|source| ThreadsError::Start { threads, source })?;
    Ok(pool.install(f))
}

/// What to do when a pool does not fit: how many threads do, if any.
fn room_for(fit: &usize) -> String {
    match fit {
        0 => "room for none: raise the limit".into(),
        n => format!("room for at most {n}: use fewer threads, or raise the limit"),
    }
}

/// Address space one worker thread takes: its 2 MiB stack (Rust's default) with its
/// guard page, signal stack and thread-local storage, rounded up.
const THREAD_ADDRESS_SPACE: u64 = (2 << 20) + (256 << 10);

/// Address space kept free for the work itself once the threads are started.
const WORK_HEADROOM: u64 = 256 << 20;

/// Refuses `threads` workers when the address-space limit (`RLIMIT_AS`, `ulimit -v`)
/// minus what the process already maps leaves less than their stacks and
/// [`WORK_HEADROOM`]. Issue 39: under `ulimit -v 1500000`, 1024 threads started, and the
/// last ones aborted the process when their signal stacks could not be mapped.
fn check_address_space(threads: usize) -> Result<(), ThreadsError> {
    let Some(free) = free_address_space() else { return Ok(()) };
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let need = |n: usize| n as u64 * THREAD_ADDRESS_SPACE + arenas(n, cores) * ARENA_ADDRESS_SPACE;
    if need(threads) + WORK_HEADROOM <= free {
        return Ok(());
    }
    let fit = (1..threads).rev().find(|&n| need(n) + WORK_HEADROOM <= free).unwrap_or(0);
    Err(ThreadsError::AddressSpace { threads, need_mib: need(threads) >> 20, free_mib: free >> 20, fit })
}

/// Address space glibc reserves for each malloc arena a thread may create (64 MiB on
/// 64-bit systems: `HEAP_MAX_SIZE`).
const ARENA_ADDRESS_SPACE: u64 = 64 << 20;

/// The malloc arenas `threads` workers may add besides the main one: one per thread up
/// to glibc's default cap of 8 per core. Measured: under a 1.5 GB limit on 2 cores, 250
/// threads failed to start and 400 aborted, far sooner than their stacks alone explain.
fn arenas(threads: usize, cores: usize) -> u64 {
    threads.min(8 * cores).saturating_sub(1) as u64
}

/// Bytes of address space left under `RLIMIT_AS`, or `None` when there is no limit
/// (or it cannot be read). What the process maps now is read from `/proc/self/statm`
/// where there is one.
#[cfg(unix)]
fn free_address_space() -> Option<u64> {
    let mut lim = libc::rlimit { rlim_cur: 0, rlim_max: 0 };
    // SAFETY: getrlimit writes one rlimit into the struct it is given.
    if unsafe { libc::getrlimit(libc::RLIMIT_AS, &mut lim) } != 0 || lim.rlim_cur == libc::RLIM_INFINITY {
        return None;
    }
    let used = std::fs::read_to_string("/proc/self/statm")
        .ok()
        .and_then(|s| s.split_whitespace().next().and_then(|p| p.parse::<u64>().ok()))
        .map_or(0, |pages| pages * page_size());
    // rlim_t is u64 on Linux but not on every Unix.
    #[allow(clippy::unnecessary_cast)]
    let limit = lim.rlim_cur as u64;
    Some(limit.saturating_sub(used))
}

/// The system's page size in bytes (4096 where it cannot be read).
#[cfg(unix)]
fn page_size() -> u64 {
    // SAFETY: sysconf only reads a system constant.
    let p = unsafe { libc::sysconf(libc::_SC_PAGESIZE) };
    if p > 0 {
        p as u64
    } else {
        4096
    }
}

/// No address-space limit is read outside Unix.
#[cfg(not(unix))]
fn free_address_space() -> Option<u64> {
    None
}

/// Starts rayon's global pool now, so that a count it cannot start is an error rather
/// than a panic at its first use: the pool has `RAYON_NUM_THREADS` workers when that is
/// set to a number above 0 (at most [`MAX_THREADS`], else [`ThreadsError::TooMany`]
/// before any thread starts), else one per core. Call it once, before any parallel
/// work; a global pool that is already running is left as it is.
pub fn start_global_threads() -> Result<(), ThreadsError> {
    let asked = std::env::var("RAYON_NUM_THREADS").ok().and_then(|v| v.trim().parse::<u128>().ok());
    let asked = asked.map_or(0, |n| usize::try_from(n).unwrap_or(usize::MAX));
    if asked > MAX_THREADS {
        return Err(ThreadsError::TooMany { threads: asked });
    }
    let threads =
        if asked == 0 { std::thread::available_parallelism().map_or(1, |n| n.get()) } else { asked };
    check_address_space(threads)?;
    match rayon::ThreadPoolBuilder::new().build_global() {
        Ok(()) => Ok(()),
        // rayon says so only in words: a pool already running is not an error here.
        Err(e) if e.to_string().contains("already") => Ok(()),
        Err(source) => Err(ThreadsError::Start { threads, source }),
    }
}
